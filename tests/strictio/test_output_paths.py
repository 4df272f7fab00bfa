"""strictio.output_paths: the one rule for where a run may write, judged before anything is written."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from strictio import OutputError
from strictio.output_paths import RunFiles, is_open_descriptor


@pytest.fixture
def run_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> RunFiles:
    (tmp_path / "params.yaml").write_text("a: 1\n", encoding="utf-8")
    (tmp_path / "frames").mkdir()
    (tmp_path / "frames" / "frame_000000.png").write_bytes(b"png")
    monkeypatch.chdir(tmp_path)  # given back afterwards: later tests name files relative to the project
    return RunFiles().reads("params.yaml", "the parameter file").reads("frames", "the source")


def refusal(files: RunFiles, option: str, path: str, **how: object) -> str:
    with pytest.raises(OutputError) as caught:
        files.writes(option, path, **how)  # type: ignore[arg-type]
    line = str(caught.value)
    assert "\n" not in line and f"refused as {option}" in line and line.endswith("nothing was written")
    assert line.startswith(f"{path}: ")
    return line


def test_an_input_by_path_link_or_hard_link_is_refused(run_files: RunFiles, tmp_path: Path) -> None:
    assert "it is the parameter file of this run" in refusal(run_files, "--output", "params.yaml")
    os.symlink("params.yaml", tmp_path / "soft.yaml")
    os.link(tmp_path / "params.yaml", tmp_path / "hard.yaml")
    assert "(the same file as params.yaml)" in refusal(run_files, "--output", "soft.yaml")
    assert "(the same file as params.yaml)" in refusal(run_files, "--explain", "hard.yaml")
    assert "a file of the source (frames)" in refusal(run_files, "--output", "frames/frame_000000.png")


def test_an_input_folder_and_what_lies_in_it_are_refused(run_files: RunFiles) -> None:
    assert "it is the source of this run" in refusal(run_files, "--annotate", "frames", folder=True)
    assert "lies inside the source frames" in refusal(run_files, "--output", "frames/new.jsonl")


def test_a_folder_output_holding_an_input_it_would_write_over(run_files: RunFiles, tmp_path: Path) -> None:
    line = refusal(run_files, "--out", ".", folder=True, names="*.yaml")
    assert "it holds the parameter file params.yaml" in line
    run_files.writes("--annotate", ".", folder=True, names="frame_*.png")  # writes nothing of the same name
    RunFiles().reads("params.yaml").writes("--out", ".", folder=True, names=None)  # each file judged on its own


def test_read_only_by_the_mode_bits_even_as_root(run_files: RunFiles, tmp_path: Path) -> None:
    (tmp_path / "kept.jsonl").write_text("x\n", encoding="utf-8")
    os.chmod(tmp_path / "kept.jsonl", 0o444)
    assert "the file is read-only" in refusal(run_files, "--output", "kept.jsonl")
    (tmp_path / "locked").mkdir()
    os.chmod(tmp_path / "locked", 0o555)
    try:
        assert "is read-only" in refusal(run_files, "--output", "locked/new.jsonl")
        assert "the folder is read-only" in refusal(run_files, "--annotate", "locked", folder=True)
    finally:
        os.chmod(tmp_path / "locked", 0o755)


def test_fifos_sockets_and_devices(run_files: RunFiles, tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe")
    assert "a FIFO (named pipe)" in refusal(run_files, "--rerun", "pipe")
    assert "a FIFO (named pipe)" in refusal(run_files, "--events", "pipe", stream=True)
    assert "a character device" in refusal(run_files, "--rerun", os.devnull)
    run_files.writes("--output", os.devnull, stream=True)  # a stream of lines may go to /dev/null
    assert "a folder" in refusal(run_files, "--diagram", str(tmp_path))
    (tmp_path / "file").write_text("", encoding="utf-8")
    assert "a file, not a folder" in refusal(run_files, "--annotate", "file", folder=True)


def test_a_link_out_of_its_folder(run_files: RunFiles, tmp_path: Path) -> None:
    (tmp_path / "out").mkdir()
    (tmp_path / "victim.md").write_text("mine\n", encoding="utf-8")
    os.symlink("../victim.md", tmp_path / "out" / "report.md")
    line = refusal(run_files, "report.md in --out", "out/report.md", inside="out")
    assert "leaves the folder out it belongs to" in line
    run_files.writes("events.jsonl in --out", "out/events.jsonl", inside="out")


def test_two_outputs_on_one_path(run_files: RunFiles) -> None:
    run_files.writes("--output", "a.jsonl")
    assert "it is also where --output goes" in refusal(run_files, "--explain", "./a.jsonl")


def test_what_is_not_judged(run_files: RunFiles) -> None:
    for path in (None, "", "-"):
        run_files.writes("--output", path)
    assert is_open_descriptor("/dev/stderr")
    run_files.writes("--explain", "/dev/stderr", stream=True)
    assert run_files.inputs == ["params.yaml", "frames"]
    assert RunFiles().reads("missing.yaml").reads(None).inputs == []
