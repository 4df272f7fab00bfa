"""The built-in demo scene: coloured objects moving over a textured, noisy background, with ground truth.

Every command can run on it with no camera, and tests compare detections with the truth it reports.
The scene is deterministic for a seed: frame ``i`` is the same image on every machine.

Besides the four saturated shapes (for the colour system) it holds a grey, textured, flat target that
moves, turns and tilts (for the feature detector), with its true corners in ``truth["target"]``. The
shapes keep to two side columns and the target to the middle, so neither ever covers the other, and the
target's grey keeps the colour system blind to it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from strictio.shown import drawable

WIDTH, HEIGHT = 640, 480
FPS = 30.0


@dataclass
class DemoObject:
    """A saturated shape on its own lane of the image, so shapes never touch and the truth stays exact."""

    name: str
    color: tuple[int, int, int]  # BGR
    shape: str  # "disk", "square", "ellipse", "triangle"
    size: float  # radius-like extent in pixels
    home: tuple[float, float]  # centre of its lane
    amplitude: tuple[float, float]
    period: float  # seconds per loop
    phase: float
    spin: float = 0.0  # radians per second

    def pose(self, t: float) -> tuple[float, float, float]:
        w = 2 * math.pi / self.period
        x = self.home[0] + self.amplitude[0] * math.sin(w * t + self.phase)
        y = self.home[1] + self.amplitude[1] * math.sin(2 * w * t + self.phase)
        return x, y, self.spin * t

    def outline(self, t: float) -> np.ndarray:
        """The exact outline as float polygon vertices (N x 2)."""
        x, y, angle = self.pose(t)
        if self.shape == "disk":
            a = np.linspace(0, 2 * np.pi, 72, endpoint=False)
            return np.stack([x + self.size * np.cos(a), y + self.size * np.sin(a)], axis=1)
        if self.shape == "ellipse":
            a = np.linspace(0, 2 * np.pi, 72, endpoint=False)
            ex, ey = self.size * np.cos(a), 0.6 * self.size * np.sin(a)
        elif self.shape == "square":
            ex, ey = self.size * np.array([-1, 1, 1, -1.0]), self.size * np.array([-1, -1, 1, 1.0])
        elif self.shape == "triangle":
            a = np.array([-np.pi / 2, np.pi / 6, 5 * np.pi / 6])
            ex, ey = self.size * np.cos(a), self.size * np.sin(a)
        else:
            raise ValueError(f"unknown demo shape {self.shape!r}")
        c, s = math.cos(angle), math.sin(angle)
        return np.stack([x + c * ex - s * ey, y + s * ex + c * ey], axis=1)

    def centroid(self, t: float) -> tuple[float, float]:
        x, y, _ = self.pose(t)
        return x, y  # every demo shape is centred on its pose (the triangle is equilateral)


def default_objects() -> list[DemoObject]:
    """Two shapes in the left column (x < 135) and two in the right one (x > 505): the middle
    (x 160..476) is the textured target's."""
    return [
        DemoObject("red", (40, 35, 215), "disk", 38, (72, 120), (12, 40), 7.0, 0.0),
        DemoObject("green", (45, 190, 40), "square", 34, (568, 120), (12, 40), 9.0, 1.0, spin=0.6),
        DemoObject("blue", (200, 80, 25), "ellipse", 48, (72, 360), (12, 40), 8.0, 2.0, spin=-0.4),
        DemoObject("yellow", (25, 215, 225), "triangle", 44, (568, 360), (12, 40), 11.0, 3.0, spin=0.3),
    ]


