"""Hostile command lines for objrec-detect, -batch, -inspect and -define: every number checked like a declared
parameter (one line, exit code 2, no traceback, fast), bad OBJREC_MAX_* variables, refusals and write failures
in the middle of a run (exit code 2, what was written kept), and Ctrl-C while a command is still importing."""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec_apps import detect, launch
from strictio import InputError
from strictio.cli_numbers import CommandLineParser, Number, NumberError, fields, one_line
from tests.hostile import harness

#: Each command's console script, as the entry point it runs (objrec_apps.launch).
SCRIPT = "import sys; from objrec_apps.launch import {0}; sys.exit({0}())"
PARAMS = "params/hsv_demo.yaml"


def command(name: str, *args: str, cwd: Path, env: dict[str, str] | None = None,
            preexec: Callable[[], None] | None = None) -> tuple[subprocess.CompletedProcess[str], float]:
    """Run a command's console-script entry point in a child (tests/hostile/harness.py): what it did, and the CPU
    seconds it took (wall-clock is only the harness's hang guard)."""
    run = harness.run([sys.executable, "-c", SCRIPT.format(name), *args], cwd, env=harness.child_env(env),
                      preexec=preexec, watch_files=False)
    return run.completed(), run.cpu_seconds


def assert_one_error_line(result: subprocess.CompletedProcess[str], cpu_seconds: float, prefix: str) -> None:
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1 and result.stderr.startswith(prefix), result.stderr
    assert result.stdout == ""
    assert cpu_seconds < harness.CPU_SECONDS_LIMIT


# -- the declared numbers themselves ------------------------------------------------------------------------------
@pytest.mark.parametrize(("number", "text", "value"), [
    (Number(0, 1), " 0.25 ", 0.25),
    (Number(0, 1), "1", 1.0),
    (Number(1, 10, whole=True), "2.0", 2),
    (Number(1, 10, whole=True), "1e1", 10),
    (Number(0, above=True), "1e-300", 1e-300),
])
def test_numbers_in_range_are_read(number, text, value):
    parsed = number.parse(text)
    assert parsed == value and type(parsed) is type(value)


@pytest.mark.parametrize(("number", "text", "message"), [
    (Number(0, 1), "nan", "nan is not a finite number"),
    (Number(0, 1), "-Infinity", "-Infinity is not a finite number"),
    (Number(), "1e400", "1e400 is not a finite number"),
    (Number(0, 1), "1e400", "1e400 is above the maximum 1"),
    (Number(0, 1), "-1", "-1 is below the minimum 0"),
    (Number(0, above=True), "0", "0 is not above 0"),
    (Number(0, above=True), "-0.0", "-0.0 is not above 0"),
    (Number(0, 1), "1_000", "'1_000' is not a number"),
    (Number(0, 1), "", "'' is not a number"),
    (Number(1, 10, whole=True), "2.5", "2.5 is not a whole number"),
    (Number(1, 10, whole=True), "0x10", "'0x10' is not a whole number"),
    (Number(0, 2**32 - 1, whole=True), "9" * 5000, "is above the maximum 4294967295"),
    (Number(0, 1), "a\nb\x1b[31m", r"'a\nb\x1b[31m' is not a number"),
])
def test_numbers_out_of_range_say_why(number, text, message):
    with pytest.raises(NumberError) as refused:
        number.parse(text)
    assert message in str(refused.value)
    assert "\n" not in str(refused.value) and "\x1b" not in str(refused.value)
    assert len(str(refused.value)) < 120


def test_argparse_messages_take_the_one_line_shape(capsys):
    parser = CommandLineParser(prog="prog")
    parser.add_argument("--max-frames", "-n", type=Number(1, 10, whole=True))
    parser.add_argument("--start", nargs=3, action=fields(Number(-5, 5), Number(-5, 5), Number(-1, 1)),
                        metavar=("X", "Y", "YAW"))
    parser.add_argument("--shift", nargs=3, action=fields(None, Number(-5, 5), Number(-5, 5), append=True),
                        metavar=("NAME", "DX", "DY"), default=[])
    for args, expected in [
        (["-n", "-1e5"], "prog: error: --max-frames: -1e5 is below the minimum 1\n"),
        (["--start", "-inf", "0", "0"], "prog: error: --start: X: -inf is not a finite number\n"),
        (["--start", "0", "0", "2"], "prog: error: --start: YAW: 2 is above the maximum 1\n"),
        (["--shift", "box", "1", "nan"], "prog: error: --shift: DY: nan is not a finite number\n"),
        (["--what\nnext"], "prog: error: unrecognized arguments: --what\\nnext\n"),
    ]:
        with pytest.raises(SystemExit) as ended:
            parser.parse_args(args)
        assert ended.value.code == 2
        assert capsys.readouterr().err == expected
    args = parser.parse_args(["--shift", "a", "1", "2", "--shift", "b", "-1", "0", "--start", "1", "2", "0.5"])
    assert args.shift == [["a", 1.0, 2.0], ["b", -1.0, 0.0]] and args.start == [1.0, 2.0, 0.5]
    assert one_line("argument -v/--verbose: x") == "--verbose: x"


