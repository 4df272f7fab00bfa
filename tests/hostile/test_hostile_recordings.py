"""Hostile recordings, case by case, through the real commands in a child process (the hostile table's harness):
compression bombs in every place a recording compresses, through objrec-detect, --list-topics and objrec-batch;
embedded definitions that lie; metadata.yaml fields of the wrong kind. A refusal is exit code 2 and one stderr line
naming the recording, within 10 s of CPU and 500 MB of the command's own memory, nothing written, the input
byte-identical after the run. The bombs are full size (1 GiB per chunk or message, 30 GiB for a file-compressed
bag) and the limits are the shipped defaults.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")

import objrec_apps

from . import recording_files as rf
from .harness import Outcome, assert_refused, bounded, outside, run

SYSTEMS = Path(objrec_apps.__file__).parent / "systems"
HSV = str(SYSTEMS / "hsv_demo.yaml")
SHAPE = str(SYSTEMS / "shape_demo.yaml")


def detect(*args: str) -> list[str]:
    return ["objrec-detect", *args]


@dataclass
class Plan:
    """One case's command line, the recording it reads and what its outcome must show."""

    argv: list[str]
    recording: str  # relative to the case's folder; named by the error line, unchanged by the run
    names: list[str] = field(default_factory=list)  # what else the error line must name
    outputs: tuple[str, ...] = ()
    check: Callable[[Outcome, Path], list[str]] | None = None  # a case that is not a plain refusal


def _source(recording: str, params: str = HSV) -> list[str]:
    return detect(params, "--source", recording, "--max-frames", "2")


# -- compression bombs ---------------------------------------------------------------------------------------
def ros1_bz2_chunk(tmp: Path) -> Plan:
    """The chunk header declares the true small size: inflating stops one byte past it."""
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "bz2")
    return Plan(_source("bomb.bag"), "bomb.bag", ["bz2 chunk", "bytes it declares"])


def ros1_lz4_chunk(tmp: Path) -> Plan:
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "lz4")
    return Plan(_source("bomb.bag"), "bomb.bag", ["lz4 chunk", "bytes it declares"])


def ros1_bz2_chunk_declaring_1gb(tmp: Path) -> Plan:
    """The chunk header declares what the bomb inflates to: refused before inflating."""
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "bz2", declare=rf.GIB)
    return Plan(_source("bomb.bag"), "bomb.bag", ["declared: 1,073,741,824 bytes", "OBJREC_MAX_RECORDING_CHUNK_BYTES"])


def ros1_lz4_chunk_declaring_200mb(tmp: Path) -> Plan:
    """Declared just under the limit, inflating to 1 GiB: bounded while inflating, at the declared size."""
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "lz4", declare=200 << 20)
    return Plan(_source("bomb.bag"), "bomb.bag", ["more than the 209,715,200 bytes it declares"])


def ros1_bz2_chunk_cloud(tmp: Path) -> Plan:
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "bz2")
    return Plan(detect(SHAPE, "--source", "bag:bomb.bag,topic=/camera/image"), "bomb.bag")


def mcap_zstd_chunk(tmp: Path) -> Plan:
    rf.mcap_chunk_bomb(tmp / "bomb.mcap", "zstd")
    return Plan(_source("bomb.mcap"), "bomb.mcap",
                ["zstd chunk, its frames declare", "OBJREC_MAX_RECORDING_CHUNK_BYTES"])


def mcap_streamed_zstd_chunk(tmp: Path) -> Plan:
    """zstd frames that do not say what they inflate to: bounded while inflating, by the chunk's declared size."""
    rf.mcap_chunk_bomb(tmp / "bomb.mcap", "zstd-stream")
    return Plan(_source("bomb.mcap"), "bomb.mcap", ["zstd chunk", "bytes it declares"])


def mcap_lz4_chunk(tmp: Path) -> Plan:
    rf.mcap_chunk_bomb(tmp / "bomb.mcap", "lz4")
    return Plan(_source("bomb.mcap"), "bomb.mcap", ["lz4 chunk"])


