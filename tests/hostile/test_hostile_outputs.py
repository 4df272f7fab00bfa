"""Outputs: no output replaces an input, a read-only file (even as root), a FIFO or what lies outside
its folder; a full disk leaves no unreadable file and no hang; no text crashes OpenCV's drawing or a ROS writer.

One row per case, each run as a user runs it, in a child process (tests/hostile/harness.py):
exit code 2, one stderr line naming the file or option, the child's CPU time under 10 s (wall-clock only as a
hang guard), its own peak memory under 500 MB, nothing written outside the declared outputs, and every input
byte-identical after the run (compared by content, link and mode).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import stat
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import cv2
import numpy as np
import pytest

import navigation
import objrec_apps

from .harness import FileSizeLimit, Outcome, assert_refused, assert_succeeded, run

SYSTEMS = Path(objrec_apps.__file__).parent / "systems"
HSV = SYSTEMS / "hsv_demo.yaml"
NAV_DATA = Path(navigation.__file__).parent / "data"
LAB = Path(objrec_apps.__file__).parent.parent / "examples" / "inspection_lab"
RECORDINGS = Path(__file__).resolve().parents[3] / "shared" / "data" / "recordings"
AS_ROOT = os.geteuid() == 0


@dataclass
class Plan:
    """One case: its command line, what the error line must name, the outputs it may write, and checks."""

    argv: list[str]
    names: list[str]
    outputs: tuple[str, ...] = ()
    preexec: FileSizeLimit | None = None
    check: Callable[[Outcome, Path], list[str]] | None = None
    accepted: bool = False  # a valid run: exit code 0


def detect(*args: str) -> list[str]:
    return ["objrec-detect", *args]


def patrol(*args: str) -> list[str]:
    return ["objrec-patrol", "poses.txt", "--map", str(NAV_DATA / "b5203.yaml"), "--laps", "1", *args]


def inspect(*args: str) -> list[str]:
    return ["objrec-inspect", "lab/mission.yaml", "--map", "lab/lab.yaml", "--world", "lab/lab.world.yaml",
            "--laps", "1", *args]


# -- the files of a case -------------------------------------------------------------------------------------


def params(tmp: Path, name: str = "p.yaml", object_name: str | None = None) -> str:
    text = HSV.read_text(encoding="utf-8")
    if object_name is not None:
        text = text.replace("object_name: coloured_object", f'object_name: "{object_name}"')
    (tmp / name).write_text(text, encoding="utf-8")
    return name


def picture(tmp: Path, name: str = "scene.png") -> str:
    image = np.full((120, 160, 3), 128, np.uint8)
    cv2.circle(image, (80, 60), 25, (0, 0, 255), -1)
    (tmp / name).parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(tmp / name), image)
    return name


def read_only(tmp: Path, name: str, text: str = "keep me\n") -> str:
    (tmp / name).write_text(text, encoding="utf-8")
    os.chmod(tmp / name, 0o444)
    return name


def fifo(tmp: Path, name: str) -> str:
    os.mkfifo(tmp / name)
    return name


def bagmaker() -> ModuleType:
    """tests/ros/bagmaker.py (rosbags), loaded by path as tests/ros/conftest.py loads it."""
    pytest.importorskip("rosbags", reason="typed outputs need the ros extra (rosbags)")
    name = "objrec_tests_bagmaker"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, Path(__file__).parents[1] / "ros" / "bagmaker.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def recording(tmp: Path, fmt: str, base: str = "src") -> str:
    """A two-frame image recording of ``fmt`` (ros1, mcap: a ROS 2 folder, mcap-file) in the case's folder."""
    maker_module = bagmaker()
    maker = maker_module.Messages(fmt)
    image = np.full((48, 64, 3), 128, np.uint8)
    entries = [maker_module.Entry("/camera/image", maker_module.IMAGE, (i + 1) * 10**9,
                                  maker.image(image, "bgr8", (i + 1) * 10**9)) for i in range(2)]
    path = maker_module.write(tmp / base, fmt, maker, entries)
    return path.name


