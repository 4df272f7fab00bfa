"""Pictures of a run: the map with the path driven, the goals, the station and the dock.

A ``.png``/``.jpg`` path gets one picture of the whole run; ``.gif``, ``.avi`` and ``.mp4`` get an
animation of the robot driving (GIF through OpenCV's animation writer, the others through
``strictio.video``, which checks that every frame reads back), so no imaging library beyond OpenCV is
needed. Drawing happens in the map's grid frame, so maps with a rotated origin come out as their image does.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from strictio import OutputError, write_atomically
from strictio.atomic import check_replaceable, remove_stale_temporaries, temporary_path
from strictio.shown import drawable
from strictio.video import VideoFile

from .costmap_filters import KEEPOUT_COLOUR, SPEED_COLOUR
from .docking import DockingStation
from .geometry import Pose2D
from .map_view import MapView
from .maps import OccupancyMap

log = logging.getLogger(__name__)

STILL = (".png", ".jpg", ".jpeg", ".bmp")
ANIMATED = (".gif", ".avi", ".mp4")
#: The long side of a GIF animation (pixels) and its most frames.
GIF_SIDE, GIF_FRAMES = 800, 100

PATH_COLOUR = (200, 110, 20)
GOAL_COLOUR = (30, 30, 220)
STATION_COLOUR = (40, 160, 40)
ROBOT_COLOUR = (0, 140, 255)
TEXT_COLOUR = (40, 40, 40)
BELIEVED_COLOUR = (160, 40, 160)
LOST_COLOUR = (0, 0, 200)
KIDNAP_COLOUR = (20, 20, 20)


Point = tuple[float, float]
Colour = tuple[int, int, int]

#: A dashed line's dash and gap along the line, in pixels.
DASH, GAP = 10.0, 7.0


def draw_dashed(img: np.ndarray, points: Sequence[tuple[int, int]], colour: Colour, thickness: int = 1,
                dash: float = DASH, gap: float = GAP) -> None:
    """A dashed polyline through pixel ``points``: dashes of ``dash`` pixels, ``gap`` pixels apart, measured along
    the line, so a track sampled every pixel or two is dashed as plainly as one with long segments."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2:
        return
    period = dash + gap
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    for a, b, s0, s1 in zip(pts[:-1], pts[1:], along[:-1], along[1:], strict=True):
        if s1 <= s0:
            continue
        start = s0 - (s0 % period)  # the dash that s0 falls in, or the one before it
        while start < s1:
            lo, hi = max(s0, start), min(s1, start + dash)
            if hi > lo:
                p = a + (b - a) * (lo - s0) / (s1 - s0)
                q = a + (b - a) * (hi - s0) / (s1 - s0)
                cv2.line(img, (round(p[0]), round(p[1])), (round(q[0]), round(q[1])), colour, thickness, cv2.LINE_AA)
            start += period


#: What the patrol picture's key says of each zone.
ZONE_NOTES = {"keepout zone": "never planned through", "speed zone": "speed capped (darker: slower)"}


