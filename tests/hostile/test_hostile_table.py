"""Hostile inputs, case by case: every hostile or broken input the rules list, given to the real commands in a child
process. A refusal is exit code 2 and one stderr line naming the file (or option), no traceback, within 10 s and
500 MB, nothing written but the declared output; the valid inputs the rules list must be accepted.

Each case builds its hostile file in a fresh folder (the child's working folder) from a few lines of code; the
valid parts of each command line are the shipped systems, map and poses.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import navigation
import objrec_apps

from . import hostile_files as hf
from .harness import (
    CPU_SECONDS_LIMIT,
    FileSizeLimit,
    Outcome,
    assert_refused,
    assert_succeeded,
    complete_json_lines,
    outside,
    run,
)

SYSTEMS = Path(objrec_apps.__file__).parent / "systems"
HSV = str(SYSTEMS / "hsv_demo.yaml")
FEATURE = SYSTEMS / "feature_demo.yaml"
SHAPE = str(SYSTEMS / "shape_demo.yaml")
NAV_DATA = Path(navigation.__file__).parent / "data"
MAP = str(NAV_DATA / "b5203.yaml")
MAP_IMAGE = str(NAV_DATA / "b5203.pgm")
POSES = str(NAV_DATA / "b5203.txt")
#: 20000 x 20000 and 30000 x 30000 claimed; 40000 x 40000 is also past OpenCV's own pixel limit (2**30).
TARGET_SIDE, IMAGE_SIDE, PAST_OPENCV_SIDE = 20_000, 30_000, 40_000


def detect(*args: str) -> list[str]:
    return ["objrec-detect", *args]


def patrol(*args: str, poses: str = POSES, map_yaml: str = MAP) -> list[str]:
    return ["objrec-patrol", poses, "--map", map_yaml, "--laps", "1", *args]


def full_disk(max_bytes: int) -> FileSizeLimit:
    """A child whose writes past ``max_bytes`` in any one file fail with EFBIG, as on a full disk."""
    return FileSizeLimit(max_bytes)


def write(folder: Path, name: str, data: str | bytes) -> str:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        path.write_text(data, encoding="utf-8")
    else:
        path.write_bytes(data)
    return name


def fifo(folder: Path, name: str) -> str:
    os.mkfifo(folder / name)
    return name


def full_device(folder: Path) -> str:
    """A node of /dev/full to write to: a copy in the case's folder when running as root (so that a save that
    replaces what it writes to can do no harm to the machine's own /dev/full), else /dev/full itself."""
    if os.geteuid() != 0:
        return "/dev/full"
    os.mknod(folder / "full", stat.S_IFCHR | 0o666, os.makedev(1, 7))
    return "full"


@dataclass
class Plan:
    """One case's command line and what its outcome must show."""

    argv: list[str]
    names: list[str] = field(default_factory=list)  # what the error line must name
    outputs: tuple[str, ...] = ()  # files the command may write
    preexec: Callable[[], None] | None = None
    accepted: bool = False  # a valid input: exit 0
    check: Callable[[Outcome, Path], list[str]] | None = None  # further problems, listed


# -- decompression bombs -------------------------------------------------------------------------------------


def feature_target_bomb(tmp: Path) -> Plan:
    name = write(tmp, "bomb_feature.yaml", hf.feature_file_with_target(FEATURE, hf.png_bomb(TARGET_SIDE, TARGET_SIDE)))
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


def image_source_bomb(tmp: Path) -> Plan:
    name = write(tmp, "bomb.png", hf.png_bomb(IMAGE_SIDE, IMAGE_SIDE))
    return Plan(detect(HSV, "--source", name, "--max-frames", "1"), [name])


def image_past_opencv_limit(tmp: Path) -> Plan:
    name = write(tmp, "past_opencv.png", hf.png_bomb(PAST_OPENCV_SIDE, PAST_OPENCV_SIDE))
    return Plan(detect(HSV, "--source", name, "--max-frames", "1"), [name])


def map_pgm_bomb(tmp: Path) -> Plan:
    hf.sparse_pgm(tmp / "bomb_map.pgm", IMAGE_SIDE, IMAGE_SIDE)
    write(tmp, "bomb_map.yaml", hf.map_yaml("bomb_map.pgm"))
    return Plan(patrol(map_yaml="bomb_map.yaml"), ["bomb_map.pgm"])


