"""ROS map_server maps: a YAML file of metadata beside a PGM/PNG/BMP image.

The occupancy values (0 free, 100 occupied, -1 unknown, 1..99 in ``scale`` mode) and the cell order are
those of map_server (nav2 ``map_io``): row 0 of :attr:`OccupancyMap.data` is the image's *bottom* row,
because the map's origin is its lower-left corner. Maps made for ROS therefore load here unchanged, and the
grid a map_server would publish is exactly ``OccupancyMap.data`` flattened.
"""

from __future__ import annotations

import logging
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from strictio import MAP_CELLS, InputError, YAMLLimits, read_text, yaml_text
from strictio.image_size import UNKNOWN_FORMAT, image_size, read_image_file, truncation
from strictio.limits import check

from .geometry import Pose2D

log = logging.getLogger(__name__)

FREE = 0
OCCUPIED = 100
UNKNOWN = -1
MODES = ("trinary", "scale", "raw")
#: A map YAML is a few lines; a megabyte leaves room for comments and never for a bomb.
MAP_YAML_LIMITS = YAMLLimits(max_bytes=1024 * 1024, max_depth=8)
#: Sane bounds of the numbers in a map YAML: a cell of up to a kilometre, an origin within a thousand
#: kilometres, a yaw within a few turns. Beyond them a value is a typo or an attack, and the arithmetic of
#: every conversion would lose its precision.
MAX_RESOLUTION = 1000.0
MAX_COORDINATE = 1e6
MAX_YAW = 100.0