def first_passes(points: Sequence[tuple[int, int]], spacing: float = 3.0) -> list[list[tuple[int, int]]]:
    """The runs of pixel ``points`` that go where the line has not been before: a point within ``spacing`` pixels
    of a part of the line passed more than a few spacings earlier is left out. A path gone along back and forth
    (a trolley between two ends) is then dashed once; dashes of the passes over it would fill each other's gaps."""
    seen: dict[tuple[int, int], float] = {}
    runs: list[list[tuple[int, int]]] = []
    run: list[tuple[int, int]] = []
    along, previous = 0.0, None
    for p in points:
        if previous is not None:
            along += math.dist(p, previous)
        previous = p
        cx, cy = int(p[0] // spacing), int(p[1] // spacing)
        earlier = (seen.get((cx + i, cy + j), math.inf) for i in (-1, 0, 1) for j in (-1, 0, 1))
        if min(earlier) < along - 4.0 * spacing:  # been here before, not just now
            if len(run) >= 2:
                runs.append(run)
            run = []
            continue
        seen.setdefault((cx, cy), along)
        run.append(p)
    if len(run) >= 2:
        runs.append(run)
    return runs


def zone_legend(zones: np.ndarray | None) -> list[tuple[str, Colour]]:
    """The legend entries of a zone layer (:func:`navigation.costmap_filters.zone_overlay`): the keepout zone and
    the speed zone, each only when the layer has cells of it, in the colour it has over free space (the layer's
    typical opacity blended over white), so the key looks like the map."""
    if zones is None:
        return []
    drawn = zones[..., 3] > 0
    entries: list[tuple[str, Colour]] = []
    for label, colour in (("keepout zone", KEEPOUT_COLOUR), ("speed zone", SPEED_COLOUR)):
        cells = drawn & np.all(zones[..., :3] == colour, axis=-1)
        if cells.any():
            alpha = float(np.median(zones[..., 3][cells])) / 255.0
            shown = tuple(round(255.0 * (1.0 - alpha) + c * alpha) for c in colour)
            entries.append((label, (shown[0], shown[1], shown[2])))
    return entries


@dataclass
class LocalizationMarks:
    """Where the robot believed it was, gathered from the run's events (subscribe it to the event log): the
    believed track (``localization`` events, t x y), each ``localization_lost`` (t, believed, true) and each
    ``kidnap`` (t, from, to). The picture draws them over the true trajectory."""

    believed: list[tuple[float, float, float]] = field(default_factory=list)
    lost: list[tuple[float, Point, Point]] = field(default_factory=list)
    kidnaps: list[tuple[float, Point, Point]] = field(default_factory=list)

    def __call__(self, ev: dict[str, Any]) -> None:
        kind = ev.get("type")
        if kind in ("localization", "localization_lost", "relocalize", "localization_regained") and \
                isinstance(ev.get("believed"), dict):
            b = ev["believed"]
            self.believed.append((float(ev["t"]), float(b["x"]), float(b["y"])))
            if kind == "localization_lost" and isinstance(ev.get("true"), dict):
                self.lost.append((float(ev["t"]), (float(b["x"]), float(b["y"])),
                                  (float(ev["true"]["x"]), float(ev["true"]["y"]))))
        elif kind == "kidnap" and isinstance(ev.get("from"), dict) and isinstance(ev.get("to"), dict):
            a, z = ev["from"], ev["to"]
            self.kidnaps.append((float(ev["t"]), (float(a["x"]), float(a["y"])), (float(z["x"]), float(z["y"]))))

    def __bool__(self) -> bool:
        return bool(self.believed or self.kidnaps)


@dataclass
class RunPicture:
    """Everything a picture shows; ``trajectory`` rows are (t, x, y, yaw)."""

    map: OccupancyMap
    trajectory: Sequence[tuple[float, float, float, float]]
    goals: Sequence[Pose2D]
    station_pose: Pose2D | None = None
    dock: DockingStation | None = None
    collisions: Sequence[tuple[float, float]] = ()
    robot_radius: float = 0.18
    caption: str = ""
    states: Sequence[tuple[float, str]] = ()
    # Keepout and speed zones, a BGRA layer over the map's cells (navigation.costmap_filters.zone_overlay).
    zones: np.ndarray | None = None
    # The believed pose, localisation lost and kidnaps (from the events), drawn over the true trajectory.
    localization: LocalizationMarks | None = None


def _canvas(pic: RunPicture, max_side: int, min_side: int = 0) -> MapView:
    """The map around what matters to the run (its known cells, route, goals and station), zones tinted."""
    m = pic.map
    known = np.argwhere(m.data >= 0)
    pts = [m.world_to_grid(x, y) for _, x, y, _ in pic.trajectory]
    pts = pts[::max(1, len(pts) // 5000)]  # the extent of a long run needs only a sample
    pts += [m.world_to_grid(g.x, g.y) for g in pic.goals]
    if pic.station_pose is not None:
        pts.append(m.world_to_grid(pic.station_pose.x, pic.station_pose.y))
    cols = [p[0] for p in pts] + ([known[:, 1].min(), known[:, 1].max() + 1] if len(known) else [])
    rows = [p[1] for p in pts] + ([known[:, 0].min(), known[:, 0].max() + 1] if len(known) else [])
    margin = max(2, round(1.0 / m.resolution))
    view = MapView(m, (math.floor(min(cols)) - margin, math.ceil(max(cols)) + margin),
                   (math.floor(min(rows)) - margin, math.ceil(max(rows)) + margin), max_side, min_side)
    if pic.zones is not None:
        view.tint(pic.zones)
    return view


def _font_scale(img: np.ndarray) -> float:
    return max(0.35, min(img.shape[:2]) / 1400.0)


def _draw_static(canvas: MapView, pic: RunPicture, img: np.ndarray) -> None:
    fs = _font_scale(img)
    if pic.dock is not None:
        d = pic.dock.pose
        a, b = canvas.px(d.x, d.y), canvas.heading(d, 0.25)
        cv2.circle(img, a, max(3, round(0.12 * canvas.px_per_m)), STATION_COLOUR, -1, cv2.LINE_AA)
        cv2.line(img, a, b, STATION_COLOUR, 2, cv2.LINE_AA)
        cv2.putText(img, "dock", (a[0] + 6, a[1] + 14), cv2.FONT_HERSHEY_SIMPLEX, fs, STATION_COLOUR, 1, cv2.LINE_AA)
    if pic.station_pose is not None:
        s = pic.station_pose
        cv2.arrowedLine(img, canvas.px(s.x, s.y), canvas.heading(s, 0.4), STATION_COLOUR, 2, cv2.LINE_AA,
                        tipLength=0.35)
        p = canvas.px(s.x, s.y)
        cv2.putText(img, "station", (p[0] + 6, p[1] - 6), cv2.FONT_HERSHEY_SIMPLEX, fs, STATION_COLOUR, 1,
                    cv2.LINE_AA)
    for i, g in enumerate(pic.goals):
        p = canvas.px(g.x, g.y)
        cv2.circle(img, p, max(3, round(0.08 * canvas.px_per_m)), GOAL_COLOUR, 1, cv2.LINE_AA)
        cv2.arrowedLine(img, p, canvas.heading(g, 0.3), GOAL_COLOUR, 1, cv2.LINE_AA, tipLength=0.35)
        cv2.putText(img, drawable(str(i)), (p[0] + 5, p[1] + 12), cv2.FONT_HERSHEY_SIMPLEX, fs, GOAL_COLOUR, 1,
                    cv2.LINE_AA)


def _trajectory_pixels(canvas: MapView, pic: RunPicture) -> np.ndarray:
    """The whole trajectory in pixels, converted once for all frames."""
    if not pic.trajectory:
        return np.zeros((0, 2), np.int32)
    return canvas.px_array(np.asarray(pic.trajectory, dtype=np.float64)[:, 1:3])


def _draw_trail(img: np.ndarray, pixels: np.ndarray) -> None:
    if len(pixels) >= 2:
        cv2.polylines(img, [pixels.reshape(-1, 1, 2)], False, PATH_COLOUR, 2, cv2.LINE_AA)


def _draw_robot(canvas: MapView, pic: RunPicture, img: np.ndarray, index: int) -> None:
    _, x, y, yaw = pic.trajectory[index]
    c = canvas.px(x, y)
    cv2.circle(img, c, max(3, round(pic.robot_radius * canvas.px_per_m)), ROBOT_COLOUR, 2, cv2.LINE_AA)
    cv2.line(img, c, canvas.heading(Pose2D(x, y, yaw), pic.robot_radius), ROBOT_COLOUR, 2, cv2.LINE_AA)


def _draw_collisions(canvas: MapView, pic: RunPicture, img: np.ndarray) -> None:
    size = max(4, round(0.1 * canvas.px_per_m))
    for x, y in pic.collisions:
        cx, cy = canvas.px(x, y)
        cv2.line(img, (cx - size, cy - size), (cx + size, cy + size), (0, 0, 255), 2)
        cv2.line(img, (cx - size, cy + size), (cx + size, cy - size), (0, 0, 255), 2)


def _draw_localization(canvas: MapView, pic: RunPicture, img: np.ndarray, until: float = math.inf) -> None:
    """The believed track (dashed) up to ``until``, each loss as a line from the believed to the true pose with
    a ring at the believed one, each kidnap as an arrow from where the robot was to where it was put."""
    marks = pic.localization
    if not marks:
        return
    draw_dashed(img, [canvas.px(x, y) for t, x, y in marks.believed if t <= until], BELIEVED_COLOUR, 2)
    for t, believed, true in marks.lost:
        if t <= until:
            a, b = canvas.px(*believed), canvas.px(*true)
            cv2.line(img, a, b, LOST_COLOUR, 1, cv2.LINE_AA)
            cv2.circle(img, a, max(4, round(0.15 * canvas.px_per_m)), LOST_COLOUR, 2, cv2.LINE_AA)
    for t, start, end in marks.kidnaps:
        if t <= until:
            cv2.arrowedLine(img, canvas.px(*start), canvas.px(*end), KIDNAP_COLOUR, 2, cv2.LINE_AA, tipLength=0.08)


def _localization_key(pic: RunPicture) -> list[str]:
    """The caption lines that say what the localisation marks mean (none without them)."""
    if not pic.localization:
        return []
    return ["purple dashes: where the robot believed it was", "red ring, line: localisation lost (believed -> true)",
            "black arrow: kidnapped (from -> to)"]


def _state_at(pic: RunPicture, t: float) -> str:
    state = ""
    for when, name in pic.states:
        if when <= t:
            state = name.rsplit(".", 1)[-1]
    return state


def _label(img: np.ndarray, text: str, line: int = 0, swatch: Colour | None = None) -> None:
    """Dark text on a white box at the top left, readable over any part of the map; a ``swatch`` of a colour
    before the text makes it a legend entry."""
    fs = _font_scale(img) * 1.1
    (w, h), base = cv2.getTextSize(drawable(text), cv2.FONT_HERSHEY_SIMPLEX, fs, 1)
    y = 6 + (h + base + 6) * line
    x = 8 if swatch is None else 8 + h + 6
    cv2.rectangle(img, (4, y), (x + 4 + w, y + h + base + 4), (255, 255, 255), -1)
    if swatch is not None:
        cv2.rectangle(img, (8, y + 2), (8 + h, y + h + 2), swatch, -1)
    cv2.putText(img, drawable(text), (x, y + h + 2), cv2.FONT_HERSHEY_SIMPLEX, fs, TEXT_COLOUR, 1, cv2.LINE_AA)


#: The key entry of the robot's orange ring: where it stands at the end of the run (a still) or now (a frame).
ROBOT_KEY = {"still": "robot at the end of the run (ring, line: heading)", "frame": "robot now (ring, line: heading)"}


def _keys(img: np.ndarray, pic: RunPicture, first_line: int, robot: str = "still") -> None:
    """The legend under the caption: the robot's ring (when it is drawn), the zones (each with its colour) and
    the localisation marks."""
    entries: list[tuple[str, Colour | None]] = [(ROBOT_KEY[robot], ROBOT_COLOUR)] if pic.trajectory else []
    entries += [(f"{label}: {ZONE_NOTES[label]}", colour) for label, colour in zone_legend(pic.zones)]
    entries += [(text, None) for text in _localization_key(pic)]
    for k, (text, swatch) in enumerate(entries):
        _label(img, text, first_line + k, swatch)


def render_still(pic: RunPicture, max_side: int = 1000) -> np.ndarray:
    canvas = _canvas(pic, max_side)
    img = canvas.image.copy()
    _draw_static(canvas, pic, img)
    _draw_trail(img, _trajectory_pixels(canvas, pic))
    _draw_collisions(canvas, pic, img)
    _draw_localization(canvas, pic, img)
    if pic.trajectory:
        _draw_robot(canvas, pic, img, len(pic.trajectory) - 1)
    captions = pic.caption.splitlines()
    for k, line in enumerate(captions):
        _label(img, line, k)
    _keys(img, pic, len(captions))
    return img


def render_frames(pic: RunPicture, max_side: int = 720, max_frames: int = 300, min_side: int = 0
                  ) -> Iterator[np.ndarray]:
    """Frames at evenly spaced moments of the run (at most ``max_frames``), made one at a time as they are asked
    for (300 frames of 720x720 kept at once were 470 MB).

    The trail is drawn incrementally on one canvas, so a long run costs its length once, not per frame.
    """
    canvas = _canvas(pic, max_side, min_side)
    trail = canvas.image.copy()
    _draw_static(canvas, pic, trail)
    n = len(pic.trajectory)
    if n == 0:
        yield trail
        return
    pixels = _trajectory_pixels(canvas, pic)
    done = 0
    for k in np.linspace(1, n, max(2, min(max_frames, n))).round().astype(int):
        _draw_trail(trail, pixels[max(0, done - 1):k])
        done = int(k)
        img = trail.copy()
        _draw_localization(canvas, pic, img, pic.trajectory[done - 1][0])
        _draw_robot(canvas, pic, img, done - 1)
        _label(img, f"t = {pic.trajectory[done - 1][0]:7.1f} s   {_state_at(pic, pic.trajectory[done - 1][0])}")
        _keys(img, pic, 1, "frame")
        yield img


def _encoded(ext: str, pic: RunPicture) -> bytes:
    """A still picture or a GIF animation as the bytes of its file."""
    if ext == ".gif":
        # Large enough to project (GIF_SIDE on the long side, a 246x326 one was not); the encoder takes every
        # frame at once, so there are fewer of them: 100 of 800x800 are 190 MB.
        frames = list(render_frames(pic, max_side=GIF_SIDE, max_frames=GIF_FRAMES, min_side=GIF_SIDE))
        anim = cv2.Animation()
        anim.frames = frames
        anim.durations = [80] * len(frames)
        ok, data = cv2.imencodeanimation(ext, anim)
    else:
        ok, data = cv2.imencode(ext, render_still(pic))
    if not ok:
        raise ValueError(f"OpenCV cannot encode a {ext} picture")
    return np.asarray(data).tobytes()


def _write_video(path: Path, ext: str, pic: RunPicture) -> None:
    """Write the animation under a temporary name, check that every frame reads back, then rename it: OpenCV's
    video writer reports no write error, so a full disk shows only as missing frames."""
    frames = render_frames(pic)
    first = next(frames)
    h, w = first.shape[:2]
    h, w = h - h % 2, w - w % 2  # most codecs want even sizes
    target = Path(os.path.realpath(path))
    if not target.parent.is_dir():
        raise OutputError(path, f"cannot save: folder {path.parent} does not exist")
    check_replaceable(str(path), target)
    remove_stale_temporaries(target.parent)
    temporary = temporary_path(target, ext)  # the suffix chooses the container
    try:
        video = VideoFile(temporary, 15.0, (w, h), shown_as=path, watch_growth=False)
        written = 0
        for frame in itertools.chain([first], frames):
            video.write(np.ascontiguousarray(frame[:h, :w]))
            written += 1
        readable = video.finish()
        if readable < written:
            raise OutputError(path, f"cannot save: only {readable} of {written} frames could be written "
                                    "(a full disk or a file size limit?)")
        os.replace(temporary, target)
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(path, f"cannot save: {exc.strerror or exc}") from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(temporary)


def save_render(path: str | Path, pic: RunPicture) -> Path:
    """Write a picture or an animation, chosen by the file extension; the file is replaced whole or not at
    all. Any failure to write is a ``strictio.OutputError`` (a path that must not be replaced, such as a
    device or a read-only file, included); an extension this cannot draw is a ValueError."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in STILL + ANIMATED:
        raise ValueError(f"cannot render to {path}: use one of {', '.join(STILL + ANIMATED)}")
    if ext in STILL or ext == ".gif":
        write_atomically(path, _encoded(ext, pic))
        return path
    _write_video(path, ext, pic)
    return path
