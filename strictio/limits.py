"""How much of anything one input may claim: declared once here, documented, and raisable by whoever has a
real huge map or cloud.

A file's header can claim far more than its bytes (a PNG of a few kilobytes that decodes to 20000x20000
pixels, a compressed PCD that claims 4 GB of points); each reader asks :func:`check` with the claimed amount
*before* it allocates, so the refusal costs nothing. Every limit has an environment variable that raises or
lowers it for one run; its value is checked like any other number the user gives.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from .errors import InputError
from .shown import printable


@dataclass(frozen=True)
class Limit:
    """One declared limit: its name, what it counts, the default and the variable that overrides it."""

    name: str
    unit: str
    default: int
    description: str

    @property
    def variable(self) -> str:
        return "OBJREC_MAX_" + self.name.upper()

    def value(self) -> int:
        """The limit in force: the environment variable when it is set, else the default."""
        text = os.environ.get(self.variable)
        if text is None or not text.strip():
            return self.default
        try:
            number = int(text.strip().replace("_", ""))
        except ValueError:
            raise LimitSettingError(self, text) from None
        if number < 1 or number > 2**62:
            raise LimitSettingError(self, text)
        return number


class LimitSettingError(InputError):
    """An environment variable that sets a limit holds something other than a positive whole number; an
    InputError, so that every command reports it like any other bad input (one line, exit code 2)."""

    def __init__(self, limit: Limit, text: str) -> None:
        shown = printable(text, 40)
        super().__init__(f"environment variable {limit.variable}",
                         f"'{shown}' is not a whole number of {limit.unit} between 1 and 2**62")


class LimitError(InputError):
    """An input that claims more than a declared limit; the message names the limit and how to raise it."""

    def __init__(self, path: object, limit: Limit, claimed: int, what: str = "", where: str = "") -> None:
        self.limit = limit
        self.claimed = claimed
        subject = f"{what}: " if what else ""
        super().__init__(
            str(path),
            f"{subject}{claimed:,} {limit.unit}, over the limit of {limit.value():,} {limit.unit}"
            f" (set {limit.variable} to raise it)",
            where,
        )


IMAGE_PIXELS = Limit("image_pixels", "pixels", 100_000_000,
                     "an image (source frame, embedded target, map or poster), width x height")
CLOUD_POINTS = Limit("cloud_points", "points", 20_000_000, "a point cloud, points claimed by its header")
#: The patrol's planner and costmaps keep some 75 bytes a cell: a 2000x2000 map at this limit runs
#: objrec-patrol in about 410 MB (a 3000x3000 one in 790 MB, a 5000x5000 one in 2 GB).
MAP_CELLS = Limit("map_cells", "cells", 4_000_000, "an occupancy map, width x height cells")
POSES = Limit("poses", "poses", 10_000, "a pose file, poses")
YAML_NODES = Limit("yaml_nodes", "nodes", 1_000_000, "a YAML document, values and collections")
#: A 4K RGB image is 25 MB, a 20-million-point cloud (the cloud limit) of x, y, z, rgb some 320 MB.
LIVE_MESSAGE_BYTES = Limit("live_message_bytes", "bytes", 1 << 30,
                           "a live ROS 1 message from a peer (TCPROS), serialized")
#: A compressed chunk is inflated whole, so a bomb costs this much memory (256 MiB keeps one under 500 MB); a
#: compressed message at the image or cloud limit (10000 x 10000 bgr8 300 MB, 20 M points of x, y, z, rgb 320 MB)
#: needs it raised, and then costs the chunk plus its decoded copy. Uncompressed chunks are not inflated.
RECORDING_CHUNK_BYTES = Limit("recording_chunk_bytes", "bytes", 256 << 20,
                              "a recording's compressed chunk or message (ROS 1 bz2/lz4, MCAP zstd/lz4, ROS 2 "
                              "zstd), inflated")
RECORDING_TEMP_BYTES = Limit("recording_temp_bytes", "bytes", 2 << 30,
                             "a file-compressed ROS 2 bag, its storage files inflated into the temp folder "
                             "(also never more than the folder's free space)")
#: A poster is drawn into 640x480 camera frames, so it is kept at most 1024 pixels on its long side; this
#: bounds what is decoded first (16 M pixels: some 100 MB while it is read, one poster at a time).
POSTER_PIXELS = Limit("poster_pixels", "pixels", 16_000_000,
                      "a world file's poster picture, width x height (decoded, then kept at most 1024 pixels wide)")
#: Each task runs at every visit of its pose, a detect task builds a recognition system: a mission's task lists
#: are for a handful of tasks a pose.
MISSION_TASKS = Limit("mission_tasks", "tasks", 1_000, "a mission file, tasks listed (its own and every pose's)")

#: Every declared limit, in the order the documentation lists them.
ALL_LIMITS: tuple[Limit, ...] = (IMAGE_PIXELS, CLOUD_POINTS, MAP_CELLS, POSES, YAML_NODES, LIVE_MESSAGE_BYTES,
                                  RECORDING_CHUNK_BYTES, RECORDING_TEMP_BYTES, POSTER_PIXELS, MISSION_TASKS)


def check(path: object, limit: Limit, claimed: int, what: str = "", where: str = "") -> None:
    """Refuse ``claimed`` (what the input says it holds) when it is over ``limit``."""
    if claimed > limit.value():
        raise LimitError(path, limit, claimed, what, where)
