"""ROS map_server maps: a YAML file of metadata beside a PGM/PNG/BMP image.

The occupancy values (0 free, 100 occupied, -1 unknown, 1..99 in ``scale`` mode) and the cell order are
those of map_server (nav2 ``map_io``): row 0 of :attr:`OccupancyMap.data` is the image's *bottom* row,
because the map's origin is its lower-left corner. Maps made for ROS therefore load here unchanged, and the
grid a map_server would publish is exactly ``OccupancyMap.data`` flattened.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from declare import Float, Ordered, Str
from declare.fields import (
    Document,
    DocumentError,
    FilePath,
    Free,
    Place,
    Record,
    Value,
    Vector,
    read_document,
)
from strictio import MAP_CELLS, InputError, YAMLLimits
from strictio.image_size import UNKNOWN_FORMAT, image_size, read_image_file, truncation
from strictio.limits import check

from .geometry import Pose2D

log = logging.getLogger(__name__)

FREE = 0
OCCUPIED = 100
UNKNOWN = -1
MODES = ("trinary", "scale", "raw")
#: A map YAML is a few lines; 64 KiB leaves room for comments and never for a bomb, nor for a megabyte of
#: keys other tools added, which are passed unread.
MAP_YAML_LIMITS = YAMLLimits(max_bytes=64 * 1024, max_depth=8)
#: Sane bounds of the numbers in a map YAML: a cell of up to a kilometre, an origin within a thousand
#: kilometres, a yaw within a few turns. Beyond them a value is a typo or an attack, and the arithmetic of
#: every conversion would lose its precision.
MAX_RESOLUTION = 1000.0
#: The finest cell: a tenth of a millimetre. Below it (``1.0e-300``) the whole map shrinks to a point, every
#: pose is off it, and the patrol could only say that its start pose is not on the map.
MIN_RESOLUTION = 1e-4
MAX_COORDINATE = 1e6
MAX_YAW = 100.0


#: A map file that cannot be used: the one error of every file reader (file, line, key, value and rule).
MapError = DocumentError


def _negate_rule(value: Any) -> str | None:
    return None if value in (0, 1) else "expected 0 or 1"


def _resolution_rule(value: float) -> str | None:
    if value < MIN_RESOLUTION:
        return f"cells finer than {MIN_RESOLUTION:g} m shrink the map to a point (metres per cell, e.g. 0.05)"
    return None


def _mode_rule(value: str) -> str | None:
    return None if value.lower() in MODES else f"expected one of {', '.join(MODES)}"


def _coordinate(name: str, bound: float, unit: str) -> Value:
    return Value(Float(0.0, f"{name}, {unit}", min=-bound, max=bound))


#: What a map YAML holds (keys other tools add pass unread, so maps made for ROS load unchanged).
MAP_FIELDS = Record({
    "image": FilePath(required=True, doc="the map image, PGM, PNG or BMP"),
    "resolution": Value(Float(0.05, "metres per cell", min=0.0, min_open=True, max=MAX_RESOLUTION), required=True,
                        check=_resolution_rule),
    "origin": Vector([_coordinate("x", MAX_COORDINATE, "m"), _coordinate("y", MAX_COORDINATE, "m"),
                      _coordinate("yaw", MAX_YAW, "rad")], ("x", "y", "yaw"), required=True,
                     doc="pose of the lower-left corner"),
    "negate": Free(default=0, kinds=(int, float, bool), what="0 or 1", check=_negate_rule),
    "occupied_thresh": Float(0.65, "occupancy above which a cell is occupied", min=0.0, max=1.0),
    "free_thresh": Float(0.196, "occupancy below which a cell is free", min=0.0, max=1.0),
    "mode": Value(Str("trinary", "how shades become occupancy"), check=_mode_rule),
}, ignore_unknown=True, rules=(Ordered("free_thresh", "occupied_thresh"),))


@dataclass(frozen=True)
class MapMetadata:
    """The fields of a map YAML file, validated."""

    image: Path
    resolution: float
    origin: Pose2D
    negate: bool = False
    occupied_thresh: float = 0.65
    free_thresh: float = 0.196
    mode: str = "trinary"


@dataclass
class OccupancyMap:
    """An occupancy grid in map_server's order (row 0 = bottom of the image) placed in the map frame.

    ``origin`` is the pose of the lower-left corner of cell (0, 0); its yaw rotates the whole grid,
    which map_server stores but most tools ignore. Conversions here honour it.
    """

    data: np.ndarray
    resolution: float
    origin: Pose2D = field(default_factory=lambda: Pose2D(0.0, 0.0, 0.0))
    source: Path | None = None

    def __post_init__(self) -> None:
        self.data = np.asarray(self.data, dtype=np.int8)
        if self.data.ndim != 2:
            raise ValueError(f"occupancy data must be 2-D, got shape {self.data.shape}")
        self._cos = math.cos(self.origin.yaw)
        self._sin = math.sin(self.origin.yaw)

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    def world_to_grid(self, x: float, y: float) -> tuple[float, float]:
        """Continuous cell coordinates (column, row); cell (i, j) covers [i, i+1) x [j, j+1)."""
        dx, dy = x - self.origin.x, y - self.origin.y
        return ((dx * self._cos + dy * self._sin) / self.resolution,
                (-dx * self._sin + dy * self._cos) / self.resolution)

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        gx, gy = self.world_to_grid(x, y)
        return math.floor(gx), math.floor(gy)

    def grid_to_world(self, gx: float, gy: float) -> tuple[float, float]:
        """Inverse of :meth:`world_to_grid`; pass ``i + 0.5`` for a cell's centre."""
        u, v = gx * self.resolution, gy * self.resolution
        return (self.origin.x + u * self._cos - v * self._sin,
                self.origin.y + u * self._sin + v * self._cos)

    def cell_to_world(self, i: int, j: int) -> tuple[float, float]:
        """World position of the centre of cell (column i, row j)."""
        return self.grid_to_world(i + 0.5, j + 0.5)

    def in_bounds(self, i: int, j: int) -> bool:
        return 0 <= i < self.width and 0 <= j < self.height

    def value_at(self, x: float, y: float) -> int:
        """Occupancy at a world point; outside the grid counts as unknown, as for any planner."""
        i, j = self.world_to_cell(x, y)
        return int(self.data[j, i]) if self.in_bounds(i, j) else UNKNOWN

    def yaw_to_grid(self, yaw: float) -> float:
        """A heading in the map frame expressed in the grid's frame (the origin's yaw removed)."""
        return yaw - self.origin.yaw

    def to_image(self) -> np.ndarray:
        """A grey picture in image order (top row first): free white, occupied black, unknown grey (a table of
        the 256 int8 values, so a map at the cell limit costs its picture only)."""
        values = np.arange(256, dtype=np.uint8).view(np.int8).astype(np.int16)
        table = np.where(values < 0, 205, 254 - np.clip(values, 0, 100) * 254 // 100).astype(np.uint8)
        return np.ascontiguousarray(table[self.data.view(np.uint8)][::-1])


def load_map_metadata(yaml_path: str | Path) -> MapMetadata:
    """Read and validate a map YAML file (not the image); ``image`` is resolved against the YAML's folder."""
    return _load_metadata(Path(yaml_path))[0]


def _load_metadata(path: Path) -> tuple[MapMetadata, Place]:
    """The validated metadata and the place of its ``image`` key (for messages about the image)."""
    document: Document = read_document(path, MAP_YAML_LIMITS, "map")
    if document.data is None or not isinstance(document.data, dict):
        raise document.root.fail(f"expected a YAML mapping of map fields, got {type(document.data).__name__}")
    raw = MAP_FIELDS.read(document.data, document.root)
    x, y, yaw = raw["origin"]
    meta = MapMetadata(
        image=raw["image"],
        resolution=raw["resolution"],
        origin=Pose2D(x, y, yaw),
        negate=bool(raw["negate"]),
        occupied_thresh=raw["occupied_thresh"],
        free_thresh=raw["free_thresh"],
        mode=raw["mode"].lower(),
    )
    return meta, document.root.key("image")


def decode_image(data: bytes, name: Path, flags: int) -> np.ndarray:
    """Decode image bytes whose header was checked, refusing a JPEG or PNG cut short (their decoders would
    return it partly grey and say so on stderr) and turning OpenCV's own refusal into an InputError."""
    cut = truncation(data)
    if cut is not None:
        raise InputError(name, cut)
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # the refusal is reported once, here
    try:
        pixels = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), flags)
    except cv2.error as exc:
        reason = " ".join(str(exc).split()).split(" error: ", 1)[-1][:200]
        raise InputError(name, f"OpenCV refuses to decode it: {reason}") from None
    finally:
        cv2.utils.logging.setLogLevel(level)
    if pixels is None or pixels.size == 0:
        raise InputError(name, "cannot be decoded as an image")
    return pixels


