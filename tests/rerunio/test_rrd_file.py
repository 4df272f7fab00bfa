"""rerunio's .rrd files: written under a hidden temporary name and renamed when the recording closes
whole; removed when writing fails; a disk that cannot take the first bytes is refused before rerun's own writer
starts (that writer could wait for ever inside native code); what must stay as it is stays."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rerun")

from rerunio import Recorder, RerunUnavailable, open_stream
from rerunio.rrd_file import PROBE_BYTES


def temporaries(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir() if ".saving-" in p.name]


def test_the_file_appears_whole_at_close_and_verifies(tmp_path: Path) -> None:
    import rerun as rr

    target = tmp_path / "run.rrd"
    recorder = Recorder(open_stream(target, "objrec-test"))
    recorder.recording.log("points", rr.Points3D([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]))
    recorder.step_logged()
    assert not target.exists() and len(temporaries(tmp_path)) == 1  # a viewer never opens half a recording
    recorder.close()
    assert target.is_file() and temporaries(tmp_path) == []
    verify = Path(sys.executable).with_name("rerun")
    if verify.exists():
        result = subprocess.run([str(verify), "rrd", "verify", str(target)], capture_output=True, text=True,
                                timeout=300, check=False)
        assert result.returncode == 0, result.stderr


def test_a_link_keeps_pointing_at_the_recording(tmp_path: Path) -> None:
    (tmp_path / "real.rrd").write_bytes(b"old")
    os.symlink("real.rrd", tmp_path / "link.rrd")
    Recorder(open_stream(tmp_path / "link.rrd", "objrec-test")).close()
    assert (tmp_path / "link.rrd").is_symlink() and (tmp_path / "real.rrd").stat().st_size > 3


@pytest.mark.parametrize("kind", ["fifo", "read-only", "folder"])
def test_what_must_stay_is_refused_before_anything_is_written(tmp_path: Path, kind: str) -> None:
    target = tmp_path / "run.rrd"
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "read-only":
        target.write_bytes(b"keep")
        target.chmod(0o444)
    else:
        target.mkdir()
    with pytest.raises(RerunUnavailable, match=r"run\.rrd: cannot save"):
        open_stream(target, "objrec-test")
    assert temporaries(tmp_path) == []
    if kind == "read-only":
        assert target.read_bytes() == b"keep"


def test_a_disk_that_cannot_take_the_first_bytes_is_refused_at_once(tmp_path: Path) -> None:
    """In a child with a file size limit under PROBE_BYTES: one RerunUnavailable, no file, no hang."""
    code = ("import resource, signal\n"
            "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
            f"resource.setrlimit(resource.RLIMIT_FSIZE, ({PROBE_BYTES // 2}, {PROBE_BYTES // 2}))\n"
            "from rerunio import RerunUnavailable, open_stream\n"
            "try:\n    open_stream('run.rrd', 'objrec-test')\n"
            "except RerunUnavailable as exc:\n    print(exc)\n")
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                            check=False)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "run.rrd: cannot be written: File too large; nothing was kept"
    assert list(tmp_path.iterdir()) == []
