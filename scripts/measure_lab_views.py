"""Measure the inspection lab from every side: recall per object and direction of the settings it ships.

The example mission (``examples/inspection_lab``) checks each object from one pose, and from there the
shipped parameter files find it. Would they from anywhere else? This script places the simulated RGB-D
camera around each object the mission expects, at 12 directions (every 30 degrees; 0 is east of the object,
+x of the map, 90 north) and at 1 to 3 m from its centre, facing it, runs the parameter files the mission
runs at that object's pose (its ``detect`` tasks that look for the object's label) on each view, and counts
the object found when one of them places an object of its label within the mission's tolerance of the world
file's position, exactly as the inspection's verdict ``present`` is decided (:mod:`objrec_apps.inspection`).

A view is left out where the robot cannot stand (in a wall, the cabinet or another object: ``blocked``) and
counted apart where the object is not in sight (hidden behind something, or fewer than ``--min-points``
pixels with depth: ``hidden``); recall is over the views in sight. It prints a table per object (rows:
directions, one mark per distance: ``+`` found in every frame, ``~`` in some, ``.`` in none, ``h`` hidden,
``x`` blocked; each view is rendered ``--repeats`` times, as the sensor's noise changes what is found) and a
summary, and with ``--picture`` draws the map around each object with every view as a dot (green found,
yellow in some frames, red missed, grey hidden), the polar plot of where the settings work.

``--truth PATH`` writes the ground truth of every frame rendered (the camera knows what it drew:
:meth:`navigation.camera.RGBDFrame.truth`) as a 3D label file; ``--views PATH`` lists the views (JSON: the
object, direction, distance, robot pose, outcome, the index of the view's first frame in the truth file and
the objects in sight with their pixels and visible points).

    .venv/bin/python scripts/measure_lab_views.py --picture docs/images/quality-lab-views.png
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from navigation.camera import RGBDCamera, RGBDFrame
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.maps import OccupancyMap, load_map
from navigation.world import World, WorldObject, load_world
from objrec_apps.camera_truth import CameraTruth
from objrec_apps.inspection import load_mission
from objrec_apps.inspection.camera_frames import camera_frames
from objrec_apps.inspection.detect_task import DetectTask
from objrec_apps.inspection.locate import locate
from strictio import write_atomically

LAB = Path(__file__).resolve().parent.parent / "examples" / "inspection_lab"
DIRECTIONS = 12
DISTANCES = (1.0, 1.5, 2.0, 2.5, 3.0)
#: The robot's footprint radius (a TurtleBot 2): a view whose robot would overlap anything is blocked.
ROBOT_RADIUS = 0.18
#: Fewer pixels with depth than this and the object is not in sight.
MIN_POINTS = 200

#: Frames rendered per view: the sensor's noise differs from frame to frame, and so does what is found.
REPEATS = 3

FOUND, PARTLY, MISSED, HIDDEN, BLOCKED = "found", "partly", "missed", "hidden", "blocked"
MARKS = {FOUND: "+", PARTLY: "~", MISSED: ".", HIDDEN: "h", BLOCKED: "x"}

log = logging.getLogger("measure_lab_views")


@dataclass
class View:
    """One camera placement around one object, and what came of it."""

    direction_deg: float
    distance: float
    outcome: str
    visible_points: int = 0
    error_m: float | None = None
    frame: int | None = None  # the view's frame in the truth file (None: blocked, not rendered)
    robot: tuple[float, float, float] | None = None
    in_sight: list[dict] = field(default_factory=list)
    found: int = 0  # frames of the view where the object was found
    tries: int = 0  # frames of the view scored


@dataclass
class ObjectViews:
    name: str
    label: str
    params: list[str]
    tolerance: float
    views: list[View] = field(default_factory=list)

    def count(self, outcome: str, direction: float | None = None) -> int:
        return sum(v.outcome == outcome and (direction is None or v.direction_deg == direction) for v in self.views)

    def frames(self, direction: float | None = None) -> tuple[int, int]:
        """Frames where the object was found, and frames scored (of views in sight)."""
        views = [v for v in self.views if direction is None or v.direction_deg == direction]
        return sum(v.found for v in views), sum(v.tries for v in views)

    def recall(self, direction: float | None = None) -> float | None:
        found, tries = self.frames(direction)
        return found / tries if tries else None


def expected_objects(mission_path: Path) -> list[tuple[str, str, float, list[DetectTask]]]:
    """Each object the mission expects: name, label, tolerance and the detect tasks that look for it there."""
    mission = load_mission(mission_path)
    out = []
    for index, expected in enumerate(mission.expected):
        tasks = [t for t in mission.tasks[index] if isinstance(t, DetectTask)]
        for e in expected:
            out.append((e.name, e.label, e.tolerance, [t for t in tasks if e.label in t.labels]))
    return out


def blocked(walls: ObstacleField, world: World, x: float, y: float) -> bool:
    """Whether the robot could not stand at (x, y): outside the map, in a wall or on a solid."""
    i, j = walls.cell(x, y)
    return not walls.inside(i, j) or walls.collides(x, y, ROBOT_RADIUS) or world.collides(x, y, ROBOT_RADIUS)


def measure_object(name: str, label: str, tolerance: float, tasks: list[DetectTask], camera: RGBDCamera,
                   occ_map: OccupancyMap, world: World, walls: ObstacleField, min_points: int,
                   truth: CameraTruth, repeats: int = REPEATS) -> ObjectViews:
    target: WorldObject = world.get(name)  # type: ignore[assignment]
    cx, cy, _ = target.centre
    result = ObjectViews(name, label, [Path(t.values["params"]).name for t in tasks], tolerance)
    for k in range(DIRECTIONS):
        direction = 360.0 * k / DIRECTIONS
        a = math.radians(direction)
        for d in DISTANCES:
            x, y = cx + d * math.cos(a), cy + d * math.sin(a)
            if blocked(walls, world, x, y):
                result.views.append(View(direction, d, BLOCKED))
                continue
            pose = Pose2D(x, y, math.atan2(cy - y, cx - x))
            frame = camera.render(world, occ_map, pose)
            seen = {s.name: s for s in frame.truth()}
            points = seen[name].visible_points if name in seen else 0
            index = truth.add(frame).index
            where = (round(x, 4), round(y, 4), round(pose.yaw, 6))
            in_sight = [s.as_dict(extras=True) for s in seen.values()]
            if points < min_points:
                result.views.append(View(direction, d, HIDDEN, points, None, index, where, in_sight))
                continue
            errors = [nearest_found(frame, pose, tasks, label, (cx, cy))]
            for _ in range(repeats - 1):  # the same view again: new noise, new dropouts
                again = camera.render(world, occ_map, pose)
                truth.add(again)
                errors.append(nearest_found(again, pose, tasks, label, (cx, cy)))
            found = sum(e is not None and e <= tolerance for e in errors)
            outcome = FOUND if found == repeats else MISSED if found == 0 else PARTLY
            placed = [e for e in errors if e is not None]
            error = min(placed) if placed else None
            result.views.append(View(direction, d, outcome, points, error, index, where, in_sight, found, repeats))
            log.info("%s %3.0f deg %.1f m: found in %d of %d frames (%d points, error %s)", name, direction, d,
                     found, repeats, points, "-" if error is None else f"{error:.2f} m")
    return result


def nearest_found(frame: RGBDFrame, pose: Pose2D, tasks: list[DetectTask], label: str,
                  where: tuple[float, float]) -> float | None:
    """Horizontal distance from ``where`` to the nearest object of ``label`` the tasks' systems place (None: none)."""
    best: float | None = None
    for task in tasks:
        kind, system = task.data_kind, task.system
        data = camera_frames(kind).from_rgbd(frame.color, frame.depth, frame.fx, frame.fy, frame.cx, frame.cy)
        result = system.process(data)
        for s in locate(kind, system.object_array_type, list(result.objects), frame, pose, "view", 0.0):
            if s.name == label:
                error = math.hypot(s.x - where[0], s.y - where[1])
                best = error if best is None else min(best, error)
    return best