def render_pattern(width: int, height: int, seed: int = 2024) -> np.ndarray:
    """A grey, feature-rich, non-repeating picture (blobs, bars, rings, lines and text at many sizes):
    the printed poster the demo's camera sees. Grey, so the colour system never finds it."""
    rng = np.random.default_rng(seed)
    coarse = rng.uniform(70, 185, size=(max(height // 24, 2), max(width // 24, 2))).astype(np.float32)
    pattern = cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC)
    pattern = np.clip(pattern, 0, 255).astype(np.uint8)
    for _ in range(int(width * height / 260)):
        grey = int(rng.integers(40, 236))
        x, y = int(rng.integers(0, width)), int(rng.integers(0, height))
        size = int(rng.integers(3, 16))
        kind = rng.integers(0, 4)
        if kind == 0:
            cv2.circle(pattern, (x, y), size, grey, -1, cv2.LINE_AA)
        elif kind == 1:
            w, h = int(rng.integers(3, 2 * size + 4)), int(rng.integers(3, 2 * size + 4))
            cv2.rectangle(pattern, (x, y), (x + w, y + h), grey, -1)
        elif kind == 2:
            cv2.circle(pattern, (x, y), size, grey, int(rng.integers(1, 4)), cv2.LINE_AA)
        else:
            a = rng.uniform(0, 2 * np.pi)
            end = (int(x + 2 * size * np.cos(a)), int(y + 2 * size * np.sin(a)))
            cv2.line(pattern, (x, y), end, grey, int(rng.integers(1, 4)), cv2.LINE_AA)
    for word in ("objrec", "ROS", "42", "demo", "AKAZE", "7x"):
        x, y = int(rng.integers(0, width - 40)), int(rng.integers(14, height))
        grey = 40 if rng.random() < 0.5 else 235
        cv2.putText(pattern, drawable(word), (x, y), cv2.FONT_HERSHEY_SIMPLEX, rng.uniform(0.35, 0.8), grey, 1,
                    cv2.LINE_AA)
    cv2.rectangle(pattern, (0, 0), (width - 1, height - 1), 40, 2)  # a printed border
    return pattern


@dataclass
class DemoTarget:
    """A flat textured poster that drifts, turns and tilts towards and away from the camera.

    Frame 0 shows it head-on, unturned, at scale 1 with its top-left pixel on ``origin``: selecting
    ``reference_rect`` in frame 0 selects exactly the poster. Its pose is a homography from poster
    pixels to frame pixels (both with pixel centres on integers), and its true corners are that
    homography applied to the poster's outline (pixel edges at -0.5 and size - 0.5).
    """

    name: str = "target"
    size: tuple[int, int] = (208, 152)  # width, height
    origin: tuple[int, int] = (216, 164)  # top-left pixel in frame 0
    amplitude: tuple[float, float] = (35.0, 80.0)  # drift of the centre, pixels
    max_turn: float = 0.45  # radians, in the image plane
    max_tilt: float = 0.45  # radians, about the poster's horizontal and vertical axes
    min_scale: float = 0.82
    focal: float = 700.0  # pixels; how strongly perspective shows
    periods: tuple[float, ...] = (13.0, 9.0, 11.0, 7.0, 8.5, 15.0)  # seconds: x, y, turn, tilt x, tilt y, scale
    pattern_seed: int = 2024
    _pattern: np.ndarray | None = field(default=None, init=False, repr=False)

    @property
    def pattern(self) -> np.ndarray:
        """The poster as BGR, tinted like the room so it is as (un)coloured as the background."""
        if self._pattern is None:
            grey = render_pattern(*self.size, seed=self.pattern_seed).astype(np.float32)
            self._pattern = np.clip(grey[:, :, None] * np.float32([1.0, 1.02, 1.04]), 0, 255).astype(np.uint8)
        return self._pattern

    @property
    def reference_rect(self) -> tuple[int, int, int, int]:
        """x, y, width, height of the poster in frame 0 (head-on), for selecting it."""
        return (*self.origin, *self.size)

    def homography(self, t: float) -> np.ndarray:
        """Poster pixel -> frame pixel at time t; a pure integer shift to ``origin`` at t = 0."""
        w = [2 * math.pi / p for p in self.periods]
        width, height = self.size
        centre = np.array([(width - 1) / 2, (height - 1) / 2])
        dx = self.amplitude[0] * math.sin(w[0] * t)
        dy = self.amplitude[1] * math.sin(w[1] * t)
        turn = self.max_turn * math.sin(w[2] * t)
        tilt_x = self.max_tilt * math.sin(w[3] * t)
        tilt_y = self.max_tilt * math.sin(w[4] * t)
        scale = 1.0 - (1.0 - self.min_scale) * 0.5 * (1 - math.cos(w[5] * t))
        ca, sa, cb, sb = math.cos(tilt_x), math.sin(tilt_x), math.cos(tilt_y), math.sin(tilt_y)
        rotation = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]]) @ np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
        # The poster plane seen by a pinhole camera at distance `focal`: [r1 r2 t] with t = (0, 0, f), over f.
        tilt = np.array(
            [
                [rotation[0, 0], rotation[0, 1], 0.0],
                [rotation[1, 0], rotation[1, 1], 0.0],
                [rotation[2, 0] / self.focal, rotation[2, 1] / self.focal, 1.0],
            ]
        )
        c, s = math.cos(turn) * scale, math.sin(turn) * scale
        turn_scale = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        to_centre = np.array([[1, 0, -centre[0]], [0, 1, -centre[1]], [0, 0, 1.0]])
        home = np.array(self.origin, dtype=np.float64) + centre
        to_frame = np.array([[1, 0, home[0] + dx], [0, 1, home[1] + dy], [0, 0, 1.0]])
        matrix = to_frame @ turn_scale @ tilt @ to_centre
        return matrix / matrix[2, 2]

    def corners(self, t: float) -> np.ndarray:
        """The poster's true outline in the frame (4 x 2, clockwise on screen from its top-left)."""
        width, height = self.size
        right, bottom = width - 0.5, height - 0.5
        outline = np.array([[-0.5, -0.5, 1], [right, -0.5, 1], [right, bottom, 1], [-0.5, bottom, 1]])
        projected = outline @ self.homography(t).T
        return projected[:, :2] / projected[:, 2:3]

    def paint(self, image: np.ndarray, t: float, index: int) -> tuple[str, Any]:
        """Warp the poster into the frame (only inside its bounding box, which keeps it fast)."""
        matrix = self.homography(t)
        corners = self.corners(t)
        x0, y0 = np.floor(corners.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(corners.max(axis=0)).astype(int) + 2
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, image.shape[1]), min(y1, image.shape[0])
        if x1 > x0 and y1 > y0:
            shift = np.array([[1, 0, -x0], [0, 1, -y0], [0, 0, 1.0]])
            patch = np.ascontiguousarray(image[y0:y1, x0:x1])
            cv2.warpPerspective(
                self.pattern, shift @ matrix, (x1 - x0, y1 - y0), dst=patch,
                flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_TRANSPARENT,
            )
            image[y0:y1, x0:x1] = patch
        truth = {"name": self.name, "corners": corners.tolist(), "homography": matrix.tolist()}
        return "target", truth