# -- what a case must leave as it was -----------------------------------------------------------------------


def fingerprint(tmp: Path) -> dict[str, tuple[object, ...]]:
    """Every entry of the case's folder: its kind, mode, link target and content hash (not following links)."""
    found: dict[str, tuple[object, ...]] = {}
    for path in sorted(tmp.rglob("*")):
        info = path.lstat()
        relative = str(path.relative_to(tmp))
        if stat.S_ISLNK(info.st_mode):
            found[relative] = ("link", os.readlink(path))
        elif stat.S_ISREG(info.st_mode):
            digest = hashlib.sha1(path.read_bytes()).hexdigest()
            found[relative] = ("file", stat.S_IMODE(info.st_mode), info.st_ino, digest)
        else:
            found[relative] = (stat.S_IFMT(info.st_mode), stat.S_IMODE(info.st_mode))
    return found


def changed(before: dict[str, tuple[object, ...]], after: dict[str, tuple[object, ...]],
            outputs: tuple[str, ...]) -> list[str]:
    """Inputs (whatever was there before the run, outside the declared outputs) that differ or went away."""
    allowed = [Path(o) for o in outputs]
    return [f"{name} changed or went away" for name, was in before.items()
            if not any(Path(name) == a or Path(name).is_relative_to(a) for a in allowed) and after.get(name) != was]


# -- the cases -----------------------------------------------------------------------------------------------


def surrogate_name_annotate(tmp: Path) -> Plan:
    """Was a segmentation fault (exit 139, nothing on stderr): the name reached OpenCV's text drawing."""
    name = params(tmp, "bad_name.yaml", object_name="bad\\udcffname")
    return Plan(detect(name, "-s", "demo", "-n", "2", "--annotate", "out.avi"), [name])


def surrogate_name_mcap(tmp: Path) -> Plan:
    bagmaker()
    name = params(tmp, "bad_name.yaml", object_name="bad\\udcffname")
    return Plan(detect(name, "-s", "demo", "-n", "2", "-o", "out.mcap"), [name])


def frame_id_not_utf8(tmp: Path) -> Plan:
    bagmaker()
    return Plan(detect(params(tmp), "-s", "demo", "-n", "2", "--frame-id", os.fsdecode(b"cam\xff"), "-o", "out.mcap"),
                ["--frame-id", "cam\\xff"])


def output_onto_source_image(tmp: Path) -> Plan:
    source = picture(tmp)
    return Plan(detect(params(tmp), "-s", source, "-o", source), ["--output", source])


def output_onto_params(tmp: Path) -> Plan:
    name = params(tmp)
    return Plan(detect(name, "-s", picture(tmp), "-o", name), ["--output", name])


def explain_onto_source_image(tmp: Path) -> Plan:
    source = picture(tmp)
    return Plan(detect(params(tmp), "-s", source, f"--explain={source}"), ["--explain", source])


def explain_onto_params(tmp: Path) -> Plan:
    name = params(tmp)
    return Plan(detect(name, "-s", picture(tmp), f"--explain={name}"), ["--explain", name])


def output_hard_link_of_source(tmp: Path) -> Plan:
    source = picture(tmp)
    os.link(tmp / source, tmp / "also.png")
    return Plan(detect(params(tmp), "-s", source, "-o", "also.png"), ["--output", "also.png"])


def explain_link_to_params(tmp: Path) -> Plan:
    name = params(tmp)
    os.symlink(name, tmp / "reasons.jsonl")
    return Plan(detect(name, "-s", picture(tmp), "--explain=reasons.jsonl"), ["--explain", "reasons.jsonl"])


def annotate_link_to_source(tmp: Path) -> Plan:
    picture(tmp, "frames/frame_000000.png")
    os.symlink("frames", tmp / "pictures")
    return Plan(detect(params(tmp), "-s", "frames", "--annotate", "pictures"), ["--annotate", "pictures"])