# -- every command's numbers, as the user meets them ---------------------------------------------------------------
@pytest.mark.parametrize(("name", "args", "message"), [
    ("detect", [PARAMS, "-s", "demo", "-n", "0"], "--max-frames: 0 is below the minimum 1"),
    ("detect", [PARAMS, "-s", "demo", "--max-frames", "nan"], "--max-frames: nan is not a finite number"),
    ("detect", [PARAMS, "-s", "demo", "-n", "2.5"], "--max-frames: 2.5 is not a whole number"),
    ("detect", [PARAMS, "-s", "demo", "-n", "1e12"], "--max-frames: 1e12 is above the maximum 1000000000"),
    ("batch", [PARAMS, "demo", "--out", "x", "-w", "0"], "--workers: 0 is below the minimum 1"),
    ("batch", [PARAMS, "demo", "--out", "x", "-w", "100000"], "--workers: 100000 is above the maximum 256"),
    ("batch", [PARAMS, "demo", "--out", "x", "-n", "inf"], "--max-frames: inf is not a finite number"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--seed", "-1"], "--seed: -1 is below the minimum 0"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--dt", "0.0001"], "--dt: 0.0001 is below the minimum 0.01"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--odom-noise", "nan"],
     "--odom-noise: nan is not a finite number"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--start", "0", "nan", "0"],
     "--start: Y: nan is not a finite number"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--shift", "box", "1", "inf"],
     "--shift: DY: inf is not a finite number"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--laps", "0"], "--laps: 0 is below the minimum 1"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--time-limit", "-5"], "--time-limit: -5 is not above 0"),
    ("define", ["--view", "tabs\x1b[2J"], r"--view: invalid choice: 'tabs\x1b[2J'"),
    ("detect", ["new\nline.yaml", "-s", "demo"], r"new\nline.yaml"),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--out", "/dev/null/\x1b[31mred"], r"\x1b[31mred"),
])
def test_command_line_numbers_are_refused_in_one_line(project_root, name, args, message):
    result, cpu = command(name, *args, cwd=project_root)
    assert_one_error_line(result, cpu, f"objrec-{name}: error: ")
    assert message in result.stderr


@pytest.mark.parametrize(("name", "args"), [
    ("detect", [PARAMS, "-s", "demo", "-n", "1"]),
    ("batch", [PARAMS, "demo:frames=1", "--out", "OUT"]),
    ("inspect", ["examples/inspection_lab/mission.yaml", "--map", "examples/inspection_lab/lab.yaml", "--world",
                 "examples/inspection_lab/lab.world.yaml", "--out", "OUT"]),
    ("define", ["hsv"]),
])
def test_a_bad_limit_variable_is_refused_before_any_work(project_root, tmp_path, name, args):
    args = [str(tmp_path / "out") if a == "OUT" else a for a in args]
    result, cpu = command(name, *args, cwd=project_root, env={"OBJREC_MAX_IMAGE_PIXELS": "lots\n"})
    assert_one_error_line(result, cpu, f"objrec-{name}: error: environment variable OBJREC_MAX_IMAGE_PIXELS: ")
    assert r"'lots\n' is not a whole number of pixels" in result.stderr
    assert not (tmp_path / "out").exists()


# -- refusals and write failures in the middle of a run ------------------------------------------------------------
class _RefusesAt:
    """A source that gives ``good`` frames of the real one, then refuses its input as a reader would."""

    def __init__(self, source, good: int) -> None:
        self._source, self._good = source, good

    def __getattr__(self, name):
        return getattr(self._source, name)

    def __iter__(self):
        for count, frame in enumerate(self._source):
            if count == self._good:
                raise InputError("frames/3.png", "60,000 x 60,000 pixels, over the limit", "header")
            yield frame