def mcap_zstd_chunk_declaring_3gb(tmp: Path) -> Plan:
    rf.mcap_chunk_bomb(tmp / "bomb.mcap", "zstd", declare=3 << 30)
    return Plan(_source("bomb.mcap"), "bomb.mcap", ["3,221,225,472 bytes", "OBJREC_MAX_RECORDING_CHUNK_BYTES"])


def mcap_zstd_chunk_declaring_its_size(tmp: Path) -> Plan:
    rf.mcap_chunk_bomb(tmp / "bomb.mcap", "zstd", declare=rf.GIB)
    return Plan(_source("bomb.mcap"), "bomb.mcap", ["OBJREC_MAX_RECORDING_CHUNK_BYTES"])


def ros2_message_zstd(tmp: Path) -> Plan:
    rf.message_bomb(tmp / "bomb")
    return Plan(_source("bomb"), "bomb", ["zstd-compressed message, its frames declare",
                                          "OBJREC_MAX_RECORDING_CHUNK_BYTES"])


def ros2_streamed_message_zstd(tmp: Path) -> Plan:
    rf.message_bomb(tmp / "bomb", codec="zstd-stream")
    return Plan(_source("bomb"), "bomb", ["zstd-compressed message, inflated", "OBJREC_MAX_RECORDING_CHUNK_BYTES"])


def ros2_file_compressed_30gb(tmp: Path) -> Plan:
    rf.file_bomb(tmp / "bomb")
    return Plan(_source("bomb"), "bomb", ["storage files", "OBJREC_MAX_RECORDING_TEMP_BYTES"])


def ros2_file_compressed_list_topics(tmp: Path) -> Plan:
    rf.file_bomb(tmp / "bomb")
    return Plan(detect("--list-topics", "bomb"), "bomb", ["OBJREC_MAX_RECORDING_TEMP_BYTES"])


def _listed(outcome: Outcome, _tmp: Path) -> list[str]:
    problems = bounded(outcome)
    if outcome.exit_code != 0 or "/camera/image" not in outcome.stdout:
        problems.append(f"exit code {outcome.exit_code}, topics not listed")
    return problems


def list_topics_of_a_chunk_bomb(tmp: Path) -> Plan:
    """--list-topics reads a ROS 1 bag's index, not its chunks: the topics are listed, at no cost."""
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "bz2")
    return Plan(detect("--list-topics", "bomb.bag"), "bomb.bag", check=_listed)


def _batch_refused(outcome: Outcome, tmp: Path) -> list[str]:
    problems = bounded(outcome)
    summary = tmp / "out" / "summary.csv"
    text = summary.read_text(encoding="utf-8") if summary.exists() else ""
    if outcome.exit_code not in (1, 2):
        problems.append(f"exit code {outcome.exit_code}, expected the failed-source code")
    if "bomb.bag" not in text or "bz2 chunk inflates to more than" not in text:
        problems.append(f"summary.csv does not name the bomb and its limit: {text!r}")
    stray = outside(outcome, ["out"])
    if stray:
        problems.append(f"files written outside the output: {stray}")
    return problems


def batch_of_a_chunk_bomb(tmp: Path) -> Plan:
    rf.ros1_chunk_bomb(tmp / "bomb.bag", "bz2")
    return Plan(["objrec-batch", HSV, "bomb.bag", "--out", "out", "--workers", "1"], "bomb.bag", check=_batch_refused)


# -- definitions and metadata that lie -----------------------------------------------------------------------
def image_string_height_bag(tmp: Path) -> Plan:
    rf.image_with_string_height(tmp / "lie.bag")
    return Plan(_source("lie.bag"), "lie.bag", ["sensor_msgs/msg/Image", "height: declared string"])


def image_string_height_mcap(tmp: Path) -> Plan:
    rf.image_with_string_height(tmp / "lie.mcap", "mcap-file")
    return Plan(_source("lie.mcap"), "lie.mcap", ["height: declared string"])


