"""objrec-tune: from deliberately bad colour thresholds to F1 >= 0.95 on held-out demo frames within 200 trials;
one seed gives one file, byte for byte; --fix keeps a value; an output never replaces an input; every mistake is
one line and exit code 2."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from objrec_apps.tune import main
from objrec_core import build_system, get_kind, open_source
from objrec_core.evaluation import TruthSet, score

pytest.importorskip("optuna")

BAD_PARAMS = """\
format_version: 1
object_name: coloured_object
kind: 2d
description: The colour demo, its hue range on a colour no demo object has.
pipeline:
- type: HSVFilter
  id: colour
  parameters: {h_min: 140, h_max: 160, s_min: 10, s_max: 255, v_min: 0, v_max: 255}
- type: MorphologyFilter
  id: open
  parameters: {operation: open, iterations: 1, kernel_size: 3, kernel_shape: rect}
- type: BinaryDetector
  id: blobs
  parameters: {min_contour_length: 40.0, max_contour_length: 5000.0}
"""
SOURCE = "demo:frames=40"


@pytest.fixture
def bad_params(tmp_path: Path) -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text(BAD_PARAMS)
    return path


def run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's refusal of an option (one line, exit 2)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def f1_on(system, spec: str) -> float:
    """The system's F1 on frames it was never tuned on, scored the way objrec-eval scores."""
    kind = get_kind("2d")
    with open_source(spec, "2d") as source:
        frames = [(frame, kind.frame_truth(frame)) for frame in source]
    return score(system, kind, frames).score


@pytest.mark.slow
def test_bad_thresholds_tune_to_f1_095_on_held_out_frames(capsys, tmp_path, bad_params):
    out = tmp_path / "tuned.yaml"
    assert f1_on(build_system(bad_params), "demo:seed=5,frames=30") < 0.1
    code, stdout, stderr = run(capsys, bad_params, "--source", SOURCE, "--trials", 200, "--out", out)
    assert code == 0, stderr
    held = float(re.search(r"held-out score (\d\.\d+) on 12 frames", stdout).group(1))
    assert held >= 0.95
    bests = [(int(t), float(b)) for t, b in re.findall(r"trial (\d+)/200: .*best (\d\.\d+) \(new best\)", stderr)]
    first = next(t for t, b in bests if b >= 0.95)
    print(f"objrec-tune reached F1 >= 0.95 on the searched frames at trial {first} of 200; held-out F1 {held:.3f}")
    assert first <= 200
    tuned = build_system(out)
    assert "Tuned by objrec-tune on demo:frames=40 with its own truth: 200 trials" in \
        tuned.description
    assert f"held-out score {held:.3f} on 12 frames" in tuned.description
    assert tuned.description.startswith("The colour demo, its hue range")
    assert f1_on(tuned, "demo:seed=5,frames=30") >= 0.9  # another scene: the tuned thresholds carry over
    assert "parameter" in stdout and "importance" in stdout and "colour.h_max" in stdout


def test_one_seed_gives_one_file_byte_for_byte(capsys, tmp_path, bad_params):
    files = []
    for name in ("a.yaml", "b.yaml"):
        code, _, stderr = run(capsys, bad_params, "--source", SOURCE, "--trials", 15, "--seed", 4, "--out",
                              tmp_path / name)
        assert code == 0, stderr
        files.append((tmp_path / name).read_bytes())
    assert files[0] == files[1]
    code, _, _ = run(capsys, bad_params, "--source", SOURCE, "--trials", 15, "--seed", 5, "--out",
                     tmp_path / "c.yaml")
    assert code == 0 and (tmp_path / "c.yaml").read_bytes() != files[0]


def test_fix_keeps_the_files_values(capsys, tmp_path, bad_params):
    out = tmp_path / "tuned.yaml"
    code, stdout, stderr = run(capsys, bad_params, "--source", SOURCE, "--trials", 12, "--out", out,
                               "--fix", "colour.h_min", "blobs")
    assert code == 0, stderr
    tuned = build_system(out)
    assert tuned.module("colour").h_min == 140
    assert tuned.module("blobs").get_parameters() == build_system(bad_params).module("blobs").get_parameters()
    assert "colour.h_min" not in stdout and "blobs." not in stdout.split("\n", 2)[2]


