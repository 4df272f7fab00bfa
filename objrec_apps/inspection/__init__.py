"""The inspection patrol: the robot visits poses, runs recognition there and reports what is where.

It composes the two halves of the project without either knowing the other: the patrol
(:mod:`navigation`, which imports no ``objrec_*``) runs the mission's tasks through its task API, and the
``detect`` task (:mod:`.detect_task`) feeds the simulated camera's frames to any parameter file whose kind
implements the app's optional kind protocol :class:`TakesRGBD`. ``objrec-inspect`` (:mod:`objrec_apps.inspect`)
is the command.
"""

from .camera_frames import NoCameraFrames, TakesRGBD, camera_frames
from .mission import Expected, Mission, MissionError, load_mission
from .session import Inspection, InspectionError, changed_world, open_inspection

__all__ = [
    "Expected",
    "Inspection",
    "InspectionError",
    "Mission",
    "MissionError",
    "NoCameraFrames",
    "TakesRGBD",
    "camera_frames",
    "changed_world",
    "load_mission",
    "open_inspection",
]