def _read_image(path: Path, where: Place) -> tuple[np.ndarray, bytes]:
    """The map's pixels and the file's bytes; the cells are counted from the header before decoding."""
    try:
        size = image_size(path)
        if size is not None:
            check(path, MAP_CELLS, size[0] * size[1], f"map of {size[0]}x{size[1]} cells")
        data, _size = read_image_file(path)
        return decode_image(data, path, cv2.IMREAD_UNCHANGED), data
    except InputError as exc:
        if exc.message == "file not found":
            raise where.fail(f"image file {path} not found") from None
        if exc.message in (UNKNOWN_FORMAT, "cannot be decoded as an image"):
            raise where.fail(f"cannot decode {path} as a PGM, PNG or BMP image ({exc.message})") from None
        raise where.fail(str(exc)) from None


def _pnm_maxval(head: bytes) -> int | None:
    """The maximum value declared in a PGM/PPM header; OpenCV returns raw samples without scaling them."""
    if head[:2] not in (b"P2", b"P3", b"P5", b"P6"):
        return None
    tokens: list[bytes] = []
    for line in head[:512].split(b"\n"):
        tokens += line.split(b"#", 1)[0].split()
        if len(tokens) >= 4:
            break
    try:
        return int(tokens[3]) if len(tokens[3]) <= 10 else None
    except (IndexError, ValueError):
        return None


