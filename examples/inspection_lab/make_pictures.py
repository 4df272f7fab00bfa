"""Make the pictures of docs/inspection.md from this example (run after make_lab.py).

    .venv/bin/python examples/inspection_lab/make_pictures.py [OUT_DIR]

``inspection_camera.png``: what the robot's camera sees at each pose of the mission, with what the pose's
detect tasks found drawn on it (3D boxes projected, 2D outlines); ``inspection_map.png``: the report's
picture of a run in which the blue ball was taken away and the red box pushed 0.8 m (absent, moved).
Default OUT_DIR: docs/images.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import cv2
import numpy as np

from navigation.camera import RGBDCamera
from objrec_apps.inspection import load_mission, open_inspection
from objrec_apps.inspection.detect_task import DetectTask

HERE = Path(__file__).resolve().parent
EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]

log = logging.getLogger("make_pictures")


def draw_found(image: np.ndarray, frame: object, task: DetectTask) -> None:
    """Run one detect task's system on a frame and draw each object's outline and name."""
    f = frame
    kind, system = task.data_kind, task.system
    objects = system.process(kind.from_rgbd(f.color, f.depth, f.fx, f.fy, f.cx, f.cy)).objects
    for obj in objects:
        outline = kind.outlines(system.object_array_type(objects=[obj]))[0]
        if outline.box is not None:
            box = np.asarray(outline.box, np.float64)
            px = np.stack([f.fx * box[:, 0] / box[:, 2] + f.cx, f.fy * box[:, 1] / box[:, 2] + f.cy], axis=1)
            pts = np.round(px).astype(np.int32)
            for a, b in EDGES:
                cv2.line(image, tuple(pts[a]), tuple(pts[b]), (0, 255, 255), 2, cv2.LINE_AA)
            anchor = pts[:, 0].min(), pts[:, 1].min() - 8
        else:
            poly = np.round(np.asarray(outline.polygon)).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(image, [poly], True, (0, 255, 255), 2, cv2.LINE_AA)
            anchor = poly[:, 0, 0].min(), poly[:, 0, 1].min() - 8
        cv2.putText(image, obj.name, (int(anchor[0]), int(max(anchor[1], 20))), cv2.FONT_HERSHEY_SIMPLEX, 0.7,
                    (0, 255, 255), 2, cv2.LINE_AA)


def camera_strip(out: Path) -> None:
    mission = load_mission(HERE / "mission.yaml")
    inspection = open_inspection(HERE / "mission.yaml", HERE / "lab.yaml", HERE / "lab.world.yaml")
    camera = RGBDCamera()
    tiles = []
    for i, goal in enumerate(mission.poses.goals):
        frame = camera.render(inspection.world, inspection.map, goal, 0.0)
        image = frame.color.copy()
        for task in mission.tasks[i]:
            if isinstance(task, DetectTask):
                draw_found(image, frame, task)
        cv2.putText(image, f"POSE_{i}", (10, 470), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 2, cv2.LINE_AA)
        tiles.append(cv2.resize(image, (480, 360), interpolation=cv2.INTER_AREA))
    grid = np.vstack([np.hstack(tiles[:2]), np.hstack(tiles[2:])])
    cv2.imwrite(str(out / "inspection_camera.png"), grid)
    log.info("wrote %s", out / "inspection_camera.png")


def changed_run(out: Path) -> None:
    inspection = open_inspection(HERE / "mission.yaml", HERE / "lab.yaml", HERE / "lab.world.yaml",
                                 remove=["blue_ball"], shift=[("red_box", 0.8, 0.0)])
    summary = inspection.run(handle_sigint=False)
    cv2.imwrite(str(out / "inspection_map.png"), inspection.picture(summary))
    log.info("wrote %s", out / "inspection_map.png")


def main() -> None:
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    log.setLevel(logging.INFO)
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parents[1] / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    camera_strip(out)
    changed_run(out)


if __name__ == "__main__":
    main()