def recording_as_source_and_output(fmt: str) -> Callable[[Path], Plan]:
    def build(tmp: Path) -> Plan:
        source = recording(tmp, fmt)
        return Plan(detect(params(tmp), "-s", source, "-o", source), ["--output", source])

    return build


def bag_scheme_source_and_output(tmp: Path) -> Plan:
    source = recording(tmp, "ros1")
    return Plan(detect(params(tmp), "-s", f"bag:{source},topic=/camera/image", "-o", source), ["--output", source])


def real_bag_source_and_output(tmp: Path) -> Plan:
    real = RECORDINGS / "rosnumpy-test.bag"
    if not real.is_file():
        pytest.skip(f"no real recording at {real}")
    bagmaker()
    (tmp / "real.bag").write_bytes(real.read_bytes())
    return Plan(detect(params(tmp), "-s", "real.bag", "-o", "real.bag"), ["--output", "real.bag"])


def batch_like_output_folder_holding_source(tmp: Path) -> Plan:
    """A ROS 2 bag output folder that is the folder holding the source .mcap: the bag would be written into it."""
    source = recording(tmp, "mcap-file", "data/src")
    return Plan(detect(params(tmp), "-s", f"data/{source}", "-o", "data"), ["--output", "data"])


def demo_truth_onto_params(tmp: Path) -> Plan:
    """The demo source writes the truth of its frames where ``truth=`` says: an output like any other."""
    name = params(tmp)
    return Plan(detect(name, "-s", f"demo:frames=2,truth={name}"), ["truth=", name])


def output_inside_folder_source(tmp: Path) -> Plan:
    picture(tmp, "frames/frame_000000.png")
    return Plan(detect(params(tmp), "-s", "frames", "-o", "frames/detections.jsonl"),
                ["--output", "frames/detections.jsonl"])


def annotate_into_folder_source(tmp: Path) -> Plan:
    picture(tmp, "frames/frame_000000.png")
    return Plan(detect(params(tmp), "-s", "frames", "--annotate", "frames"), ["--annotate", "frames"])


def read_only_output(option: str) -> Callable[[Path], Plan]:
    """Run as root, these files were overwritten: root ignores permission bits, the commands must not."""

    def build(tmp: Path) -> Plan:
        target = {"--output": "detections.jsonl", "--explain": "reasons.jsonl", "--rerun": "run.rrd",
                  "--annotate": "pictures.avi"}[option]
        if option == "--rerun":
            pytest.importorskip("rerun", reason="--rerun needs rerun-sdk (objrec[viz])")
        read_only(tmp, target)
        given = [f"{option}={target}"] if option == "--explain" else [option, target]
        return Plan(detect(params(tmp), "-s", "demo", "-n", "2", *given), [option, target])

    return build


def read_only_output_with_other_outputs(tmp: Path) -> Plan:
    """The refusal comes before any output is opened: the annotated video asked first is not written either."""
    read_only(tmp, "reasons.jsonl")
    return Plan(detect(params(tmp), "-s", "demo", "-n", "2", "--annotate", "out.avi", "-o", "d.jsonl",
                       "--explain=reasons.jsonl"), ["--explain", "reasons.jsonl"])


def fifo_output(option: str) -> Callable[[Path], Plan]:
    """A FIFO nobody reads: opening it for writing would wait for ever (the --rerun and --explain= hangs)."""

    def build(tmp: Path) -> Plan:
        if option == "--rerun":
            pytest.importorskip("rerun", reason="--rerun needs rerun-sdk (objrec[viz])")
        name = fifo(tmp, "target.rrd" if option == "--rerun" else "target.jsonl")
        given = [f"{option}={name}"] if option == "--explain" else [option, name]
        return Plan(detect(params(tmp), "-s", "demo", "-n", "2", *given), [option, name])

    return build