def cloud_string_fields_bag(tmp: Path) -> Plan:
    rf.cloud_with_string_fields(tmp / "lie.bag")
    return Plan(_source("lie.bag", SHAPE), "lie.bag", ["sensor_msgs/msg/PointCloud2", "fields: declared string"])


def cloud_string_fields_mcap(tmp: Path) -> Plan:
    rf.cloud_with_string_fields(tmp / "lie.mcap", "mcap-file")
    return Plan(_source("lie.mcap", SHAPE), "lie.mcap", ["fields: declared string"])


def metadata_message_count_lots(tmp: Path) -> Plan:
    rf.edit_metadata(rf.plain_bag_folder(tmp / "bag"), "\n  message_count: 2\n", "\n  message_count: lots\n")
    return Plan(_source("bag"), "bag", ["metadata.yaml", "message_count", "'lots'"])


def metadata_message_count_lots_list_topics(tmp: Path) -> Plan:
    rf.edit_metadata(rf.plain_bag_folder(tmp / "bag"), "\n  message_count: 2\n", "\n  message_count: lots\n")
    return Plan(detect("--list-topics", "bag"), "bag", ["message_count", "'lots'"])


CASES: dict[str, Callable[[Path], Plan]] = {
    "bomb-ros1-bz2-chunk": ros1_bz2_chunk,
    "bomb-ros1-lz4-chunk": ros1_lz4_chunk,
    "bomb-ros1-bz2-chunk-declaring-1gb": ros1_bz2_chunk_declaring_1gb,
    "bomb-ros1-lz4-chunk-declaring-200mb": ros1_lz4_chunk_declaring_200mb,
    "bomb-ros1-bz2-chunk-3d-source": ros1_bz2_chunk_cloud,
    "bomb-mcap-zstd-chunk": mcap_zstd_chunk,
    "bomb-mcap-zstd-chunk-streamed-frames": mcap_streamed_zstd_chunk,
    "bomb-mcap-lz4-chunk": mcap_lz4_chunk,
    "bomb-mcap-zstd-chunk-declaring-3gb": mcap_zstd_chunk_declaring_3gb,
    "bomb-mcap-zstd-chunk-declaring-1gb": mcap_zstd_chunk_declaring_its_size,
    "bomb-ros2-message-zstd": ros2_message_zstd,
    "bomb-ros2-message-zstd-streamed-frames": ros2_streamed_message_zstd,
    "bomb-ros2-file-compressed-30gb": ros2_file_compressed_30gb,
    "bomb-ros2-file-compressed-list-topics": ros2_file_compressed_list_topics,
    "bomb-ros1-chunk-list-topics": list_topics_of_a_chunk_bomb,
    "bomb-ros1-chunk-batch": batch_of_a_chunk_bomb,
    "lie-image-string-height-bag": image_string_height_bag,
    "lie-image-string-height-mcap": image_string_height_mcap,
    "lie-cloud-string-fields-bag": cloud_string_fields_bag,
    "lie-cloud-string-fields-mcap": cloud_string_fields_mcap,
    "metadata-message-count-lots": metadata_message_count_lots,
    "metadata-message-count-lots-list-topics": metadata_message_count_lots_list_topics,
}


def _digest(path: Path) -> dict[str, str]:
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    return {str(f.relative_to(path.parent)): hashlib.sha256(f.read_bytes()).hexdigest() for f in files}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_hostile_recording(case: str, tmp_path: Path) -> None:
    plan = CASES[case](tmp_path)
    before = _digest(tmp_path / plan.recording)
    outcome = run(plan.argv, tmp_path)
    if plan.check is not None:
        problems = plan.check(outcome, tmp_path)
        assert not problems, "; ".join(problems) + "\n" + outcome.describe()
    else:
        assert_refused(outcome, [plan.recording, *plan.names], plan.outputs)
    assert _digest(tmp_path / plan.recording) == before, "the recording changed"
