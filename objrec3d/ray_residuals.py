"""What a depth camera sees of a solid: each point's error along its ray from the sensor, behind where the ray
enters the solid (a sphere or circle, a capped cylinder, a box), in metres; a ray that misses errs sideways.

The depth noise of such a camera lies along its rays, so these are the errors a fit by point positions
weighs (``cluster_fit``). The capped cylinder and the box come in batches of K solids at once (K x N errors),
written with K x N arrays only: the fixed cost of NumPy's calls, not the points, is most of an evaluation on a
far object's few hundred points, so a forward-difference Jacobian of all parameters costs about two
evaluations instead of one per parameter (``forward_jacobian``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .vec import norms, row_dots, squared_norms

#: A point is an inlier within this many sigmas of the depth noise at its range (along its ray).
INLIER_SIGMAS = 2.5


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` (a vector, or rows of vectors) scaled to length one."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across the unit ``axis`` and across each other."""
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


#: A ray that misses the surface errs sideways, where a depth camera is precise: such an error weighs this much
#: more than the same error along the ray.
SIDEWAYS_WEIGHT = 4.0


def front_residuals(pts: np.ndarray, rays: np.ndarray, center: np.ndarray, radius: float) -> np.ndarray:
    """How far each point lies along its ray from where the ray *enters* the circle (2D) or sphere (3D):
    positive behind the surface. Only the side facing the camera is visible, so a point is never explained by
    the far crossing (that lets a small circle absorb the noisy points near the silhouette). ``rays`` may be
    shorter than unit (a 3D ray seen in a cylinder's cross-section); a ray that misses: its sideways miss,
    weighted."""
    rel = pts - center
    a = np.maximum(np.einsum("ij,ij->i", rays, rays), 1e-12)
    b = np.einsum("ij,ij->i", rays, rel)
    q = np.einsum("ij,ij->i", rel, rel)
    disc = b * b - a * (q - radius * radius)
    enter = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
    miss = np.sqrt(np.maximum(q - b * b / a, 0.0)) - radius
    return np.where(disc >= 0.0, -enter, SIDEWAYS_WEIGHT * miss)