def occupancy_from_pixels(pixels: np.ndarray, meta: MapMetadata, max_value: float | None = None) -> np.ndarray:
    """Threshold an image (OpenCV channel order) into occupancy values, still in image row order.

    Follows nav2 ``map_io``: the shade is the mean of R, G, B (plus alpha in trinary mode when the
    image has one) over the sample range (``max_value``: the PGM's maxval, else the dtype's maximum),
    ``occ = 1 - shade`` unless negated, then the mode decides.

    Integer images (every PGM, PNG and BMP) go through a table of the occupancy of every possible channel sum,
    so that a map at the cell limit costs its int8 grid and one integer sum, not a handful of float64 copies
    of the image (2 GB for 5000x5000 cells); the table holds exactly the values the float formula gives.
    """
    if max_value is None:
        max_value = float(np.iinfo(pixels.dtype).max) if pixels.dtype.kind in "ui" else 1.0
    channels, alpha = _shade_channels(pixels, meta)
    if pixels.dtype.kind in "ui" and pixels.dtype.itemsize <= 2:
        distinct = list({id(c): c for c in channels}.values())
        repeats = [sum(c is d for c in channels) for d in distinct]
        if len(distinct) == 1:  # grey: the table is indexed by the sample itself
            index = distinct[0]
            totals = np.arange(int(np.iinfo(pixels.dtype).max) + 1, dtype=np.float64) * repeats[0]
        else:
            index = np.zeros(pixels.shape[:2], dtype=np.int32)
            for channel, times in zip(distinct, repeats, strict=True):
                index += channel.astype(np.int32) * times if times != 1 else channel
            top = int(np.iinfo(pixels.dtype).max) * len(channels)
            totals = np.arange(top + 1, dtype=np.float64)
        table = _occupancy_of_shade(totals / (len(channels) * max_value), meta)
        out = table[index]
    else:
        shade = sum(c.astype(np.float64) for c in channels) / (len(channels) * max_value)
        out = _occupancy_of_shade(shade, meta)
    if meta.mode == "scale" and alpha is not None:
        out[alpha < max_value] = UNKNOWN
    return out


