"""The built-in demo scene: coloured objects moving over a textured, noisy background, with ground truth.

Every command can run on it with no camera, and tests compare detections with the truth it reports.
The scene is deterministic for a seed: frame ``i`` is the same image on every machine.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

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
    return [
        DemoObject("red", (40, 35, 215), "disk", 38, (160, 120), (70, 35), 7.0, 0.0),
        DemoObject("green", (45, 190, 40), "square", 34, (480, 120), (70, 35), 9.0, 1.0, spin=0.6),
        DemoObject("blue", (200, 80, 25), "ellipse", 48, (160, 360), (70, 35), 8.0, 2.0, spin=-0.4),
        DemoObject("yellow", (25, 215, 225), "triangle", 44, (480, 360), (70, 35), 11.0, 3.0, spin=0.3),
    ]


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
        truth_objects = []
        for obj in self.objects:
            outline = obj.outline(t)
            pts = np.round(outline * 16).astype(np.int32)  # sub-pixel vertices (shift=4)
            cv2.fillPoly(image, [pts], obj.color, lineType=cv2.LINE_AA, shift=4)
            truth_objects.append(
                {"name": obj.name, "centroid": obj.centroid(t), "polygon": outline.tolist(), "shape": obj.shape}
            )
        truth: dict[str, Any] = {"time": t, "objects": truth_objects}
        for paint in self.painters:
            key, value = paint(image, t, index)
            truth[key] = value
        if self.noise_sigma > 0:
            rng = np.random.default_rng((self.seed, index))
            noise = rng.normal(0, self.noise_sigma, size=image.shape).astype(np.int16)
            image = np.clip(image.astype(np.int16) + noise, 0, 255).astype(np.uint8)
        return image, truth