def no_file(name: str) -> Callable[[Outcome, Path], list[str]]:
    def check(_outcome: Outcome, tmp: Path) -> list[str]:
        left = [str(p.relative_to(tmp)) for p in tmp.rglob("*") if p.name == name or ".saving-" in p.name]
        return [f"left {left}"] if left else []

    return check


def rerun_full_disk(tmp: Path) -> Plan:
    """Was a hang past 60 s inside rerun-sdk's own file writer, leaving its file: now one line and no file."""
    pytest.importorskip("rerun", reason="--rerun needs rerun-sdk (objrec[viz])")
    return Plan(detect(params(tmp), "-s", "demo", "-n", "300", "--rerun", "run.rrd", "-o", os.devnull),
                ["run.rrd"], preexec=FileSizeLimit(200_000), check=no_file("run.rrd"))


def patrol_rerun_full_disk(tmp: Path) -> Plan:
    pytest.importorskip("rerun", reason="--rerun needs rerun-sdk (objrec[viz])")
    (tmp / "poses.txt").write_bytes((NAV_DATA / "b5203.txt").read_bytes())
    return Plan(patrol("--rerun", "run.rrd"), ["run.rrd"], preexec=FileSizeLimit(20_000), check=no_file("run.rrd"))


def annotate_video_full_disk(tmp: Path) -> Plan:
    """Was an .avi of 0 readable frames left behind: a video none of whose frames reads is not kept."""

    def check(_outcome: Outcome, folder: Path) -> list[str]:
        from objrec_apps.annotation_writer import readable_frames

        video = folder / "annotated.avi"
        problems = no_file("never")(_outcome, folder)  # no temporary left
        if video.exists() and readable_frames(video, 1000) == 0:
            problems.append("annotated.avi was left with 0 readable frames")
        return problems

    return Plan(detect(params(tmp), "-s", "demo", "-n", "200", "--annotate", "annotated.avi", "-o", os.devnull),
                ["annotated.avi"], ("annotated.avi",), FileSizeLimit(4_000), check=check)


def patrol_events_onto_pose_file(tmp: Path) -> Plan:
    (tmp / "poses.txt").write_bytes((NAV_DATA / "b5203.txt").read_bytes())
    return Plan(patrol("--events", "poses.txt"), ["--events", "poses.txt"])


def patrol_read_only(option: str) -> Callable[[Path], Plan]:
    def build(tmp: Path) -> Plan:
        if option == "--rerun":
            pytest.importorskip("rerun", reason="--rerun needs rerun-sdk (objrec[viz])")
        (tmp / "poses.txt").write_bytes((NAV_DATA / "b5203.txt").read_bytes())
        target = read_only(tmp, {"--events": "events.jsonl", "--rerun": "run.rrd", "--diagram": "d.md"}[option])
        return Plan(patrol(option, target), [option, target])

    return build


def patrol_events_fifo(tmp: Path) -> Plan:
    (tmp / "poses.txt").write_bytes((NAV_DATA / "b5203.txt").read_bytes())
    name = fifo(tmp, "events.jsonl")
    return Plan(patrol("--events", name), ["--events", name])


def lab(tmp: Path) -> None:
    for source in LAB.rglob("*"):
        if source.is_file() and source.suffix in (".yaml", ".txt", ".pgm", ".png"):
            target = tmp / "lab" / source.relative_to(LAB)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(source.read_bytes())


def inspect_events_read_only(tmp: Path) -> Plan:
    """The inspection's events.jsonl in --out, read-only: was overwritten as root."""
    lab(tmp)
    (tmp / "out").mkdir()
    read_only(tmp, "out/events.jsonl")
    return Plan(inspect("--out", "out"), ["events.jsonl"])


