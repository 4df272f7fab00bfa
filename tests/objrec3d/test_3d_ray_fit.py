"""The final fit measures each point's error along its ray when the depth noise is large for the radius: a
plain geometric circle fit of the ~120-degree arc a depth camera sees reads the radius small there."""

from __future__ import annotations

import numpy as np

from objrec3d.fitting import _geometric_fit, _ray_fit


def _arcs(rng: np.random.Generator, radius: float, noise: float, half_arc: float, runs: int = 40):
    """Points of the visible arc of a circle 2.25 m in front of the sensor, depth noise along each ray."""
    for _ in range(runs):
        angle = np.radians(rng.uniform(-half_arc, half_arc, 300))
        center = np.array([0.0, 2.25])
        surface = center + radius * np.stack([np.sin(angle), -np.cos(angle)], axis=1)
        rays = surface / np.linalg.norm(surface, axis=1, keepdims=True)
        yield surface + rays * rng.normal(0.0, noise, (300, 1)), rays, center


def test_the_ray_fit_reads_a_noisy_partial_arc_without_the_geometric_fits_bias() -> None:
    rng = np.random.default_rng(3)
    geometric, ray = [], []
    for points, rays, center in _arcs(rng, 0.045, 0.0063, 60.0):
        start = center + np.array([0.003, -0.004])
        geometric.append(_geometric_fit(points, start, 0.05)[1])
        ray.append(_ray_fit(points, rays, start, 0.05)[1])
    assert np.mean(geometric) < 0.045 - 0.003  # the geometric fit reads a 4.5 cm can 3+ mm small
    assert abs(np.mean(ray) - 0.045) < 0.0005  # the ray fit: within half a millimetre on average
    assert np.std(ray) < 0.002


def test_without_noise_both_fits_agree_exactly() -> None:
    rng = np.random.default_rng(4)
    points, rays, center = next(_arcs(rng, 0.03, 0.0, 60.0, runs=1))
    for fit in (_geometric_fit(points, center + 0.002, 0.035), _ray_fit(points, rays, center + 0.002, 0.035)):
        assert fit is not None
        assert abs(fit[1] - 0.03) < 1e-6 and np.linalg.norm(fit[0] - center) < 1e-6
