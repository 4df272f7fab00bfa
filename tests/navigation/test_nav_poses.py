"""The goal-pose file format: x, y, z, qx, qy, qz, qw per line."""

from __future__ import annotations

import math

import pytest

from navigation.geometry import Pose2D, quaternion_from_yaw, yaw_from_quaternion
from navigation.poses import PoseFileError, load_poses, parse_poses, save_poses


def test_seed_b5203_file(b5203_poses):
    assert len(b5203_poses.goals) == 15
    assert b5203_poses.station == Pose2D(14.4, 12.8, 0.0)
    first = b5203_poses.goals[0]
    assert (first.x, first.y) == (10.6897900314, 14.1520320024)
    assert first.yaw == pytest.approx(2 * math.atan2(0.0547466180359, 0.998500279326))
    # POSE_8 faces almost exactly west (qz = -0.999, qw = 0.043).
    assert abs(math.remainder(b5203_poses.goals[8].yaw - math.pi, 2 * math.pi)) < 0.1


def test_comments_blank_lines_and_empty_station():
    text = "# header\n\nstation_pose:\n1, 2, 0, 0, 0, 0, 1   # trailing comment\n\n3,4,0,0,0,1,0\n"
    pf = parse_poses(text)
    assert pf.station is None
    assert pf.goals[0] == Pose2D(1.0, 2.0, 0.0)
    assert pf.goals[1].x == 3.0 and pf.goals[1].yaw == pytest.approx(math.pi)


def test_unnormalised_quaternion_is_normalised():
    pf = parse_poses("0, 0, 0, 0, 0, 2, 2\n")
    assert pf.goals[0].yaw == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("1, 2, 3\n",
         ":1: goals[0]: '1, 2, 3' is invalid: expected 7 comma-separated numbers (x, y, z, qx, qy, qz, qw), got 3"),
        ("# c\n1, 2, 0, 0, 0, zero, 1\n", ":2: goals[0].qz: 'zero' is invalid: expected a number"),
        ("1, 2, 0, 0, 0, 0, 0\n", ":1: goals[0]: '1, 2, 0, 0, 0, 0, 0' is invalid: the orientation quaternion is zero"),
        ("1, nan, 0, 0, 0, 0, 1\n", ":1: goals[0].y: 'nan' is invalid: expected a finite number"),
        ("station_pose: 1, 2\n1, 2, 0, 0, 0, 0, 1\n", ":1: station_pose: '1, 2' is invalid: expected 7"),
        ("station_pose:\nstation_pose:\n1, 2, 0, 0, 0, 0, 1\n",
         ":2: station_pose: a second station_pose (the first is on line 1)"),
        ("# nothing here\nstation_pose: 1, 2, 0, 0, 0, 0, 1\n", "no goal poses"),
    ],
)
def test_errors_name_file_line_and_text(tmp_path, text, needle):
    path = tmp_path / "poses.txt"
    path.write_text(text)
    with pytest.raises(PoseFileError) as err:
        load_poses(path)
    assert str(err.value).startswith(f"{path}:")
    assert needle in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(PoseFileError, match="pose file not found"):
        load_poses(tmp_path / "none.txt")


def test_save_and_load_round_trip(tmp_path):
    goals = [Pose2D(1.5, -2.25, 0.7), Pose2D(0.0, 3.0, -2.9)]
    path = save_poses(tmp_path / "p.txt", goals, Pose2D(4.0, 5.0, 3.1), comment="made by a test")
    pf = load_poses(path)
    assert pf.station is not None and pf.station.x == 4.0 and pf.station.yaw == pytest.approx(3.1)
    for a, b in zip(pf.goals, goals, strict=True):
        assert (a.x, a.y) == (b.x, b.y) and a.yaw == pytest.approx(b.yaw)


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5, math.pi - 1e-6])
def test_quaternion_yaw_round_trip(yaw):
    assert yaw_from_quaternion(*quaternion_from_yaw(yaw)) == pytest.approx(yaw)


def test_numpy_numbers_are_saved_as_plain_numbers(tmp_path):
    """Poses computed with NumPy (np.float64 fields) used to be written as 'np.float64(1.25)'."""
    import numpy as np

    goals = [Pose2D(np.float64(1.25), np.float64(-2.5), np.float64(0.75)), Pose2D(np.float32(3.0), 4, 0)]
    path = save_poses(tmp_path / "np.txt", goals, station=Pose2D(np.float64(0.5), np.float64(0.5), np.float64(0)))
    assert "np." not in path.read_text()
    loaded = load_poses(path)
    assert [(g.x, g.y) for g in loaded.goals] == [(1.25, -2.5), (3.0, 4.0)]
    assert loaded.goals[0].yaw == pytest.approx(0.75)
    assert loaded.station == Pose2D(0.5, 0.5, 0.0)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    """Editors on Windows start UTF-8 files with a BOM; the first pose (or comment) must still parse."""
    path = tmp_path / "bom.txt"
    path.write_bytes(b"\xef\xbb\xbf1.5, 2, 0, 0, 0, 0, 1\nstation_pose: 0, 0, 0, 0, 0, 0, 1\n")
    loaded = load_poses(path)
    assert loaded.goals == (Pose2D(1.5, 2.0, 0.0),) and loaded.station == Pose2D(0.0, 0.0, 0.0)
    path.write_bytes(b"\xef\xbb\xbf# comment\n1, 2, 0, 0, 0, 0, 1\n")
    assert load_poses(path).goals == (Pose2D(1.0, 2.0, 0.0),)