def sphere_residuals_batch(pts: np.ndarray, rays: np.ndarray, center: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """``front_residuals`` of K spheres at once (``center`` K x 3, ``radius`` K) for 3D points: K x N, each
    product with a point a K x N dot product (positions from the points' middle: no digits lost)."""
    middle = pts.mean(axis=0)
    local = pts - middle
    offset = center - middle
    a = np.maximum(squared_norms(rays), 1e-12)[None, :]
    b = row_dots(rays, local)[None, :] - np.einsum("hk,km->hm", offset, np.ascontiguousarray(rays.T))
    q = (squared_norms(local)[None, :] - 2.0 * np.einsum("hk,km->hm", offset, np.ascontiguousarray(local.T))
         + squared_norms(offset)[:, None])
    disc = b * b - a * (q - (radius * radius)[:, None])
    enter = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
    miss = np.sqrt(np.maximum(q - b * b / a, 0.0)) - radius[:, None]
    return np.where(disc >= 0.0, -enter, SIDEWAYS_WEIGHT * miss)


@dataclass(frozen=True)
class RayPoints:
    """Points seen along rays from ``sensor``, with what every evaluation of a solid on them needs computed
    once: their rays' squared lengths, their ranges, and their positions from their own middle (small numbers,
    so distances from a nearby axis lose no digits). The transposed arrays serve K x N dot products."""

    points: np.ndarray
    rays: np.ndarray
    sensor: np.ndarray
    middle: np.ndarray
    local: np.ndarray
    rays_t: np.ndarray
    local_t: np.ndarray
    ray_squared: np.ndarray
    local_squared: np.ndarray
    depth: np.ndarray

    @classmethod
    def of(cls, points: np.ndarray, rays: np.ndarray, sensor: np.ndarray) -> RayPoints:
        middle = points.mean(axis=0)
        local = points - middle
        return cls(points, rays, sensor, middle, local, np.ascontiguousarray(rays.T),
                   np.ascontiguousarray(local.T), squared_norms(rays), squared_norms(local), norms(points - sensor))

    def subset(self, mask: np.ndarray) -> RayPoints:
        """The points of ``mask``, their middle unchanged."""
        local = self.local[mask]
        rays = self.rays[mask]
        return RayPoints(self.points[mask], rays, self.sensor, self.middle, local, np.ascontiguousarray(rays.T),
                         np.ascontiguousarray(local.T), self.ray_squared[mask], self.local_squared[mask],
                         self.depth[mask])


def capped_residuals(pts: np.ndarray, rays: np.ndarray, sensor: np.ndarray, axis: np.ndarray, center: np.ndarray,
                     radius: float, low: float, high: float) -> tuple[np.ndarray, np.ndarray]:
    """How far each point lies along its ray (unit, from ``sensor``) behind where the ray enters a capped
    cylinder (its side between ``low`` and ``high`` along the axis from ``center``, and its flat ends): a
    standing cylinder seen from above shows its top as much as its side, and a fit of the side alone bends to
    take the top in. A ray that misses: the point's distance to the solid, weighted (``SIDEWAYS_WEIGHT``).
    Also whether each ray enters through the side (not an end). One cylinder of ``capped_residuals_batch``."""
    residual, side = capped_residuals_batch(RayPoints.of(pts, rays, sensor), np.asarray(axis, dtype=np.float64)[None],
                                            np.asarray(center, dtype=np.float64)[None], np.array([radius]),
                                            np.array([low]), np.array([high]))
    return residual[0], side[0]


def capped_residuals_batch(seen: RayPoints, axis: np.ndarray, center: np.ndarray, radius: np.ndarray,
                           low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``capped_residuals`` of K capped cylinders at once (``axis`` and ``center`` K x 3, the others K) on the
    points ``seen``: K x N errors and side masks. Every product with a point is a K x N dot product: no
    K x N x 3 temporaries. The crossing of a ray with the side, in the plane across the axis:
    ``a`` t^2 + 2 ``b`` t + ``c`` = 0."""
    o = seen.sensor - center
    along_o = row_dots(o, axis)
    along_d = np.einsum("hk,km->hm", axis, seen.rays_t)
    o_across = o - along_o[:, None] * axis
    a = np.maximum(seen.ray_squared[None, :] - along_d * along_d, 1e-12)
    b = np.einsum("hk,km->hm", o_across, seen.rays_t)  # the ray's part along the axis is across o_across
    c = squared_norms(o_across) - radius * radius
    disc = b * b - a * c[:, None]
    root = np.sqrt(np.maximum(disc, 0.0))
    side_in, side_out = (-b - root) / a, (-b + root) / a
    parallel = np.abs(along_d) < 1e-9
    safe = np.where(parallel, 1.0, along_d)
    t_low, t_high = (low - along_o)[:, None] / safe, (high - along_o)[:, None] / safe
    inside_slab = ((low <= along_o) & (along_o <= high))[:, None]
    slab_in = np.where(parallel, np.where(inside_slab, -np.inf, np.inf), np.minimum(t_low, t_high))
    slab_out = np.where(parallel, np.where(inside_slab, np.inf, -np.inf), np.maximum(t_low, t_high))
    enter = np.maximum(side_in, slab_in)
    hit = (disc >= 0.0) & (enter <= np.minimum(side_out, slab_out)) & np.isfinite(enter)
    offset = center - seen.middle
    along = np.einsum("hk,km->hm", axis, seen.local_t) - row_dots(offset, axis)[:, None]
    squared = (seen.local_squared[None, :] - 2.0 * np.einsum("hk,km->hm", offset, seen.local_t)
               + squared_norms(offset)[:, None])
    radial = np.sqrt(np.maximum(squared - along * along, 0.0)) - radius[:, None]
    axial = np.maximum(low[:, None] - along, along - high[:, None])
    miss = np.hypot(np.maximum(radial, 0.0), np.maximum(axial, 0.0))
    residual = np.where(hit, seen.depth - np.where(hit, enter, 0.0), SIDEWAYS_WEIGHT * miss)
    return residual, hit & (side_in >= slab_in)


def truncated_cost(error: np.ndarray) -> float:
    """The sum of squared errors (in sigmas), each capped at ``INLIER_SIGMAS`` squared: minus twice the log
    likelihood of the fit under Gaussian depth noise with a uniform share of outliers (MSAC's cost)."""
    return float(np.minimum(error * error, INLIER_SIGMAS**2).sum())


def box_residuals(pts: np.ndarray, rays: np.ndarray, sensor: np.ndarray, frame: np.ndarray, center: np.ndarray,
                  half: np.ndarray) -> np.ndarray:
    """How far each point lies along its ray behind where the ray enters a box (``frame``'s columns its
    axes, ``half`` its half sizes); a ray that misses: the point's distance to the box, weighted. One box of
    ``box_residuals_batch``."""
    return box_residuals_batch(pts, rays, sensor, frame[None], np.asarray(center)[None], np.asarray(half)[None])[0]


def box_residuals_batch(pts: np.ndarray, rays: np.ndarray, sensor: np.ndarray, frame: np.ndarray,
                        center: np.ndarray, half: np.ndarray) -> np.ndarray:
    """``box_residuals`` of K boxes at once (``frame`` K x 3 x 3, ``center`` and ``half`` K x 3): K x N. Axis by
    axis, each a K x N dot product: the slab each ray crosses between the box's two faces across the axis."""
    middle = pts.mean(axis=0)
    local_t = np.ascontiguousarray((pts - middle).T)
    rays_t = np.ascontiguousarray(rays.T)
    enter = leave = outside = None
    for j in range(3):
        axis = np.ascontiguousarray(frame[:, :, j])
        o = row_dots(sensor - center, axis)[:, None]
        d = np.einsum("hk,km->hm", axis, rays_t)
        safe = np.where(np.abs(d) < 1e-9, 1e-9, d)
        t1, t2 = (-half[:, j, None] - o) / safe, (half[:, j, None] - o) / safe
        near, far = np.minimum(t1, t2), np.maximum(t1, t2)
        local = np.einsum("hk,km->hm", axis, local_t) + row_dots(middle - center, axis)[:, None]
        beyond = np.maximum(np.abs(local) - half[:, j, None], 0.0)
        if enter is None:
            enter, leave, outside = near, far, beyond * beyond
        else:
            enter, leave, outside = np.maximum(enter, near), np.minimum(leave, far), outside + beyond * beyond
    depth = norms(pts - sensor)
    return np.where(enter <= leave, depth - enter, SIDEWAYS_WEIGHT * np.sqrt(outside))


def rotation(vector: np.ndarray) -> np.ndarray:
    """The rotation by ``vector`` (axis times angle, radians): Rodrigues' formula."""
    return rotations(np.asarray(vector, dtype=np.float64)[None])[0]


def rotations(vectors: np.ndarray) -> np.ndarray:
    """``rotation`` of K vectors (K x 3): K x 3 x 3."""
    angle = np.sqrt((vectors * vectors).sum(axis=1))
    tiny = angle < 1e-12
    k = vectors / np.where(tiny, 1.0, angle)[:, None]
    zero = np.zeros(k.shape[0])
    skew = np.stack([np.stack([zero, -k[:, 2], k[:, 1]], axis=1), np.stack([k[:, 2], zero, -k[:, 0]], axis=1),
                     np.stack([-k[:, 1], k[:, 0], zero], axis=1)], axis=1)
    out = (np.eye(3) + np.sin(angle)[:, None, None] * skew
           + (1.0 - np.cos(angle))[:, None, None] * np.einsum("kij,kjl->kil", skew, skew))
    out[tiny] = np.eye(3)
    return out
