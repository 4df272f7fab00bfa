"""The objrec-patrol command: summary, events file, pictures, diagram, errors and Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import pytest

import navigation
from navigation.cli import main
from tests.signal_steps import signal_during, signal_once_working

DATA = Path(navigation.__file__).parent / "data"

POSES = str(DATA / "b5203.txt")
MAP = str(DATA / "b5203.yaml")


def summary_fields(text: str) -> dict[str, str]:
    return {k.strip(): v.strip() for k, v in (line.split(":", 1) for line in text.strip().splitlines())}


def test_one_lap_with_every_output(tmp_path, capsys):
    events, picture, diagram = tmp_path / "e.jsonl", tmp_path / "run.png", tmp_path / "machine.md"
    code = main([POSES, "--map", MAP, "--laps", "1", "--events", str(events), "--render", str(picture),
                 "--diagram", str(diagram)])
    out, err = capsys.readouterr()
    assert code == 0
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown"
    assert fields["final state"] == "SHUTDOWN"
    assert fields["laps"] == "1"
    assert fields["goals"] == "15 reached, 0 aborted, 0 preempted"
    assert fields["collisions"] == "0"
    assert 15.0 < float(fields["distance"].split()[0]) < 30.0
    assert fields["distance"].endswith("(odometry drifted 0.00 m)")
    assert err == ""

    lines = [json.loads(line) for line in events.read_text().splitlines()]
    assert lines[0] == {"t": 0.0, "type": "state_enter", "state": "MONITORED_PATROL"}
    assert [e["name"] for e in lines if e["type"] == "goal_sent"] == [f"POSE_{i}" for i in range(15)]
    assert lines[-1]["type"] == "outcome" and lines[-1]["outcome"] == "shutdown"
    assert all(isinstance(e["t"], float) for e in lines)
    times = [e["t"] for e in lines]
    assert times == sorted(times)
    assert any(e["type"] == "state_exit" for e in lines)

    img = cv2.imread(str(picture))
    assert img is not None and min(img.shape[:2]) >= 300
    text = diagram.read_text()
    assert text.startswith("```mermaid\nstateDiagram-v2\n")
    assert "SHUTDOWN : ACTIVE" in text and "class SHUTDOWN active" in text


def test_battery_low_docks_and_stops(tmp_path, capsys):
    events = tmp_path / "e.jsonl"
    code = main([POSES, "--map", MAP, "--robot-battery", "28.3", "--events", str(events)])
    out, _ = capsys.readouterr()
    assert code == 0
    assert summary_fields(out)["robot battery"] == "100.0 %"
    entered = [json.loads(line)["state"] for line in events.read_text().splitlines()
               if json.loads(line)["type"] == "state_enter"]
    assert entered[-5:] == ["DOCK_AT_STATION", "DOCK_AT_STATION.MOVE_TO_STATION", "DOCK_AT_STATION.DOCK",
                            "WAIT_UNTIL_CHARGED", "SHUTDOWN"]


def test_time_limit_and_no_station(capsys):
    code = main([POSES, "--map", MAP, "--time-limit", "30", "--no-station", "--start", "14.4", "12.8", "0"])
    out, _ = capsys.readouterr()
    assert code == 0
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown (time limit)"
    assert fields["simulated time"].startswith("0:00:30 (30.1 s)")


def _run_cli(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "navigation", *args], capture_output=True, text=True,
                          timeout=timeout, check=False)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["MISSING.txt", "--map", MAP], "MISSING.txt: pose file not found"),
        ([POSES, "--map", "nowhere.yaml"], "nowhere.yaml: map file not found"),
        ([POSES, "--map", MAP, "--start", "12.7", "12.2", "0"], "inside an obstacle"),
    ],
)
def test_bad_input_is_one_error_line_and_exit_2(args, needle, capsys):
    assert main(args) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("objrec-patrol: error: ") and needle in err


def test_bad_pose_line_via_the_module_entry_point(tmp_path):
    poses = tmp_path / "poses.txt"
    poses.write_text("# goals\n1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0\n3.0, four, 0, 0, 0, 0, 1\n")
    result = _run_cli(str(poses), "--map", MAP)
    assert result.returncode == 2
    assert result.stdout == ""
    assert result.stderr == f"objrec-patrol: error: {poses}:3: goals[1].y: 'four' is invalid: expected a number\n"


@pytest.mark.realdata
def test_invalid_map_image_via_the_module_entry_point(shared_data):
    yaml_path = shared_data / "maps/nav2_testmap/invalid_image.yaml"
    result = _run_cli(POSES, "--map", str(yaml_path))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and str(yaml_path) in lines[0] and "invalid.png" in lines[0]


def test_render_extension_is_checked(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([POSES, "--map", MAP, "--render", "out.tiff"])
    assert exit_info.value.code == 2
    assert "--render out.tiff: the extension must be one of" in capsys.readouterr().err


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_on_a_realtime_run_shuts_down_cleanly(tmp_path, sig):
    """Real Ctrl-C or SIGTERM on a real-time run: the patrol is preempted, SHUTDOWN entered, summary printed."""
    events = tmp_path / "e.jsonl"
    started = time.monotonic()
    code, out, err = signal_once_working(
        [sys.executable, "-m", "navigation", POSES, "--map", MAP, "--realtime", "--events", str(events)],
        lambda: events.exists() and events.stat().st_size > 0, sig, after=1.5)
    ran = time.monotonic() - started
    assert code == 0, err
    assert "Traceback" not in err
    fields = summary_fields(out)
    assert fields["outcome"] == f"shutdown ({sig.name})" and fields["final state"] == "SHUTDOWN"
    sim_seconds = float(fields["simulated time"].split("(")[1].split()[0])
    # real time never runs ahead of the clock (a fast-forward run would be hundreds of seconds), and it ran
    # for at least most of the 1.5 s before the signal: a relation to the measured run, not a speed limit
    assert 1.0 <= sim_seconds <= ran
    kinds = [json.loads(line) for line in Path(events).read_text().splitlines()]
    assert kinds[-1] == {"t": kinds[-1]["t"], "type": "outcome", "outcome": "shutdown"}
    assert any(e["type"] == "state_enter" and e["state"] == "SHUTDOWN" for e in kinds)
    assert any(e["type"] == "preempt_requested" and e["reason"] == sig.name for e in kinds)


def test_help_runs_as_a_module():
    result = _run_cli("--help")
    assert result.returncode == 0
    assert "POSES_FILE" in result.stdout and "--realtime" in result.stdout
    assert os.linesep in result.stdout


@pytest.mark.parametrize("option", ["--events", "--diagram", "--render"])
def test_unwritable_output_is_an_error_not_a_traceback(tmp_path, option, capsys):
    (tmp_path / "a_file").write_text("not a folder")
    target = tmp_path / "a_file" / "dir" / "out.png"  # a folder cannot be made under a regular file
    assert main([POSES, "--map", MAP, "--laps", "1", option, str(target)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("objrec-patrol: error: ") and "out.png" in err and err.count("\n") == 1
    assert (tmp_path / "a_file").read_text() == "not a folder"


def test_missing_parent_folders_of_outputs_are_made(tmp_path, capsys):
    out = tmp_path / "no" / "such"
    assert main([POSES, "--map", MAP, "--laps", "1", "--events", str(out / "e" / "events.jsonl"),
                 "--diagram", str(out / "d" / "machine.md"), "--render", str(out / "r" / "run.png")]) == 0
    assert (out / "e" / "events.jsonl").stat().st_size > 0
    assert "SHUTDOWN" in (out / "d" / "machine.md").read_text()
    assert (out / "r" / "run.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_during_start_up_still_writes_the_events_and_summary(tmp_path, capsys, monkeypatch, sig):
    """A real signal while the map loads: the patrol starts preempted and ends in SHUTDOWN, files written, and
    the signal's handling is given back."""
    import navigation.cli as cli

    signal_during(monkeypatch, cli, "load_map", sig)
    before = signal.getsignal(sig)
    events = tmp_path / "e.jsonl"
    assert main([POSES, "--map", MAP, "--events", str(events)]) == 0
    fields = summary_fields(capsys.readouterr().out)
    assert fields["outcome"] == f"shutdown ({sig.name})"
    assert fields["final state"] == "SHUTDOWN"
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    assert lines[0] == {"t": 0.0, "type": "preempt_requested", "reason": sig.name}
    assert lines[-1] == {"t": lines[-1]["t"], "type": "outcome", "outcome": "shutdown"}
    assert lines[-1]["t"] < 1.0
    assert signal.getsignal(sig) is before
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