#: Extra painters other features of the demo add (e.g. a textured target); each draws on the frame at
#: time t and returns its ground truth under its own key.
Painter = Callable[[np.ndarray, float, int], tuple[str, Any]]


@dataclass
class DemoScene:
    """Renders frame ``index`` of the demo: background texture + moving shapes + sensor noise."""

    seed: int = 0
    objects: list[DemoObject] = field(default_factory=default_objects)
    painters: list[Painter] = field(default_factory=list)
    noise_sigma: float = 4.0
    #: The textured poster for the feature detector (None leaves it out); truth under "target".
    target: DemoTarget | None = field(default_factory=DemoTarget)

    def __post_init__(self) -> None:
        rng = np.random.default_rng(self.seed)
        # Low-saturation texture: a smooth grey field with a grain, so nothing in it looks "coloured".
        coarse = rng.normal(128, 28, size=(HEIGHT // 16, WIDTH // 16)).astype(np.float32)
        smooth = cv2.resize(coarse, (WIDTH, HEIGHT), interpolation=cv2.INTER_CUBIC)
        grain = rng.normal(0, 10, size=(HEIGHT, WIDTH)).astype(np.float32)
        grey = np.clip(smooth + grain, 40, 215)
        tint = np.array([1.0, 1.02, 1.04], dtype=np.float32)  # a slightly warm room
        self._background = np.clip(grey[:, :, None] * tint, 0, 255).astype(np.uint8)

    def render(self, index: int) -> tuple[np.ndarray, dict[str, Any]]:
        t = index / FPS
        image = self._background.copy()
        truth: dict[str, Any] = {"time": t}
        if self.target is not None:
            key, value = self.target.paint(image, t, index)
            truth[key] = value
        truth_objects = []
        for obj in self.objects:
            outline = obj.outline(t)
            pts = np.round(outline * 16).astype(np.int32)  # sub-pixel vertices (shift=4)
            cv2.fillPoly(image, [pts], obj.color, lineType=cv2.LINE_AA, shift=4)
            truth_objects.append(
                {"name": obj.name, "centroid": obj.centroid(t), "polygon": outline.tolist(), "shape": obj.shape}
            )
        truth["objects"] = truth_objects
        for paint in self.painters:
            key, value = paint(image, t, index)
            truth[key] = value
        if self.noise_sigma > 0:
            rng = np.random.default_rng((self.seed, index))
            # float32 noise and OpenCV's saturating add: a third of the time of float64 NumPy arithmetic
            noise = rng.standard_normal(size=image.shape, dtype=np.float32)
            noise *= self.noise_sigma
            image = cv2.add(image, noise, dtype=cv2.CV_8U)
        return image, truth