def _shade_channels(pixels: np.ndarray, meta: MapMetadata) -> tuple[list[np.ndarray], np.ndarray | None]:
    """The channels whose mean is the shade (views of ``pixels``, a grey image three times) and the alpha."""
    alpha = None
    if pixels.ndim == 2:
        channels = [pixels] * 3
    elif pixels.shape[2] <= 2:  # grey, or grey + alpha
        channels = [pixels[:, :, 0]] * 3
        alpha = pixels[:, :, 1] if pixels.shape[2] == 2 else None
    else:
        channels = [pixels[:, :, k] for k in range(3)]
        alpha = pixels[:, :, 3] if pixels.shape[2] == 4 else None
    if meta.mode == "trinary" and alpha is not None:
        channels = [*channels, alpha]
    return channels, alpha


def _occupancy_of_shade(shade: np.ndarray, meta: MapMetadata) -> np.ndarray:
    """Occupancy values (int8) of shades in 0..1, by the map's mode and thresholds (alpha aside)."""
    occ = shade if meta.negate else 1.0 - shade
    out = np.full(shade.shape, UNKNOWN, dtype=np.int8)
    if meta.mode == "raw":
        percent = np.floor(shade * 255.0 + 0.5)
        ok = (percent >= 0) & (percent <= 100)
        out[ok] = percent[ok].astype(np.int8)
        return out
    occupied = meta.occupied_thresh < occ
    free = occ < meta.free_thresh
    out[occupied] = OCCUPIED
    out[free & ~occupied] = FREE
    if meta.mode == "scale":
        middle = ~occupied & ~free
        span = meta.occupied_thresh - meta.free_thresh
        if span > 0:
            scaled = np.rint((occ - meta.free_thresh) / span * 100.0)
            out[middle] = np.clip(scaled[middle], 0, 100).astype(np.int8)
    return out


def load_map(yaml_path: str | Path) -> OccupancyMap:
    """Load a map_server map; raises :class:`MapError` with file, field and value on bad input."""
    path = Path(yaml_path)
    meta, image_place = _load_metadata(path)
    pixels, data = _read_image(meta.image, image_place)
    grid = occupancy_from_pixels(pixels, meta, _pnm_maxval(data))[::-1]
    log.info("loaded map %s: %dx%d cells at %.3f m", path, grid.shape[1], grid.shape[0], meta.resolution)
    return OccupancyMap(np.ascontiguousarray(grid), meta.resolution, meta.origin, source=path)


def save_map(occ_map: OccupancyMap, yaml_path: str | Path, image_format: str = "pgm",
             mode: str = "trinary") -> Path:
    """Write a map as map_saver would (image beside the YAML); loading it back gives the same grid.

    ``trinary`` keeps 0/100/-1 (other values become free up to 25, occupied from 65, unknown between),
    ``raw`` stores the values themselves, ``scale`` stores probabilities with unknown as transparency
    (PNG only) and writes thresholds 0/1 so that every value survives the round trip.
    """
    path = Path(yaml_path)
    fmt = image_format.lower().lstrip(".")
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if fmt not in ("pgm", "png", "bmp"):
        raise ValueError(f"image format must be pgm, png or bmp, got {image_format!r}")
    if mode == "scale" and fmt != "png":
        raise ValueError("scale mode needs transparency for unknown cells: use png")
    data = occ_map.data[::-1].astype(np.int16)
    occupied_thresh, free_thresh = 0.65, 0.196
    if mode == "trinary":
        img = np.full(data.shape, 205, np.uint8)
        img[(data >= 0) & (data <= 25)] = 254
        img[data >= 65] = 0
    elif mode == "raw":
        img = np.where(data < 0, 255, np.clip(data, 0, 100)).astype(np.uint8)
    else:
        grey = np.rint(255.0 * (1.0 - np.clip(data, 0, 100) / 100.0)).astype(np.uint8)
        alpha = np.where(data < 0, 0, 255).astype(np.uint8)
        img = np.dstack([grey, grey, grey, alpha])
        occupied_thresh, free_thresh = 1.0, 0.0
    image_path = path.with_suffix(f".{fmt}")
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(image_path), img):
        raise OSError(f"cannot write map image {image_path}")
    meta = {
        "image": image_path.name,
        "mode": mode,
        "resolution": float(occ_map.resolution),
        "origin": [float(occ_map.origin.x), float(occ_map.origin.y), float(occ_map.origin.yaw)],
        "negate": 0,
        "occupied_thresh": occupied_thresh,
        "free_thresh": free_thresh,
    }
    path.write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf-8")
    return path