# -- output ------------------------------------------------------------------------------------------------
def table(results: Sequence[ObjectViews]) -> str:
    """Markdown: per object and direction, recall over the views in sight, and the mark of each distance."""
    head = "| direction | " + " | ".join(f"{r.name} ({', '.join(r.params)})" for r in results) + " |"
    lines = [head, "|---|" + "---|" * len(results)]
    for k in range(DIRECTIONS):
        direction = 360.0 * k / DIRECTIONS
        cells = []
        for r in results:
            rec = r.recall(direction)
            marks = "".join(MARKS[v.outcome] for v in r.views if v.direction_deg == direction)
            cells.append(f"{'-' if rec is None else f'{rec:.0%}'} `{marks}`")
        lines.append(f"| {direction:.0f} deg | " + " | ".join(cells) + " |")
    totals = []
    for r in results:
        rec = r.recall()
        found, tries = r.frames()
        totals.append(f"**{'-' if rec is None else f'{rec:.0%}'}** ({found}/{tries} frames; "
                      f"{r.count(HIDDEN)} views hidden, {r.count(BLOCKED)} blocked)")
    lines.append("| all | " + " | ".join(totals) + " |")
    return "\n".join(lines)


def sides_failing(r: ObjectViews) -> tuple[int, int]:
    """Directions with a view in sight, and those of them where recall is below one half."""
    rated = [r.recall(360.0 * k / DIRECTIONS) for k in range(DIRECTIONS)]
    rated = [x for x in rated if x is not None]
    return len(rated), sum(x < 0.5 for x in rated)


