"""Scattered normals weigh less, but a wrong model is not excused as noise: the scatter is measured where a
wrong model cannot explain it."""

from __future__ import annotations

import math

import numpy as np

from objrec3d.fitting import ShapeSettings, _noise_weighted

AXIS = np.array([0.0, 1.0, 0.0])
CENTER = np.array([0.0, 0.0, 1.0])


def _cylinder_side(rng: np.random.Generator, radius: float, tilt_degrees: float, n: int = 3000):
    """The visible half of an upright cylinder (facing the sensor at the origin), normals tilted at random by
    ``tilt_degrees`` (per component, Gaussian)."""
    theta = rng.uniform(np.pi / 2 + 0.3, 3 * np.pi / 2 - 0.3, n)  # the side toward z = 0
    height = rng.uniform(-0.05, 0.05, n)
    outward = np.stack([np.cos(theta), np.zeros(n), np.sin(theta)], axis=1)
    points = CENTER + radius * outward + height[:, None] * AXIS
    noise = rng.normal(0.0, math.radians(tilt_degrees), (n, 3))
    normals = outward + noise - (noise * outward).sum(axis=1, keepdims=True) * outward
    return points, normals / np.linalg.norm(normals, axis=1, keepdims=True)


def _settings() -> ShapeSettings:
    return ShapeSettings(shape="cylinder", min_radius=0.01, max_radius=0.1, threshold=0.01, normal_weight=0.05,
                         noise_weighted=True)


def test_steady_normals_keep_their_weight() -> None:
    points, normals = _cylinder_side(np.random.default_rng(1), 0.04, 2.0)
    assert _noise_weighted(_settings(), points, normals, CENTER, AXIS, 0.04).normal_weight == 0.05


def test_normals_scattered_by_twelve_degrees_weigh_half() -> None:
    points, normals = _cylinder_side(np.random.default_rng(2), 0.04, 12.0)
    weight = _noise_weighted(_settings(), points, normals, CENTER, AXIS, 0.04).normal_weight
    assert 0.025 <= weight <= 0.03  # 6 / (about 12) of 0.05, never below half


def test_a_wrong_radius_is_not_excused_as_noise() -> None:
    """A 4 cm cylinder's steady normals under a 2.5 cm hypothesis disagree by tens of degrees, all within the
    cross-section: the measured scatter stays that of the noise, and the weight stays."""
    points, normals = _cylinder_side(np.random.default_rng(3), 0.04, 2.0)
    shifted = CENTER + np.array([0.0, 0.0, -0.015])  # the wrong model touches the points' front
    assert _noise_weighted(_settings(), points, normals, shifted, AXIS, 0.025).normal_weight == 0.05


def test_a_sphere_seen_as_a_cylinder_is_not_excused_as_noise() -> None:
    """A sphere's normals tilt along the cylinder's axis in step with the height: shape, not noise."""
    rng = np.random.default_rng(4)
    directions = rng.normal(size=(4000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions = directions[directions[:, 2] < -0.3]  # the cap toward the sensor
    points = CENTER + 0.04 * directions
    assert _noise_weighted(_settings(), points, directions, CENTER, AXIS, 0.04).normal_weight == 0.05