def inspect_report_link_out_of_out(tmp: Path) -> Plan:
    """A link in --out named like a report, pointing at a file elsewhere: the file elsewhere stays."""
    lab(tmp)
    (tmp / "out").mkdir()
    (tmp / "elsewhere.md").write_text("not a report\n", encoding="utf-8")
    os.symlink("../elsewhere.md", tmp / "out" / "report.md")
    return Plan(inspect("--out", "out"), ["report.md", "--out"])


def inspect_diagram_onto_mission(tmp: Path) -> Plan:
    lab(tmp)
    return Plan(inspect("--out", "out", "--diagram", "lab/mission.yaml"), ["--diagram", "mission.yaml"])


def inspect_out_is_pose_file(tmp: Path) -> Plan:
    lab(tmp)
    return Plan(inspect("--out", "lab/lab_poses.txt"), ["--out", "lab_poses.txt"])


def mission_name_not_utf8(tmp: Path) -> Plan:
    """Was a segmentation fault and no report: the mission's file name is drawn on the map picture and written
    into report.md. Now drawn and written escaped, the run completes."""
    lab(tmp)
    name = os.fsdecode(b"m\xffission.yaml")
    (tmp / "lab" / name).write_bytes((tmp / "lab" / "mission.yaml").read_bytes())

    def check(_outcome: Outcome, folder: Path) -> list[str]:
        report = folder / "out" / "report.md"
        if not report.is_file():
            return ["no report.md"]
        text = report.read_bytes().decode("utf-8")  # valid UTF-8, or this raises
        return [] if "m\\xffission.yaml" in text else ["report.md does not name the mission escaped"]

    argv = ["objrec-inspect", f"lab/{name}", "--map", "lab/lab.yaml", "--world", "lab/lab.world.yaml", "--laps", "1",
            "--time-limit", "30", "--out", "out"]
    return Plan(argv, [], ("out",), check=check, accepted=True)


def world_object_surrogate_name(tmp: Path) -> Plan:
    lab(tmp)
    text = (tmp / "lab" / "lab.world.yaml").read_text(encoding="utf-8")
    (tmp / "lab" / "bad.world.yaml").write_text(text.replace("name: red_box", 'name: "red\\udcffbox"'),
                                                encoding="utf-8")
    argv = ["objrec-inspect", "lab/mission.yaml", "--map", "lab/lab.yaml", "--world", "lab/bad.world.yaml",
            "--out", "out"]
    return Plan(argv, ["bad.world.yaml"], ("out",))


def mission_detect_file_surrogate_name(tmp: Path) -> Plan:
    lab(tmp)
    detect_file = tmp / "lab" / "params" / "cylinder_3d.yaml"
    text = detect_file.read_text(encoding="utf-8")
    first = next(line for line in text.splitlines() if line.startswith("object_name:"))
    detect_file.write_text(text.replace(first, 'object_name: "cyl\\udcffinder"'), encoding="utf-8")
    return Plan(inspect("--out", "out"), ["cylinder_3d.yaml"], ("out",))


def refused_name_shown_escaped(tmp: Path) -> Plan:
    """A path with bytes that are not UTF-8 is named with them escaped (``\\xff``), not as a lone surrogate."""
    name = os.fsdecode(b"ro\xff.jsonl")
    read_only(tmp, name)
    return Plan(detect(params(tmp), "-s", "demo", "-n", "1", "-o", name), ["--output", "ro\\xff.jsonl"])


