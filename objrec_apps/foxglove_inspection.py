"""An inspection served live to Foxglove (``objrec-inspect --foxglove [HOST:]PORT``, the ``viz`` extra).

Everything the patrol's view serves (:mod:`navigation.foxglove_log`: map, pose, path, scan, goals, plan,
state, events, batteries), and what the inspection adds:

- ``/inspection/camera``: every frame the robot's camera takes for a task (a photo, a look around, a
  detection), as ``foxglove.RawImage`` (bgr8, frame ``camera``), stamped with the patrol's time;
- ``/inspection/sightings``: every object a detection task placed in the map, a sphere at its map position
  with its name (``foxglove.SceneUpdate``, frame ``map``), all of the run so far in each message and sent
  again to a viewer that subscribes later.
"""

from __future__ import annotations

from typing import Any

from foxgloveio.server import Address, timestamp
from navigation.foxglove_log import MAP_FRAME, PatrolView, open_patrol_view

from .foxglove_view import raw_image
from .inspection import Inspection

CAMERA_TOPIC = "/inspection/camera"
SIGHTINGS_TOPIC = "/inspection/sightings"
#: Diameter of a sighting's sphere, metres.
SIGHTING_SIZE = 0.15
SIGHTING_RGBA = {"r": 1.0, "g": 0.4, "b": 0.0, "a": 0.9}


class InspectionView:
    """The patrol's live view of an inspection, with its camera frames and sightings; :meth:`close` stops it."""

    def __init__(self, address: Address, inspection: Inspection, *, name: str = "objrec-inspect") -> None:
        from foxglove.channels import RawImageChannel, SceneUpdateChannel

        poses = inspection.mission.poses
        self.patrol: PatrolView = open_patrol_view(address, inspection.sim, inspection.map, inspection.machine,
                                                   poses.goals, poses.station, name=name)
        server = self.patrol.server
        try:
            self.camera = server.channel(RawImageChannel, CAMERA_TOPIC)
            self.sightings = server.channel(SceneUpdateChannel, SIGHTINGS_TOPIC)
        except BaseException:
            self.patrol.close()
            raise
        self.found: list[dict[str, Any]] = []
        self.machine = inspection.machine
        self._camera = inspection.machine.camera
        if self._camera is not None:
            inspection.machine.camera = self._shoot
        self._unsubscribe = inspection.sim.events.subscribe(self._on_event)

    @property
    def url(self) -> str:
        return self.patrol.server.url

    def _shoot(self) -> Any:
        """The robot's camera, each frame also served."""
        frame = self._camera()
        if self.patrol.server.wanted(self.camera):
            when = self.patrol.now_ns()
            self.camera.log(raw_image(frame.color, timestamp(when), "camera"), log_time=when)
        return frame

    def _on_event(self, event: dict[str, Any]) -> None:
        if event.get("type") != "detection":
            return
        from foxglove.messages import (
            Color,
            Pose,
            Quaternion,
            SceneEntity,
            SceneUpdate,
            SpherePrimitive,
            TextPrimitive,
            Vector3,
        )

        self.found.append(event)
        when = self.patrol.now_ns(float(event["t"]))
        stamp = timestamp(when)
        colour = Color(**SIGHTING_RGBA)
        white = Color(r=1.0, g=1.0, b=1.0, a=1.0)
        entities = []
        for i, seen in enumerate(self.found):
            x, y, z = float(seen["x"]), float(seen["y"]), float(seen["z"])
            at = Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(w=1.0))
            above = Pose(position=Vector3(x=x, y=y, z=z + SIGHTING_SIZE), orientation=Quaternion(w=1.0))
            entities.append(SceneEntity(
                timestamp=stamp, frame_id=MAP_FRAME, id=f"sighting/{i}",
                spheres=[SpherePrimitive(pose=at, size=Vector3(x=SIGHTING_SIZE, y=SIGHTING_SIZE, z=SIGHTING_SIZE),
                                         color=colour)],
                texts=[TextPrimitive(pose=above, billboard=True, font_size=14.0, scale_invariant=True, color=white,
                                     text=str(seen.get("name", "")))]))
        self.patrol.server.latch(self.sightings, SceneUpdate(entities=entities), when)

    def close(self) -> None:
        """Unhook from the inspection and stop serving; closing again does nothing."""
        self._unsubscribe()
        if self._camera is not None and self.machine.camera == self._shoot:
            self.machine.camera = self._camera
        self.patrol.close()