def test_an_input_refused_mid_run_is_exit_2_and_keeps_what_was_written(project_root, tmp_path, monkeypatch,
                                                                      capsys):
    real_open = detect.open_source
    monkeypatch.setattr(detect, "open_source", lambda spec, kind: _RefusesAt(real_open(spec, kind), 3))
    out = tmp_path / "objects.jsonl"
    code = detect.main([str(project_root / PARAMS), "-s", "demo", "-n", "10", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err == "objrec-detect: error: frames/3.png: header: 60,000 x 60,000 pixels, over the limit\n"
    lines = out.read_text().splitlines()
    assert [json.loads(line)["header"]["seq"] for line in lines] == [0, 1, 2]


def _grey_frames(folder: Path, count: int) -> Path:
    folder.mkdir()
    for i in range(count):
        cv2.imwrite(str(folder / f"{i:03d}.png"), np.full((48, 64, 3), 128, np.uint8))
    return folder


def test_explain_file_failing_after_some_lines_is_exit_2(project_root, tmp_path):
    frames = _grey_frames(tmp_path / "frames", 40)
    reasons = tmp_path / "reasons.jsonl"
    result, cpu_seconds = command("detect", PARAMS, "-s", str(frames), f"--explain={reasons}", cwd=project_root,
                                  preexec=harness.file_size_limit(600))
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr and cpu_seconds < harness.CPU_SECONDS_LIMIT
    assert result.stderr.count("\n") == 1 and str(reasons) in result.stderr
    written = reasons.read_text().splitlines()
    assert written and all(json.loads(line) for line in written[:-1])  # what got through is readable
    assert len(result.stdout.splitlines()) >= len(written) - 1  # the detections went on as far as the reasons


def test_a_full_disk_under_the_output_is_exit_2(project_root):
    result, cpu = command("detect", PARAMS, "-s", "demo", "-n", "3", "-o", "/dev/full", cwd=project_root)
    assert_one_error_line(result, cpu, "objrec-detect: error: ")
    assert "/dev/full" in result.stderr and "No space left on device" in result.stderr


# -- Ctrl-C while starting -----------------------------------------------------------------------------------------
def start(name: str, *args: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    """Start a command and return once its launcher's handler is in place (SIGTERM caught, as /proc shows):
    the interpreter's own start-up before that is out of the project's hands, and on a loaded machine it
    alone can take longer than the delays the tests then wait."""
    process = subprocess.Popen([sys.executable, "-c", SCRIPT.format(name), *args], cwd=cwd, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    status, caught = Path(f"/proc/{process.pid}/status"), 1 << (signal.SIGTERM - 1)
    deadline = time.monotonic() + 120.0  # a hang guard, never a speed bound
    while status.exists() and time.monotonic() < deadline:
        masks = [line.split()[1] for line in status.read_text().splitlines() if line.startswith("SigCgt:")]
        if masks and int(masks[0], 16) & caught:
            break
        time.sleep(0.002)
    return process


@pytest.mark.parametrize("delay", [0.1, 0.2, 0.4])
def test_ctrl_c_while_starting_prints_no_traceback(project_root, delay):
    # No frame limit: the run ends only by the signal, however late a loaded machine lets it come.
    process = start("detect", PARAMS, "-s", "demo", cwd=project_root)
    try:
        time.sleep(delay)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=180)  # a hang guard
    finally:
        if process.poll() is None:
            process.kill()
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    if process.returncode == 130:  # still starting: one line, nothing on stdout
        assert err == "objrec-detect: interrupted while starting (SIGINT)\n" or \
            err == "objrec-detect: interrupted while starting\n", err
        assert out == ""
    else:  # already running: it stops between frames, every line written complete
        assert process.returncode == 0, err
        assert "stopped by SIGINT" in err
        assert all(json.loads(line) for line in out.splitlines())


#: Sends SIGINT at the Nth Python call of a command's start-up (tests/apps/interrupt_at_call.py).
INTERRUPT_AT_CALL = Path(__file__).with_name("interrupt_at_call.py")


def interrupted_at(call: int, cwd: Path, launcher: str, args: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(INTERRUPT_AT_CALL), str(call), launcher, *args], cwd=cwd,
                          capture_output=True, text=True, timeout=180)  # a hang guard


@pytest.mark.parametrize(("prog", "launcher", "args", "points"), [
    ("objrec-detect", "detect", [PARAMS, "-s", "demo", "-n", "3"], 96),
    ("objrec-eval", "evaluate", [PARAMS, "--source", "demo:frames=3", "--out", "OUT"], 32),
    ("objrec-tune", "tune", [PARAMS, "--source", "demo:frames=6", "--trials", "2", "--out", "OUT.yaml"], 32),
    ("objrec-batch", "batch", [PARAMS, "demo:frames=2", "--out", "OUT", "-w", "1"], 24),
])
def test_ctrl_c_anywhere_in_the_start_up_ends_it_in_one_line(project_root, tmp_path, prog, launcher, args, points):
    """Not where a timer happens to land but spread over every Python call from the launcher's handler to the
    run loop's: an interrupt raised as an exception there was once printed and lost inside a generator being
    closed (the run then went on to the end) or became 'cannot be loaded' inside a plug-in's class creation."""
    args = [str(tmp_path / a) if a.startswith("OUT") else a for a in args]
    counted = interrupted_at(-1, project_root, launcher, args)
    assert counted.returncode == 0, counted.stderr
    calls = int(next(line for line in counted.stderr.splitlines() if line.startswith("CALLS ")).split()[1])
    assert calls > 10_000  # the imports, the system and the source: the stretch the signal is spread over
    # The last few calls are the run loop's own handler going in: a signal there is the loop's.
    for call in np.linspace(1, calls - 20, points).round().astype(int):
        done = interrupted_at(int(call), project_root, launcher, args)
        assert (done.returncode, done.stdout) == (130, ""), f"SIGINT at call {call}: {done.stderr}"
        # In the few calls between one handling and the next, Python's own KeyboardInterrupt is what arrives,
        # and the command names no signal.
        assert done.stderr in (f"{prog}: interrupted while starting (SIGINT)\n",
                               f"{prog}: interrupted while starting\n", f"{prog}: interrupted\n"), \
            f"SIGINT at call {call}: {done.stderr}"


def test_a_run_started_with_ctrl_c_ignored_keeps_ignoring_it_and_stops_on_sigterm(project_root):
    """As a shell starts a background job (`objrec-detect ... &` in a script): Ctrl-C at the terminal is not
    for it, in no phase of the run; SIGTERM still stops it cleanly."""
    process = subprocess.Popen([sys.executable, "-c", SCRIPT.format("detect"), PARAMS, "-s", "demo"],
                               cwd=project_root, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        assert process.stdout.readline()  # running
        process.send_signal(signal.SIGINT)
        for _ in range(5):  # frames still come after it
            assert json.loads(process.stdout.readline())["objects"]
        process.send_signal(signal.SIGTERM)
        rest, err = process.communicate(timeout=60)  # a hang guard
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert "stopped by SIGTERM" in err and "SIGINT" not in err
    assert all(json.loads(line) for line in rest.splitlines())


@pytest.mark.parametrize(("name", "args", "signum"), [
    ("batch", [PARAMS, "demo:frames=5", "--out", "OUT"], signal.SIGINT),
    ("inspect", ["m.yaml", "--map", "m", "--world", "w", "--out", "OUT"], signal.SIGINT),
    ("patrol", ["poses.txt", "--map", "m.yaml"], signal.SIGINT),
    ("detect", [PARAMS, "-s", "demo"], signal.SIGTERM),
])
def test_every_command_interrupted_while_importing_says_one_line(project_root, tmp_path, name, args, signum):
    args = [str(tmp_path / "out") if a == "OUT" else a for a in args]
    process = start(name, *args, cwd=project_root)
    time.sleep(0.02)  # importing takes a tenth of a second (batch) to half a second (patrol)
    process.send_signal(signum)
    out, err = process.communicate(timeout=180)  # a hang guard
    assert process.returncode == 128 + signum, err
    # While importing the launcher says so; a command already past its imports says it in its own words.
    assert err in (f"objrec-{name}: interrupted while starting ({signal.Signals(signum).name})\n",
                   f"objrec-{name}: interrupted while starting\n")
    assert out == "" and not (tmp_path / "out").exists()


@pytest.mark.parametrize("delay", [0.3, 0.6])
def test_ctrl_c_while_the_window_starts_ends_it(project_root, tmp_path, delay):
    pytest.importorskip("PySide6")
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen", "HOME": str(tmp_path), "XDG_CONFIG_HOME": str(tmp_path)}
    process = start("define", "hsv", cwd=project_root, env=env)
    try:
        time.sleep(delay)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=180)  # a hang guard
    finally:
        if process.poll() is None:
            process.kill()
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    if process.returncode == 130:  # before the window took Ctrl-C over
        assert err == "objrec-define: interrupted while starting (SIGINT)\n"
    else:  # the window was up: Ctrl-C closed it as File>Quit would
        assert process.returncode == 0, err


def test_the_launcher_imports_each_command_and_gives_the_signals_back(monkeypatch):
    before = {sig: signal.getsignal(sig) for sig in launch.START_SIGNALS}
    seen = {}

    def fake_main() -> int:
        seen.update({sig: signal.getsignal(sig) for sig in launch.START_SIGNALS})
        return 7

    monkeypatch.setattr(detect, "main", fake_main)
    assert launch.detect() == 7
    assert seen == before  # the command's main runs with the handling it had before
    assert {sig: signal.getsignal(sig) for sig in launch.START_SIGNALS} == before
    assert set(launch.COMMANDS) == {"objrec-detect", "objrec-define", "objrec-batch", "objrec-inspect",
                                    "objrec-patrol", "objrec-eval", "objrec-tune"}
    for name in ("detect", "define", "batch", "inspect", "patrol", "evaluate", "tune"):
        assert callable(getattr(launch, name))


def test_help_lists_the_declared_ranges():
    text = detect.build_parser().format_help()
    assert "a whole number in 1..1000000000" in text
    assert isinstance(detect.build_parser(), argparse.ArgumentParser)