CASES: dict[str, Callable[[Path], Plan]] = {
    "text-surrogate-object-name-annotate": surrogate_name_annotate,
    "text-surrogate-object-name-mcap": surrogate_name_mcap,
    "text-frame-id-not-utf8-mcap": frame_id_not_utf8,
    "text-refused-name-not-utf8-shown-escaped": refused_name_shown_escaped,
    "text-mission-file-name-not-utf8-inspect-completes": mission_name_not_utf8,
    "text-world-object-surrogate-name": world_object_surrogate_name,
    "text-mission-detect-file-surrogate-name": mission_detect_file_surrogate_name,
    "input-output-onto-source-image": output_onto_source_image,
    "input-output-onto-params": output_onto_params,
    "input-explain-onto-source-image": explain_onto_source_image,
    "input-explain-onto-params": explain_onto_params,
    "input-output-hard-link-of-source": output_hard_link_of_source,
    "input-explain-symlink-to-params": explain_link_to_params,
    "input-annotate-symlink-to-folder-source": annotate_link_to_source,
    "input-mcap-source-and-output": recording_as_source_and_output("mcap-file"),
    "input-ros2-folder-source-and-output": recording_as_source_and_output("mcap"),
    "input-ros2-sqlite-folder-source-and-output": recording_as_source_and_output("sqlite3"),
    "input-ros1-bag-source-and-output": recording_as_source_and_output("ros1"),
    "input-bag-scheme-source-and-output": bag_scheme_source_and_output,
    "input-real-ros1-bag-source-and-output": real_bag_source_and_output,
    "input-output-folder-holds-source-mcap": batch_like_output_folder_holding_source,
    "input-output-inside-folder-source": output_inside_folder_source,
    "input-demo-truth-onto-params": demo_truth_onto_params,
    "input-annotate-into-folder-source": annotate_into_folder_source,
    "input-patrol-events-onto-pose-file": patrol_events_onto_pose_file,
    "input-inspect-diagram-onto-mission": inspect_diagram_onto_mission,
    "input-inspect-out-is-pose-file": inspect_out_is_pose_file,
    "read-only-output": read_only_output("--output"),
    "read-only-explain": read_only_output("--explain"),
    "read-only-rerun": read_only_output("--rerun"),
    "read-only-annotate-video": read_only_output("--annotate"),
    "read-only-explain-refused-before-other-outputs": read_only_output_with_other_outputs,
    "read-only-patrol-events": patrol_read_only("--events"),
    "read-only-patrol-rerun": patrol_read_only("--rerun"),
    "read-only-patrol-diagram": patrol_read_only("--diagram"),
    "read-only-inspect-events-jsonl": inspect_events_read_only,
    "link-inspect-report-leaves-out": inspect_report_link_out_of_out,
    "fifo-rerun": fifo_output("--rerun"),
    "fifo-explain": fifo_output("--explain"),
    "fifo-output": fifo_output("--output"),
    "fifo-patrol-events": patrol_events_fifo,
    "full-disk-rerun-detect-no-file": rerun_full_disk,
    "full-disk-rerun-patrol-no-file": patrol_rerun_full_disk,
    "full-disk-annotate-video-no-unreadable-avi": annotate_video_full_disk,
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_hostile_output_case(case: str, tmp_path: Path) -> None:
    plan = CASES[case](tmp_path)
    before = fingerprint(tmp_path)
    outcome = run(plan.argv, tmp_path, preexec=plan.preexec)
    problems = plan.check(outcome, tmp_path) if plan.check else []
    problems += changed(before, fingerprint(tmp_path), plan.outputs)
    if plan.accepted:
        assert_succeeded(outcome, plan.outputs)
    else:
        assert_refused(outcome, plan.names, plan.outputs)
    assert not problems, "; ".join(problems) + "\n" + outcome.describe()


def test_the_real_recordings_are_refused_as_outputs_even_as_root(tmp_path: Path) -> None:
    """The shared recordings are read-only files: as root, --output onto one (not the source) is refused."""
    real = RECORDINGS / "embag-test.bag"
    if not real.is_file():
        pytest.skip(f"no real recording at {real}")
    bagmaker()
    name = params(tmp_path)
    before = hashlib.sha1(real.read_bytes()).hexdigest()
    outcome = run(detect(name, "-s", "demo", "-n", "1", "-o", str(real)), tmp_path)
    assert_refused(outcome, ["--output", real.name])
    assert "read-only" in outcome.stderr, outcome.describe()
    assert hashlib.sha1(real.read_bytes()).hexdigest() == before