def map_png_bomb(tmp: Path) -> Plan:
    write(tmp, "bomb_map.png", hf.png_bomb(IMAGE_SIDE, IMAGE_SIDE))
    write(tmp, "bomb_map.yaml", hf.map_yaml("bomb_map.png"))
    return Plan(patrol(map_yaml="bomb_map.yaml"), ["bomb_map.png"])


def compressed_pcd_4gb(tmp: Path) -> Plan:
    name = write(tmp, "bomb.pcd", hf.compressed_pcd_claiming((2**32 - 16) // 16))
    return Plan(detect(SHAPE, "--source", name), [name])


# -- YAML expansion and nesting ------------------------------------------------------------------------------


def map_billion_laughs(tmp: Path) -> Plan:
    name = write(tmp, "laughs.yaml", hf.map_yaml(MAP_IMAGE) + hf.billion_laughs())
    return Plan(patrol(map_yaml=name), [name])


def params_billion_laughs(tmp: Path) -> Plan:
    name = write(tmp, "laughs.yaml", Path(HSV).read_text(encoding="utf-8") + hf.billion_laughs())
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


def map_deeply_nested(tmp: Path) -> Plan:
    name = write(tmp, "nested.yaml", hf.map_yaml(MAP_IMAGE) + "deep: " + hf.deeply_nested())
    return Plan(patrol(map_yaml=name), [name])


def params_deeply_nested(tmp: Path) -> Plan:
    name = write(tmp, "nested.yaml", hf.with_value(Path(HSV), "description", hf.deeply_nested().strip()))
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


# -- special files -------------------------------------------------------------------------------------------


def fifo_params(tmp: Path) -> Plan:
    name = fifo(tmp, "params.yaml")
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


def fifo_video(tmp: Path) -> Plan:
    name = fifo(tmp, "video.avi")
    return Plan(detect(HSV, "--source", name), [name])


def fifo_poses(tmp: Path) -> Plan:
    name = fifo(tmp, "poses.txt")
    return Plan(patrol(poses=name), [name])


def fifo_map(tmp: Path) -> Plan:
    name = fifo(tmp, "map.yaml")
    return Plan(patrol(map_yaml=name), [name])


def fifo_map_image(tmp: Path) -> Plan:
    fifo(tmp, "map.pgm")
    write(tmp, "map.yaml", hf.map_yaml("map.pgm"))
    return Plan(patrol(map_yaml="map.yaml"), ["map.pgm"])


def device_params(device: str) -> Callable[[Path], Plan]:
    def build(tmp: Path) -> Plan:
        return Plan(detect(device, "--source", "demo", "--max-frames", "1"), [device])

    return build


def device_map(device: str) -> Callable[[Path], Plan]:
    def build(tmp: Path) -> Plan:
        return Plan(patrol(map_yaml=device), [device])

    return build


# -- numbers -------------------------------------------------------------------------------------------------


def huge_int_params(tmp: Path) -> Plan:
    name = write(tmp, "digits.yaml", hf.with_value(Path(HSV), "h_max", "9" * 5000))
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


def huge_int_map(tmp: Path) -> Plan:
    name = write(tmp, "digits.yaml", hf.map_yaml(MAP_IMAGE).replace("resolution: 0.05", "resolution: " + "1" * 5000))
    return Plan(patrol(map_yaml=name), [name])


def option(option_name: str, *values: str) -> Callable[[Path], Plan]:
    def build(tmp: Path) -> Plan:
        return Plan(patrol(option_name, *values), [option_name])

    return build


def pose_1e308(tmp: Path) -> Plan:
    name = write(tmp, "far.txt", "station_pose:\n1e308, 1e308, 0.0, 0.0, 0.0, 0.0, 1.0\n12.0, 12.0, 0, 0, 0, 0, 1\n")
    return Plan(patrol(poses=name), [name])


# -- clouds --------------------------------------------------------------------------------------------------


def identical_points(tmp: Path) -> Plan:
    name = write(tmp, "frozen.pcd", hf.identical_points_pcd())
    return Plan(detect(SHAPE, "--source", name), accepted=True)


def count_3_on_x(tmp: Path) -> Plan:
    points = hf.scene_points(50)
    body = np.column_stack([points[:, 0]] * 3 + [points[:, 1], points[:, 2]]).astype("<f4")
    name = write(tmp, "count3.pcd", hf.pcd_text_header("x y z", "4 4 4", "F F F", "3 1 1", 50, 1, "binary")
                 + body.tobytes())
    return Plan(detect(SHAPE, "--source", name), [name])


def rgb_count_2(tmp: Path) -> Plan:
    points = hf.scene_points(50)
    table = np.zeros(50, dtype=[("xyz", "<f4", 3), ("rgb", "<u4", 2)])
    table["xyz"] = points
    name = write(tmp, "rgb2.pcd", hf.pcd_text_header("x y z rgb", "4 4 4 4", "F F F U", "1 1 1 2", 50, 1, "binary")
                 + table.tobytes())
    return Plan(detect(SHAPE, "--source", name), [name])


def ply_garbage_body(tmp: Path) -> Plan:
    points = hf.scene_points(20)
    name = write(tmp, "garbage.ply", hf.ascii_ply(points, body=b"abc def ghi\n" * len(points)))
    return Plan(detect(SHAPE, "--source", name), [name])


def pcd_100_comments(tmp: Path) -> Plan:
    write(tmp, "commented.pcd", hf.binary_pcd(hf.scene_points(), comments=100))
    return Plan(detect(SHAPE, "--source", "commented.pcd"), accepted=True)


def ply_long_header(tmp: Path) -> Plan:
    data = hf.ascii_ply(hf.scene_points(), comments=150)
    assert data.index(b"end_header") > 4096
    write(tmp, "long_header.ply", data)
    return Plan(detect(SHAPE, "--source", "long_header.ply"), accepted=True)


def cloud_folder_one_bad(tmp: Path) -> Plan:
    write(tmp, "clouds/a.pcd", hf.binary_pcd(hf.scene_points(seed=1)))
    write(tmp, "clouds/b_bad.pcd", b"this is no point cloud\n")
    write(tmp, "clouds/c.ply", hf.ascii_ply(hf.scene_points(seed=2)))

    def check(outcome: Outcome, _tmp: Path) -> list[str]:
        problems = []
        if "b_bad.pcd" not in outcome.stderr:
            problems.append("no warning names b_bad.pcd")
        frames = [line for line in outcome.stdout.splitlines() if line.startswith("{")]
        if len(frames) != 2:
            problems.append(f"{len(frames)} frames written, expected the 2 good files")
        return problems

    return Plan(detect(SHAPE, "--source", "clouds"), accepted=True, check=check)


def cloud_folder_all_bad(tmp: Path) -> Plan:
    write(tmp, "clouds/a_bad.pcd", b"this is no point cloud\n")
    write(tmp, "clouds/b_bad.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\nx y\n")
    return Plan(detect(SHAPE, "--source", "clouds"), ["clouds"])


# -- truncations ---------------------------------------------------------------------------------------------


def truncated_jpeg(tmp: Path) -> Plan:
    name = write(tmp, "cut.jpg", hf.truncated_jpeg())
    return Plan(detect(HSV, "--source", name), [name])


def truncated_avi(tmp: Path) -> Plan:
    hf.truncated_avi(tmp / "cut.avi")
    return Plan(detect(HSV, "--source", "cut.avi"), ["cut.avi"])


# -- write failures ------------------------------------------------------------------------------------------


def whole_lines(name: str) -> Callable[[Outcome, Path], list[str]]:
    return lambda _outcome, tmp: complete_json_lines(tmp / name)


def events_full_disk(tmp: Path) -> Plan:
    return Plan(patrol("--events", "events.jsonl"), ["events.jsonl"], ("events.jsonl",), full_disk(4096),
                check=whole_lines("events.jsonl"))


def diagram_full_disk(tmp: Path) -> Plan:
    return Plan(patrol("--diagram", "diagram.md"), ["diagram.md"], ("diagram.md",), full_disk(1000))


def annotate_full_disk(tmp: Path) -> Plan:
    return Plan(detect(HSV, "--source", "demo", "--max-frames", "200", "--annotate", "annotated.avi"),
                ["annotated.avi"], ("annotated.avi",), full_disk(300_000))


def output_full_disk(tmp: Path) -> Plan:
    return Plan(detect(HSV, "--source", "demo", "--max-frames", "500", "--output", "detections.jsonl"),
                ["detections.jsonl"], ("detections.jsonl",), full_disk(4096), check=whole_lines("detections.jsonl"))


def annotate_folder_full_disk(tmp: Path) -> Plan:
    return Plan(detect(HSV, "--source", "demo", "--max-frames", "100", "--annotate", "pictures"), ["pictures"],
                ("pictures",), full_disk(300_000))


def explain_full_disk(tmp: Path) -> Plan:
    """A system that finds nothing in the demo, so that every frame writes a reason to the side file."""
    blind = Path(HSV).read_text(encoding="utf-8").replace("h_max: 179", "h_max: 1").replace("s_min: 120", "s_min: 255")
    write(tmp, "blind.yaml", blind.replace("v_min: 60", "v_min: 255"))
    return Plan(detect("blind.yaml", "--source", "demo", "--max-frames", "300", "--explain=reasons.jsonl"),
                ["reasons.jsonl"], ("reasons.jsonl",), full_disk(2000), check=whole_lines("reasons.jsonl"))


def rerun_full_disk(command: str) -> Callable[[Path], Plan]:
    """A recording that fills the disk early in a long run: the run must stop soon after, not log on for
    minutes into a sink that has died (3,000 demo frames take about 40 s)."""

    def build(tmp: Path) -> Plan:
        pytest.importorskip("rerun", reason="--rerun needs rerun-sdk (objrec[viz])")
        argv = (detect(HSV, "--source", "demo", "--max-frames", "3000", "--rerun", "run.rrd") if command == "detect"
                else patrol("--rerun", "run.rrd"))
        return Plan(argv, ["run.rrd"], ("run.rrd",), full_disk(20_000))

    return build


def render_full_disk(tmp: Path) -> Plan:
    return Plan(patrol("--render", "run.gif"), ["run.gif"], ("run.gif",), full_disk(20_000))


def node_kept(name: str, is_kind: Callable[[int], bool]) -> Callable[[Outcome, Path], list[str]]:
    def check(_outcome: Outcome, tmp: Path) -> list[str]:
        info = os.lstat(tmp / name)
        return [] if is_kind(info.st_mode) else [f"{name} was replaced by a file of mode {oct(info.st_mode)}"]

    return check


def diagram_dev_full(tmp: Path) -> Plan:
    device = full_device(tmp)
    return Plan(patrol("--diagram", device), [device], check=node_kept(device, stat.S_ISCHR))


def diagram_fifo(tmp: Path) -> Plan:
    name = fifo(tmp, "diagram.md")
    return Plan(patrol("--diagram", name), [name], check=node_kept(name, stat.S_ISFIFO))


# -- messages and outputs ------------------------------------------------------------------------------------

#: A key that, printed raw, would split the error line and clear the screen.
EVIL_KEY = '"evil\\nkey\\e[2J\\e[31mFAKE: all good\\r"'


def unknown_key_escapes(tmp: Path) -> Plan:
    name = write(tmp, "evil_key.yaml", Path(HSV).read_text(encoding="utf-8") + f"{EVIL_KEY}: 1\n")
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


def unknown_parameter_escapes(tmp: Path) -> Plan:
    text = Path(HSV).read_text(encoding="utf-8").replace("    h_min: 0\n", f"    h_min: 0\n    {EVIL_KEY}: 1\n")
    name = write(tmp, "evil_parameter.yaml", text)
    return Plan(detect(name, "--source", "demo", "--max-frames", "1"), [name])


def annotate_fresh_folder(tmp: Path) -> Plan:
    def check(_outcome: Outcome, folder: Path) -> list[str]:
        video = folder / "out" / "colour.avi"
        return [] if video.is_file() and video.stat().st_size > 0 else ["out/colour.avi was not written"]

    return Plan(detect(HSV, "--source", "demo", "--max-frames", "5", "--annotate", "out/colour.avi"),
                outputs=("out",), accepted=True, check=check)


CASES: dict[str, Callable[[Path], Plan]] = {
    "bomb-feature-target-png-20000": feature_target_bomb,
    "bomb-image-source-png-30000": image_source_bomb,
    "bomb-image-source-past-opencv-limit": image_past_opencv_limit,
    "bomb-map-pgm-30000": map_pgm_bomb,
    "bomb-map-png-30000": map_png_bomb,
    "bomb-compressed-pcd-4gb": compressed_pcd_4gb,
    "yaml-map-billion-laughs": map_billion_laughs,
    "yaml-params-billion-laughs": params_billion_laughs,
    "yaml-map-deeply-nested": map_deeply_nested,
    "yaml-params-deeply-nested": params_deeply_nested,
    "fifo-params": fifo_params,
    "fifo-video": fifo_video,
    "fifo-poses": fifo_poses,
    "fifo-map": fifo_map,
    "fifo-map-image": fifo_map_image,
    "dev-zero-params": device_params("/dev/zero"),
    "dev-urandom-params": device_params("/dev/urandom"),
    "dev-zero-map": device_map("/dev/zero"),
    "dev-urandom-map": device_map("/dev/urandom"),
    "number-5000-digits-params": huge_int_params,
    "number-5000-digits-map": huge_int_map,
    "number-start-nan": option("--start", "nan", "0", "0"),
    "number-start-inf": option("--start", "1", "inf", "0"),
    "number-margin-nan": option("--margin", "nan"),
    "number-seed-negative": option("--seed", "-1"),
    "number-odom-noise-negative": option("--odom-noise", "-1"),
    "number-odom-noise-nan": option("--odom-noise", "nan"),
    "number-dt-0.0001": option("--dt", "0.0001"),
    "number-pose-1e308": pose_1e308,
    "cloud-307200-identical-points": identical_points,
    "cloud-count-3-on-x": count_3_on_x,
    "cloud-rgb-count-2": rgb_count_2,
    "cloud-ply-garbage-ascii-body": ply_garbage_body,
    "cloud-pcd-100-comment-lines": pcd_100_comments,
    "cloud-ply-header-over-4096-bytes": ply_long_header,
    "cloud-folder-one-bad-file": cloud_folder_one_bad,
    "truncated-jpeg": truncated_jpeg,
    "truncated-avi": truncated_avi,
    "full-disk-events": events_full_disk,
    "full-disk-diagram": diagram_full_disk,
    "full-disk-annotate": annotate_full_disk,
    "full-disk-output": output_full_disk,
    "full-disk-annotate-folder": annotate_folder_full_disk,
    "full-disk-explain": explain_full_disk,
    "full-disk-rerun-detect": rerun_full_disk("detect"),
    "full-disk-rerun-patrol": rerun_full_disk("patrol"),
    "full-disk-render": render_full_disk,
    "diagram-onto-dev-full": diagram_dev_full,
    "diagram-onto-fifo": diagram_fifo,
    "message-unknown-key-escapes": unknown_key_escapes,
    "message-unknown-parameter-escapes": unknown_parameter_escapes,
    "output-annotate-creates-folder": annotate_fresh_folder,
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_hostile_case(case: str, tmp_path: Path) -> None:
    plan = CASES[case](tmp_path)
    outcome = run(plan.argv, tmp_path, preexec=plan.preexec)
    extra = plan.check(outcome, tmp_path) if plan.check else []
    if plan.accepted:
        assert_succeeded(outcome, plan.outputs)
    else:
        assert_refused(outcome, plan.names, plan.outputs)
    assert not extra, "; ".join(extra) + "\n" + outcome.describe()


def test_cloud_folder_of_only_bad_files(tmp_path: Path) -> None:
    """A folder where nothing could be read: each bad file named in a warning, then one error line naming the
    folder, exit code 2 (the shape of a folder of unreadable images)."""
    plan = cloud_folder_all_bad(tmp_path)
    outcome = run(plan.argv, tmp_path)
    lines = outcome.stderr.splitlines()
    errors = [line for line in lines if "error:" in line]
    problems = []
    if outcome.exit_code != 2:
        problems.append(f"exit code {outcome.exit_code}, expected 2")
    if len(errors) != 1 or "clouds" not in errors[0]:
        problems.append(f"{len(errors)} error lines, expected one naming the folder")
    problems += [f"{name} not named" for name in ("a_bad.pcd", "b_bad.ply") if name not in outcome.stderr]
    if "Traceback" in outcome.stderr or outcome.cpu_seconds >= CPU_SECONDS_LIMIT or outside(outcome, ()):
        problems.append("a traceback, too slow, or files written")
    assert not problems, "; ".join(problems) + "\n" + outcome.describe()