class MapError(ValueError):
    """A map file that cannot be used; the message names the file, the field or line, and the value."""


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
        """A grey picture in image order (top row first): free white, occupied black, unknown grey."""
        d = self.data.astype(np.int16)
        img = np.where(d < 0, 205, 254 - np.clip(d, 0, 100) * 254 // 100).astype(np.uint8)
        return np.ascontiguousarray(img[::-1])


def _key_lines(text: str) -> dict[str, int]:
    """Line number (1-based) of each top-level key, so errors can point at the line."""
    try:
        node = yaml.compose(text)
    except yaml.YAMLError:
        return {}
    lines: dict[str, int] = {}
    if isinstance(node, yaml.MappingNode):
        for key, _value in node.value:
            lines[str(key.value)] = key.start_mark.line + 1
    return lines


def _where(path: Path, lines: dict[str, int], key: str) -> str:
    return f"{path}: line {lines[key]}: field '{key}'" if key in lines else f"{path}: field '{key}'"


def _number(path: Path, lines: dict[str, int], raw: dict[str, Any], key: str, default: float | None) -> float:
    if key not in raw:
        if default is None:
            raise MapError(f"{path}: required field '{key}' is missing")
        return default
    value = finite_number(raw[key])
    if value is None:
        raise MapError(f"{_where(path, lines, key)}: expected a number, got {shown_value(raw[key])}")
    return value


def finite_number(value: Any) -> float | None:
    """A YAML number as a finite float, or None (not a number, NaN, infinite, or an integer past float)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def shown_value(value: Any) -> str:
    """A value for an error line: its repr, shortened (a 4,000-digit number stays one readable line)."""
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:40]}... ({len(text):,} characters)"


def _bounded(path: Path, lines: dict[str, int], key: str, value: float, low: float, high: float,
             what: str) -> float:
    if not low <= value <= high:
        raise MapError(f"{_where(path, lines, key)}: {what}, got {value!r}")
    return value


def find_long_integer(text: str) -> tuple[str, int, int] | None:
    """Where a YAML text holds an integer too long for Python to convert (the strict reader only says that
    one does): its key path, line and digits. Call only after the strict reader composed the text (it
    refuses aliases and deep nesting first); composing converts nothing."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return None
    limit = sys.get_int_max_str_digits()
    stack: list[tuple[yaml.Node, str]] = [(root, "")] if root is not None and limit else []
    while stack:  # depth first, in document order
        node, where = stack.pop()
        if isinstance(node, yaml.MappingNode):
            stack += reversed([(v, f"{where}.{k.value}" if where else str(k.value)) for k, v in node.value])
        elif isinstance(node, yaml.SequenceNode):
            stack += reversed([(value, f"{where}[{i}]") for i, value in enumerate(node.value)])
        elif isinstance(node, yaml.ScalarNode) and node.tag.endswith(":int"):
            digits = sum(c.isdigit() for c in node.value)
            if digits > limit:
                return where, node.start_mark.line + 1, digits
    return None


def long_integer_message(text: str, exc: InputError) -> str:
    """The strict reader's refusal of a too-long integer, with the field and line where it is."""
    found = find_long_integer(text) if "digits" in exc.message and not exc.where else None
    if found is None:
        return str(exc)
    where, line, digits = found
    return f"{exc.path}: line {line}: field '{where}': an integer of {digits:,} digits is not a usable number"


def load_map_metadata(yaml_path: str | Path) -> MapMetadata:
    """Read and validate a map YAML file (not the image); ``image`` is resolved against the YAML's folder."""
    return _load_metadata(Path(yaml_path))[0]


def _load_metadata(path: Path) -> tuple[MapMetadata, dict[str, int]]:
    """The validated metadata and the line of each top-level key (for messages about the image)."""
    try:
        text = read_text(path, MAP_YAML_LIMITS.max_bytes)
    except InputError as exc:
        if exc.message == "file not found":
            raise MapError(f"{path}: map file not found") from None
        raise MapError(str(exc)) from None
    try:
        raw = yaml_text(text, path, MAP_YAML_LIMITS)
    except InputError as exc:
        raise MapError(long_integer_message(text, exc)) from None
    if not isinstance(raw, dict):
        raise MapError(f"{path}: expected a YAML mapping of map fields, got {type(raw).__name__}")
    lines = _key_lines(text)

    image = raw.get("image")
    if "image" not in raw:
        raise MapError(f"{path}: required field 'image' is missing")
    if not isinstance(image, str) or not image.strip():
        raise MapError(f"{_where(path, lines, 'image')}: expected an image file name, got {shown_value(image)}")
    image_path = Path(image)
    if not image_path.is_absolute():
        image_path = path.parent / image_path

    resolution = _number(path, lines, raw, "resolution", None)
    if resolution <= 0.0:
        raise MapError(f"{_where(path, lines, 'resolution')}: must be positive, got {resolution!r}")
    _bounded(path, lines, "resolution", resolution, 0.0, MAX_RESOLUTION,
             f"must be at most {MAX_RESOLUTION:g} m per cell")

    if "origin" not in raw:
        raise MapError(f"{path}: required field 'origin' is missing")
    origin = raw["origin"]
    values = [finite_number(v) for v in origin] if isinstance(origin, list) else []
    numbers = [v for v in values if v is not None]
    if len(values) != 3 or len(numbers) != 3:
        raise MapError(f"{_where(path, lines, 'origin')}: expected [x, y, yaw] numbers, got {shown_value(origin)}")
    x, y, yaw = numbers
    for value, bound, what in ((x, MAX_COORDINATE, "x"), (y, MAX_COORDINATE, "y"), (yaw, MAX_YAW, "yaw")):
        unit = "rad" if what == "yaw" else "m"
        _bounded(path, lines, "origin", value, -bound, bound, f"{what} must lie within ±{bound:g} {unit}")

    negate = raw.get("negate", 0)
    if negate not in (0, 1) and not isinstance(negate, bool):
        raise MapError(f"{_where(path, lines, 'negate')}: expected 0 or 1, got {shown_value(negate)}")
    occupied = _number(path, lines, raw, "occupied_thresh", 0.65)
    free = _number(path, lines, raw, "free_thresh", 0.196)
    for key, value in (("occupied_thresh", occupied), ("free_thresh", free)):
        if not 0.0 <= value <= 1.0:
            raise MapError(f"{_where(path, lines, key)}: must lie in [0, 1], got {value!r}")
    if free > occupied:
        raise MapError(f"{_where(path, lines, 'free_thresh')}: {free!r} is above occupied_thresh {occupied!r}")
    mode = raw.get("mode", "trinary")
    if not isinstance(mode, str) or mode.lower() not in MODES:
        raise MapError(f"{_where(path, lines, 'mode')}: expected one of {', '.join(MODES)}, got {shown_value(mode)}")
    meta = MapMetadata(
        image=image_path,
        resolution=resolution,
        origin=Pose2D(x, y, yaw),
        negate=bool(negate),
        occupied_thresh=occupied,
        free_thresh=free,
        mode=mode.lower(),
    )
    return meta, lines


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


def _read_image(path: Path, where: str) -> tuple[np.ndarray, bytes]:
    """The map's pixels and the file's bytes; the cells are counted from the header before decoding."""
    try:
        size = image_size(path)
        if size is not None:
            check(path, MAP_CELLS, size[0] * size[1], f"map of {size[0]}x{size[1]} cells")
        data, _size = read_image_file(path)
        return decode_image(data, path, cv2.IMREAD_UNCHANGED), data
    except InputError as exc:
        if exc.message == "file not found":
            raise MapError(f"{where}: image file {path} not found") from None
        if exc.message in (UNKNOWN_FORMAT, "cannot be decoded as an image"):
            raise MapError(f"{where}: cannot decode {path} as a PGM, PNG or BMP image ({exc.message})") from None
        raise MapError(f"{where}: {exc}") from None


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
    """
    if max_value is None:
        max_value = float(np.iinfo(pixels.dtype).max) if pixels.dtype.kind in "ui" else 1.0
    img = pixels.astype(np.float64)
    alpha = None
    if img.ndim == 2:
        channels = [img] * 3
    elif img.shape[2] <= 2:  # grey, or grey + alpha
        channels = [img[:, :, 0]] * 3
        alpha = img[:, :, 1] if img.shape[2] == 2 else None
    else:
        channels = [img[:, :, k] for k in range(3)]
        alpha = img[:, :, 3] if img.shape[2] == 4 else None
    if meta.mode == "trinary" and alpha is not None:
        channels = [*channels, alpha]
    shade = sum(channels) / (len(channels) * max_value)
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
        if alpha is not None:
            out[alpha < max_value] = UNKNOWN
    return out


def load_map(yaml_path: str | Path) -> OccupancyMap:
    """Load a map_server map; raises :class:`MapError` with file, field and value on bad input."""
    path = Path(yaml_path)
    meta, lines = _load_metadata(path)
    pixels, data = _read_image(meta.image, _where(path, lines, "image"))
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
