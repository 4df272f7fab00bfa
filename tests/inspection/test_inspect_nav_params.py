"""objrec-inspect takes objrec-patrol's navigation parameters: a keepout zone is never planned or driven through,
a goal inside one is warned about and aborted, and the map picture shows the zone with its legend entry."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from navigation.costmap import ObstacleField
from navigation.costmap_filters import zone_overlay
from navigation.geometry import Pose2D
from navigation.maps import OCCUPIED, OccupancyMap, load_map, save_map
from navigation.nav_params import NavParams
from navigation.planner import Planner, PlannerParams
from navigation.render import zone_legend
from navigation.simulation import SimConfig
from objrec_apps.inspect import main
from objrec_apps.inspection import open_inspection

ROOT = Path(__file__).resolve().parents[2]
LAB = ROOT / "examples" / "inspection_lab"
MAP, WORLD, POSES = LAB / "lab.yaml", LAB / "lab.world.yaml", LAB / "lab_poses.txt"
#: The example's keepout band (examples/inspection_lab/make_masks.py) across the straight way from the station
#: (4.5, 1.85) to POSE_0 (2.8, 4.5), from the free west part of the room to the table: the robot must go round it.
BAND = (1.9, 2.6, 3.7, 3.4)  # x0, y0, x1, y1 in metres
RADIUS = SimConfig().robot.radius
#: How a keepout zone looks over free space, on the map and in the legend.
KEEPOUT_SHOWN = dict(zone_legend(zone_overlay(np.ones((2, 2), bool), None, 0.5)))["keepout zone"]
SPEED_SHOWN = dict(zone_legend(zone_overlay(None, np.full((2, 2), 0.25), 0.5)))["speed zone"]


def pixels_of(image: np.ndarray, colour: tuple[int, int, int]) -> int:
    return int(np.all(np.abs(image.astype(int) - colour) <= 3, axis=-1).sum())


def keepout_mask(tmp_path: Path, box: tuple[float, float, float, float], name: str = "keepout") -> Path:
    """A keepout mask on the lab map's grid: the cells of ``box`` occupied, the rest free."""
    lab = load_map(MAP)
    data = np.zeros_like(lab.data)
    x0, y0, x1, y1 = box
    res = lab.resolution
    data[round(y0 / res):round(y1 / res), round(x0 / res):round(x1 / res)] = OCCUPIED
    path = tmp_path / f"{name}.yaml"
    save_map(OccupancyMap(data, res, lab.origin), path)
    return path


def waiting_mission(tmp_path: Path) -> Path:
    """The lab's four poses with a short wait at each: driving is all this mission does."""
    path = tmp_path / "mission.yaml"
    path.write_text(f"poses: {POSES}\nlaps: 1\ntasks:\n  - wait: 0.5\n")
    return path


def distance_to_box(xy: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray:
    x0, y0, x1, y1 = box
    dx = np.maximum(np.maximum(x0 - xy[:, 0], 0.0), xy[:, 0] - x1)
    dy = np.maximum(np.maximum(y0 - xy[:, 1], 0.0), xy[:, 1] - y1)
    return np.hypot(dx, dy)


def test_an_inspection_never_plans_or_drives_in_a_keepout_zone(tmp_path):
    station, pose_0 = Pose2D(4.5, 1.85, 1.5708), Pose2D(2.8, 4.5, 0.55)
    lab = load_map(MAP)
    # Without the zone the way to POSE_0 crosses it: the test would prove nothing otherwise.
    plain = Planner(ObstacleField(lab), PlannerParams(robot_radius=RADIUS)).plan(station, pose_0)
    assert plain.ok and (distance_to_box(plain.path, BAND) == 0.0).any()

    inspection = open_inspection(waiting_mission(tmp_path), MAP, WORLD, out_dir=tmp_path / "out",
                                 nav=NavParams(keepout_mask=LAB / "lab_keepout.yaml"))  # the example's mask
    planner = inspection.sim.move_base.planner
    assert planner is inspection.sim.planner and planner.params.keepout is not None  # built once, with the zone
    paths: list[np.ndarray] = []
    plan = planner.plan

    def recorded(*args, **kwargs):
        result = plan(*args, **kwargs)
        if result.ok:
            paths.append(result.path)
        return result

    planner.plan = recorded  # type: ignore[method-assign]
    summary = inspection.run(handle_sigint=False)
    assert (summary.goals_reached, summary.goals_aborted, summary.collisions) == (4, 0, 0)
    assert len(paths) >= 4
    planned = np.concatenate(paths)
    # Keepout cells are inflated like walls: no planned point, and no driven position, within the robot's radius.
    assert distance_to_box(planned, BAND).min() >= RADIUS - 0.05  # a cell of the mask's grid
    driven = np.asarray(inspection.sim.trajectory)[:, 1:3]
    assert distance_to_box(driven, BAND).min() >= RADIUS - 0.05
    assert driven[:, 0].min() < BAND[0]  # it went round to the west

    picture = inspection.picture(summary)
    legend = 80  # the caption and the legend's two rows above the map
    zone = (BAND[2] - BAND[0]) * (BAND[3] - BAND[1]) * (picture.shape[1] / 9.5) ** 2  # pixels, roughly
    assert pixels_of(picture[legend:], KEEPOUT_SHOWN) > 0.8 * zone  # the zone tinted on the map
    assert pixels_of(picture[:legend], KEEPOUT_SHOWN) >= 100  # and its patch in the legend


def test_objrec_inspect_takes_the_navigation_options(tmp_path, capsys, caplog):
    """A goal inside the keepout zone is warned about before the run and aborted; the legend names the zone."""
    mask = keepout_mask(tmp_path, (5.5, 4.3, 6.1, 4.9), "around_pose_3")
    out = tmp_path / "out"
    code = main([str(waiting_mission(tmp_path)), "--map", str(MAP), "--world", str(WORLD), "--out", str(out),
                 "--keepout-mask", str(mask), "--cost-scaling-factor", "4"])
    assert code == 0
    captured = capsys.readouterr()
    assert "goal POSE_3 (5.80, 4.60) is in a keepout zone; it will be aborted" in caplog.text
    assert "3 reached, 1 aborted" in captured.out
    picture = cv2.imread(str(out / "map.png"))
    assert pixels_of(picture[:80], KEEPOUT_SHOWN) >= 100  # its patch in the legend above the map
    assert pixels_of(picture[:80], SPEED_SHOWN) == 0  # no speed mask, no speed zone in the legend


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--cost-scaling-factor", "0", "--cost-scaling-factor: 0 is not above 0"),
    ("--keepout-mask", "nowhere.yaml", "nowhere.yaml"),
])
def test_bad_navigation_options_are_one_line(tmp_path, capsys, option, value, message):
    argv = [str(waiting_mission(tmp_path)), "--map", str(MAP), "--world", str(WORLD), "--out", str(tmp_path / "out"),
            option, value]
    try:
        code = main(argv)
    except SystemExit as exc:  # a value out of its declared range is the parser's usage error
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1