PANEL = 420
SCALE = PANEL / (2 * 3.6)  # pixels per metre: 3.6 m around the object
COLORS = {FOUND: (60, 170, 40), PARTLY: (30, 190, 240), MISSED: (40, 40, 220), HIDDEN: (170, 170, 170)}


def picture(results: Sequence[ObjectViews], occ_map: OccupancyMap, world: World) -> np.ndarray:
    """One panel per object: the map around it, rings at each distance, every view a dot (or a cross: blocked)."""
    panels = [panel(r, occ_map, world) for r in results]
    while len(panels) % 2:
        panels.append(np.full_like(panels[0], 255))
    rows = [np.hstack(panels[i:i + 2]) for i in range(0, len(panels), 2)]
    legend = np.full((62, rows[0].shape[1], 3), 255, np.uint8)
    x = 10
    keys = ((FOUND, "found"), (PARTLY, "in some frames"), (MISSED, "missed"), (HIDDEN, "not in sight"),
            (BLOCKED, "robot cannot stand"))
    for outcome, text in keys:
        if outcome == BLOCKED:
            cv2.drawMarker(legend, (x + 6, 20), (30, 30, 30), cv2.MARKER_TILTED_CROSS, 10, 1, cv2.LINE_AA)
        else:
            cv2.circle(legend, (x + 6, 20), 6, COLORS[outcome], -1, cv2.LINE_AA)
        cv2.putText(legend, text, (x + 18, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (30, 30, 30), 1, cv2.LINE_AA)
        x += 40 + 9 * len(text)
    span = f"{DISTANCES[0]:g}-{DISTANCES[-1]:g}"
    cv2.putText(legend, f"a dot: the camera at {span} m facing the object; rings 1, 2, 3 m; "
                "0 deg = east (+x); grey: walls, the map's outside, other solids",
                (10, 50), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (30, 30, 30), 1, cv2.LINE_AA)
    return np.vstack([*rows, legend])


def panel(r: ObjectViews, occ_map: OccupancyMap, world: World) -> np.ndarray:
    target = world.get(r.name)
    cx, cy = target.centre[0], target.centre[1]  # type: ignore[union-attr]
    img = np.full((PANEL, PANEL, 3), 255, np.uint8)
    # The map around the object: each pixel's map cell, walls dark grey, unknown light grey.
    us, vs = np.meshgrid(np.arange(PANEL), np.arange(PANEL))
    mx = cx + (us - PANEL / 2) / SCALE
    my = cy - (vs - PANEL / 2) / SCALE
    walls = ObstacleField(occ_map).obstacle  # padded by one solid cell all round
    gx, gy = occ_map.world_to_grid(mx, my)
    i, j = np.floor(gx).astype(np.int64) + 1, np.floor(gy).astype(np.int64) + 1
    inside = (i >= 0) & (i < walls.shape[1]) & (j >= 0) & (j < walls.shape[0])
    solid = np.ones((PANEL, PANEL), bool)
    solid[inside] = walls[j[inside], i[inside]]
    img[solid] = (160, 160, 160)
    for thing in world.solids_at(0.0):
        fp = thing.footprint()
        corners = fp.corners() if not fp.is_circle else None
        mine = thing.name == r.name
        colour = tuple(int(c) for c in thing.color) if mine and thing.shape != "poster" else (150, 150, 150)
        if corners is None:
            centre = _px(fp.x, fp.y, cx, cy)
            cv2.circle(img, centre, max(2, round(fp.radius * SCALE)), colour, -1, cv2.LINE_AA)
            if mine:
                cv2.circle(img, centre, max(2, round(fp.radius * SCALE)), (0, 0, 0), 2, cv2.LINE_AA)
        else:
            pts = np.array([_px(a, b, cx, cy) for a, b in corners], np.int32)
            cv2.fillPoly(img, [pts], colour, cv2.LINE_AA)
            if mine:
                cv2.polylines(img, [pts], True, (0, 0, 0), 3 if thing.shape == "poster" else 2, cv2.LINE_AA)
    for d in (1.0, 2.0, 3.0):
        cv2.circle(img, (PANEL // 2, PANEL // 2), round(d * SCALE), (200, 160, 120), 1, cv2.LINE_AA)
    for v in r.views:
        a = math.radians(v.direction_deg)
        p = _px(cx + v.distance * math.cos(a), cy + v.distance * math.sin(a), cx, cy)
        if v.outcome == BLOCKED:
            if 0 <= p[0] < PANEL and 0 <= p[1] < PANEL and not solid[p[1], p[0]]:  # in a wall: plainly so
                cv2.drawMarker(img, p, (30, 30, 30), cv2.MARKER_TILTED_CROSS, 8, 1, cv2.LINE_AA)
        else:
            cv2.circle(img, p, 6, COLORS[v.outcome], -1, cv2.LINE_AA)
            cv2.circle(img, p, 6, (40, 40, 40), 1, cv2.LINE_AA)
    rec = r.recall()
    title = f"{r.name}: recall {'-' if rec is None else f'{rec:.0%}'} ({', '.join(r.params)})"
    cv2.rectangle(img, (0, 0), (PANEL - 1, 26), (255, 255, 255), -1)
    cv2.putText(img, title, (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (20, 20, 20), 1, cv2.LINE_AA)
    cv2.rectangle(img, (0, 0), (PANEL - 1, PANEL - 1), (120, 120, 120), 1)
    return img


def _px(x: float, y: float, cx: float, cy: float) -> tuple[int, int]:
    return (round(PANEL / 2 + (x - cx) * SCALE), round(PANEL / 2 - (y - cy) * SCALE))


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mission", type=Path, default=LAB / "mission.yaml", help="the mission (default: the lab's)")
    p.add_argument("--map", type=Path, default=LAB / "lab.yaml", help="its map")
    p.add_argument("--world", type=Path, default=LAB / "lab.world.yaml", help="its world file")
    p.add_argument("--objects", nargs="*", metavar="NAME", help="only these expected objects")
    p.add_argument("--min-points", type=int, default=MIN_POINTS,
                   help=f"pixels with depth an object needs to be in sight (default {MIN_POINTS})")
    p.add_argument("--seed", type=int, default=0, help="the camera's noise seed")
    p.add_argument("--repeats", type=int, default=REPEATS, help=f"frames per view (default {REPEATS})")
    p.add_argument("--picture", type=Path, help="write the polar plots (PNG)")
    p.add_argument("--truth", type=Path, help="write every rendered view's ground truth (a 3D label file)")
    p.add_argument("--views", type=Path, help="write every view: where, outcome, objects in sight (JSON)")
    p.add_argument("-v", "--verbose", action="store_true")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(message)s")
    occ_map, world = load_map(args.map), load_world(args.world)
    walls = ObstacleField(occ_map)
    camera = RGBDCamera(random_seed=args.seed)
    truth = CameraTruth()
    results = []
    for name, label, tolerance, tasks in expected_objects(args.mission):
        if args.objects and name not in args.objects:
            continue
        if not tasks:
            log.warning("%s: no detect task looks for %r at its pose; skipped", name, label)
            continue
        results.append(measure_object(name, label, tolerance, tasks, camera, occ_map, world, walls,
                                      args.min_points, truth, max(1, args.repeats)))
    sys.stdout.write(table(results) + "\n\n")
    for r in results:
        rated, failing = sides_failing(r)
        found, tries = r.frames()
        sys.stdout.write(f"{r.name}: found in {found} of {tries} frames of views in sight; "
                         f"recall below 50 % from {failing} of {rated} directions\n")
    if args.picture:
        ok, png = cv2.imencode(".png", picture(results, occ_map, world))
        if ok:
            write_atomically(args.picture, png.tobytes())
    if args.truth:
        truth.write(args.truth)
    if args.views:
        write_atomically(args.views, json.dumps([{"name": r.name, "label": r.label, "params": r.params,
                                                  "views": [v.__dict__ for v in r.views]} for r in results],
                                                indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