def test_a_label_file_and_a_held_out_share(capsys, tmp_path, bad_params):
    kind = get_kind("2d")
    with open_source("demo:frames=20", "2d") as source:
        labels = [kind.frame_truth(frame) for frame in source]
    truth_path = tmp_path / "labels.json"
    kind.write_truth(truth_path, TruthSet("2d", labels, "index"))
    out = tmp_path / "tuned.yaml"
    code, stdout, stderr = run(capsys, bad_params, "--source", "demo:frames=20", "--truth", truth_path,
                               "--trials", 8, "--held-out", 0.5, "--out", out)
    assert code == 0, stderr
    assert "on 10 frames (" in stdout and "on 10 searched frames" in stdout
    assert f"with the labels {truth_path}" in build_system(out).description
    assert "20 labelled frames; 8 trials, seed 0, held-out share 0.5" in stderr


@pytest.mark.parametrize(("extra", "message"), [
    (["--fix", "colour.hue"], r"--fix 'colour\.hue': no such module parameter \(MODULE_ID\.PARAMETER; known: "),
    (["--search", "nothing"], r"--search 'nothing': no such module parameter"),
    (["--held-out", "1"], r"--held-out 1(\.0)?: must be below 1"),
    (["--held-out", "nan"], r"--held-out: nan is not a finite number"),
    (["--fix", "colour", "open", "blobs"], r"nothing to search: every parameter is fixed"),
    (["--out", "no-such-folder/t.yaml"], r"--out no-such-folder/t\.yaml: the folder no-such-folder does not exist"),
])
def test_mistakes_are_one_line_and_exit_2(capsys, tmp_path, bad_params, extra, message):
    code, stdout, stderr = run(capsys, bad_params, "--source", "demo:frames=6", "--trials", 3, "--out",
                               tmp_path / "t.yaml", *extra)
    assert code == 2 and stdout == ""
    assert stderr.count("\n") == 1 and stderr.startswith("objrec-tune: error: ")
    assert re.search(message, stderr), stderr
    assert not (tmp_path / "t.yaml").exists()


def test_the_output_may_not_replace_an_input(capsys, tmp_path, bad_params):
    before = bad_params.read_bytes()
    code, stdout, stderr = run(capsys, bad_params, "--source", "demo:frames=6", "--trials", 3, "--out", bad_params)
    assert code == 2 and stdout == ""
    assert stderr == (f"objrec-tune: error: --out {bad_params}: is the parameter file; write the tuned file "
                      "elsewhere (an output never replaces an input)\n")
    assert bad_params.read_bytes() == before


def test_an_endless_source_needs_a_frame_count(capsys, tmp_path, bad_params):
    code, _, stderr = run(capsys, bad_params, "--source", "demo", "--trials", 3, "--out", tmp_path / "t.yaml")
    assert code == 2 and "--source demo: has no end: give --max-frames N" in stderr


def test_without_the_extra_one_line_says_what_to_install(capsys, monkeypatch, tmp_path, bad_params):
    monkeypatch.setitem(sys.modules, "optuna", None)
    code, stdout, stderr = run(capsys, bad_params, "--source", "demo:frames=6", "--trials", 3, "--out",
                               tmp_path / "t.yaml")
    assert (code, stdout) == (2, "")
    assert stderr == "objrec-tune: error: objrec-tune needs the tune extra: pip install 'objrec[tune]'\n"


def test_ctrl_c_keeps_the_best_so_far(tmp_path, bad_params):
    """Ctrl-C during the search: the trial under way is dropped, the best so far scored on the held-out frames
    and written, exit code 130."""
    import signal
    import subprocess

    out = tmp_path / "tuned.yaml"
    child = subprocess.Popen([sys.executable, "-m", "objrec_apps.tune", str(bad_params), "--source", SOURCE,
                              "--trials", "100000", "--out", str(out)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        for line in child.stderr:
            lines.append(line)
            if "trial 1/100000" in line:
                child.send_signal(signal.SIGINT)
                break
        stdout, rest = child.communicate(timeout=300)  # a hang guard only
    finally:
        if child.poll() is None:
            child.kill()
    stderr = "".join(lines) + rest
    assert child.returncode == 130, stderr
    finished = int(re.search(r"interrupted after (\d+) trials: the best so far is in ", stderr).group(1))
    assert 1 <= finished < 100000
    assert f"best of {finished} trials" in stdout and "held-out score" in stdout
    assert f"{finished} trials (best: trial" in build_system(out).description
    assert "stopped early" in build_system(out).description
