"""Localisation as amcl does it: a particle filter that matches laser scans to the map.

With noisy odometry, dead reckoning drifts without bound, and a robot driving on it misses its goals by
more than the tolerance after a few laps. amcl keeps a cloud of pose hypotheses instead: each is moved
by the odometry with the noise the odometry might have had (the ``diff`` motion model), weighted by how
well the laser scan seen from it lands on the map's walls (the likelihood field, from the
:class:`~navigation.costmap.ObstacleField`'s distance transform), and the cloud is resampled with
KLD sampling, so a converged cloud needs few particles.

The cost is bounded the way amcl bounds it: the filter runs only after the robot has moved
``update_min_d`` or turned ``update_min_a``, reads at most ``max_beams`` beams and keeps at most
``max_particles`` particles. Between updates the estimate follows odometry through the map -> odom
correction of the last update, as amcl's published transform does, which costs a few microseconds per
simulation step.

Three modes (``SimConfig.localization``): ``exact`` (navigation sees the true pose: no localizer at all),
``amcl`` (:class:`Amcl`) and ``odometry`` (:class:`OdometryLocalizer`, dead reckoning alone, the baseline
that shows what the filter corrects).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .costmap import ObstacleField
from .events import Event, EventLog
from .geometry import Pose2D, wrap_angle
from .grid_distance import distance_to_zero
from .laser import LaserParams, LaserScan, cast_scan

log = logging.getLogger(__name__)

LOCALIZATION_MODES = ("exact", "amcl", "odometry")

ScanSource = Callable[[LaserParams], LaserScan]


@dataclass(frozen=True)
class AmclParams:
    """amcl's parameters under amcl's names; its defaults except where noted.

    - ``max_particles`` 2000 (amcl 5000) as in the TurtleBot's amcl launch file.
    - ``kld_z`` is the upper standard normal quantile of the KLD bound: 2.33, the 1 % quantile that amcl's
      ``kld_z: 0.99`` stands for (amcl puts 0.99 itself into the formula, which asks for fewer particles
      than its own bound and, here, let the estimate stray past 0.1 m).
    - ``odom_alpha*`` 0.1 (amcl 0.2): still several times the 5 % wheel noise the tests drive with; a
      cloud spread wider than the odometry can err wanders along walls where the scan says little.
    - ``beam_skip`` on (amcl's ``do_beamskip``, off there): the simulated worlds hold obstacles the map
      does not, and a beam on one of those is better left out than explained by a wrong pose.
      ``beam_skip_distance`` 0.3 m (amcl 0.5): a crate standing 0.4 m from a wall is then skipped too,
      and the simulated laser is exact enough for beams on the map to stay within it.
    - ``short_margin`` 0.3 m: a beam this much shorter than the map's wall seen from the believed pose is
      left out (the beam model's ``z_short``: something unmapped in front of the wall) while the cloud's
      spread is below the margin; 0 turns it off.
    - ``initial_sigma_*`` 0.1 m and 0.05 rad (amcl's ``initial_cov`` 0.5 m and pi/12 rad, for a click in
      rviz): the patrol starts at a known pose, the station or ``--start``. :meth:`Amcl.set_pose` takes
      wider spreads.
    - ``resample_threshold``: resample when the effective number of particles falls below this share of the
      cloud (selective resampling; amcl resamples every update). ``cluster_radius``: the estimate is the
      weighted mean of the particles within this distance of the cloud's mean.

    A ``localization`` event is written every ``event_period`` simulated seconds and at every goal result.

    Confidence (not in amcl, which publishes a covariance and leaves judging it to others): after each update
    the filter measures the cloud's ``spread`` (metres, the root of the position covariance's trace) and the
    ``score``, the share of the scan's beams whose end points land within ``score_distance`` of a mapped
    obstacle, or short of a mapped wall (something unmapped in front of it, the beam model's ``z_short``), when
    cast from the pose believed just before the scan (the last estimate moved by odometry). A pose is lost when
    the spread exceeds ``lost_spread`` for ``lost_after`` updates in a row or the mean score of the last
    ``lost_after`` updates falls below ``lost_score`` (a filter that is wrong soon finds a pose that explains one
    wall, so its scores jump; their mean does not). It is found again after ``found_after`` updates in a row
    within ``lost_spread`` whose mean share of beams on the map (no credit for short ones) is at least
    ``found_score``: 12 updates of ``update_min_a`` are a full turn on the spot, and the camera-like laser sees
    only 58 degrees at a time.
    """

    min_particles: int = 100
    max_particles: int = 2000
    kld_err: float = 0.01
    kld_z: float = 2.33
    bin_xy: float = 0.5
    bin_yaw: float = math.radians(10.0)
    update_min_d: float = 0.2
    update_min_a: float = math.pi / 6.0
    max_beams: int = 30
    z_hit: float = 0.95
    z_rand: float = 0.05
    sigma_hit: float = 0.2
    likelihood_max_dist: float = 2.0
    odom_alpha1: float = 0.1
    odom_alpha2: float = 0.1
    odom_alpha3: float = 0.1
    odom_alpha4: float = 0.1
    beam_skip: bool = True
    beam_skip_distance: float = 0.3
    beam_skip_threshold: float = 0.3
    beam_skip_error_threshold: float = 0.9
    resample_threshold: float = 0.5
    cluster_radius: float = 0.5
    initial_sigma_xy: float = 0.1
    initial_sigma_yaw: float = 0.05
    event_period: float = 10.0
    lost_spread: float = 0.5
    lost_score: float = 0.6
    score_distance: float = 0.2
    lost_after: int = 3
    found_after: int = 12
    found_score: float = 0.7
    global_particles: int = 5000
    short_margin: float = 0.3

    def __post_init__(self) -> None:
        if not 1 <= self.min_particles <= self.max_particles:
            raise ValueError(f"need 1 <= min_particles <= max_particles, got {self.min_particles}, "
                             f"{self.max_particles}")
        if self.max_beams < 2:
            raise ValueError(f"max_beams must be at least 2, got {self.max_beams}")
        for name in ("kld_err", "kld_z", "bin_xy", "bin_yaw", "sigma_hit", "likelihood_max_dist", "cluster_radius",
                     "event_period", "update_min_d", "update_min_a", "lost_spread", "score_distance"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0 < self.beam_skip_distance < self.likelihood_max_dist:
            raise ValueError(f"beam_skip_distance must be in (0, likelihood_max_dist), got {self.beam_skip_distance}")
        if not 0 <= self.lost_score <= self.found_score <= 1:
            raise ValueError(f"need 0 <= lost_score <= found_score <= 1, got {self.lost_score}, {self.found_score}")
        if self.lost_after < 1 or self.found_after < 1:
            raise ValueError(f"lost_after and found_after must be at least 1, got {self.lost_after}, "
                             f"{self.found_after}")


@dataclass(frozen=True)
class Confidence:
    """How sure the filter is after an update: the cloud's ``spread`` (m), the ``score`` (share of beams
    landing on mapped obstacles from the pose believed before the scan, 0..1) and ``likelihood``, the mean
    log-likelihood per beam at the new estimate. ``on_map`` is the stricter share that gives short beams no
    credit: losing a pose is judged leniently (a box in front of a wall is no sign of a wrong pose), finding
    it strictly (from a wrong pose many beams also end short of where the map has a wall)."""

    spread: float = 0.0
    score: float = 1.0
    likelihood: float = 0.0
    beams: int = 0
    on_map: float = 1.0

    def problem(self, params: AmclParams) -> str:
        """Why this confidence is below the declared bound, or "" when it is not."""
        if self.spread > params.lost_spread:
            return f"particle spread {self.spread:.2f} m > {params.lost_spread:g} m"
        if self.beams and self.score < params.lost_score:
            return f"only {self.score:.0%} of beams on the map (< {params.lost_score:.0%})"
        return ""


@dataclass(frozen=True)
class ScanView:
    """A scan the filter weighed, with the simulated time ``t`` and the odometry pose it was taken at: a robot
    turning on the spot collects a ring of these, which together see far more of the room than one 58 degree
    scan (see :mod:`navigation.amcl_global`)."""

    t: float
    odom: Pose2D
    scan: LaserScan


#: How many of the filter's latest scans :attr:`Amcl.views` keeps: two full turns of ``update_min_a``.
VIEWS_KEPT = 24


def compose(a: Pose2D, b: Pose2D) -> Pose2D:
    """``b`` (expressed in ``a``'s frame) in the frame ``a`` is expressed in."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.yaw + b.yaw))


def inverse(a: Pose2D) -> Pose2D:
    """The pose that undoes ``a``: ``compose(a, inverse(a))`` is the origin."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(-c * a.x - s * a.y, s * a.x - c * a.y, wrap_angle(-a.yaw))


def kld_sample_count(bins: int, err: float, z: float) -> int:
    """Particles enough that the sampled distribution is within ``err`` (KL divergence) of the true one
    with probability given by ``z``, when it covers ``bins`` histogram bins (Fox 2003, as amcl)."""
    if bins <= 1:
        return 1
    k = bins - 1
    b = 2.0 / (9.0 * k)
    x = 1.0 - b + math.sqrt(b) * z
    return math.ceil(k / (2.0 * err) * x * x * x)


#: Metres from any obstacle a pose drawn over the free space keeps (the robot's centre cannot be nearer a wall).
SEED_CLEARANCE = 0.15


class ParticleFilter:
    """The particle cloud and its three operations: predict (odometry), weigh (scan), resample.

    The cloud is the arrays ``x``, ``y`` (map frame), ``yaw`` (not wrapped to (-pi, pi]) and the weights
    ``w``. The likelihood table is indexed in the grid of the field with one more ring of "far from
    everything" cells, so beam end points off the map cost one clip, not a test.
    """

    def __init__(self, field: ObstacleField, params: AmclParams | None = None,
                 rng: np.random.Generator | None = None) -> None:
        self.params = p = params or AmclParams()
        self.rng = rng or np.random.default_rng(0)
        self.field = field
        m = field.map
        self._res = m.resolution
        self._origin = m.origin
        self._c0, self._s0 = math.cos(m.origin.yaw), math.sin(m.origin.yaw)
        # Distance of each cell to the nearest obstacle surface, from either side: from free cells the
        # field's distance transform, from inside obstacles the distance to the nearest free cell. A plain
        # distance-to-obstacle table is zero all through a solid block (or the unknown space behind a
        # wall, which counts as obstacle), so a pose whose beams end deep inside one would score as well
        # as the true pose, and the cloud slides through walls.
        inner = distance_to_zero(field.obstacle.astype(np.uint8))
        d = np.where(field.obstacle, inner * self._res, field.dist) - 0.5 * self._res
        d = np.clip(d, 0.0, p.likelihood_max_dist)
        # Probability of a beam end point at each cell: a hit blurred by sigma_hit; the random returns'
        # share z_rand / range_max depends on the scan's range_max and is added in _log_table().
        self._hit = p.z_hit * np.exp(-(d * d) / (2.0 * p.sigma_hit ** 2))
        self._far_hit = p.z_hit * math.exp(-(p.likelihood_max_dist ** 2) / (2.0 * p.sigma_hit ** 2))
        self._table_range: float | None = None
        self._table = np.zeros(0)
        self._rand = 0.0
        self.skipped_beams = 0
        self.short_beams = 0
        self._beam_key: tuple[int, float, float] | None = None
        self._beam_idx = np.zeros(0, np.intp)
        self._beam_angles = np.zeros(0)
        self._tw = field.width + 2
        self._th = field.height + 2
        self.x = np.zeros(0)
        self.y = np.zeros(0)
        self.yaw = np.zeros(0)
        self.w = np.zeros(0)

    @property
    def count(self) -> int:
        return len(self.x)

    def initialize(self, pose: Pose2D, sigma_xy: float | None = None, sigma_yaw: float | None = None,
                   count: int | None = None) -> None:
        """A Gaussian cloud around ``pose``, as amcl's initial pose (max_particles of them by default)."""
        p = self.params
        n = count or p.max_particles
        sxy = p.initial_sigma_xy if sigma_xy is None else sigma_xy
        syaw = p.initial_sigma_yaw if sigma_yaw is None else sigma_yaw
        self.x = pose.x + self.rng.normal(0.0, sxy, n) if sxy > 0 else np.full(n, pose.x)
        self.y = pose.y + self.rng.normal(0.0, sxy, n) if sxy > 0 else np.full(n, pose.y)
        self.yaw = pose.yaw + self.rng.normal(0.0, syaw, n) if syaw > 0 else np.full(n, pose.yaw)
        self.w = np.full(n, 1.0 / n)

    def predict(self, old: Pose2D, new: Pose2D) -> None:
        """Move every particle by the odometry step old -> new with sampled noise (amcl's ``diff`` model)."""
        p = self.params
        dx, dy = new.x - old.x, new.y - old.y
        trans = math.hypot(dx, dy)
        rot1 = 0.0 if trans < 0.01 else wrap_angle(math.atan2(dy, dx) - old.yaw)
        rot2 = wrap_angle(new.yaw - old.yaw - rot1)
        # Driving backwards is a small rotation, not a half turn, for the noise (as amcl does).
        rot1_n = min(abs(rot1), abs(wrap_angle(rot1 - math.pi)))
        rot2_n = min(abs(rot2), abs(wrap_angle(rot2 - math.pi)))
        s_rot1 = math.sqrt(p.odom_alpha1 * rot1_n * rot1_n + p.odom_alpha2 * trans * trans)
        s_trans = math.sqrt(p.odom_alpha3 * trans * trans + p.odom_alpha4 * (rot1_n * rot1_n + rot2_n * rot2_n))
        s_rot2 = math.sqrt(p.odom_alpha1 * rot2_n * rot2_n + p.odom_alpha2 * trans * trans)
        noise = self.rng.standard_normal((3, self.count))
        r1 = rot1 - s_rot1 * noise[0]
        t = trans - s_trans * noise[1]
        r2 = rot2 - s_rot2 * noise[2]
        heading = self.yaw + r1
        self.x = self.x + t * np.cos(heading)
        self.y = self.y + t * np.sin(heading)
        self.yaw = heading + r2  # not wrapped: only cos, sin and the histogram (which wraps) read it

    def _log_table(self, range_max: float) -> np.ndarray:
        """Log-likelihood of an end point per cell (padded with a far ring), for this sensor's range_max."""
        if self._table_range != range_max:
            rand = self.params.z_rand / range_max
            table = np.full((self._th, self._tw), math.log(self._far_hit + rand))
            table[1:-1, 1:-1] = np.log(self._hit + rand)
            self._table = table.ravel()
            self._table_range = range_max
            self._rand = rand
        return self._table

    def beams(self, scan: LaserScan) -> tuple[np.ndarray, np.ndarray]:
        """At most max_beams evenly spread beams with a return: (angles in the robot frame, ranges).

        Beams without a return (max range) are left out, as amcl's likelihood field does: they say
        nothing about where a wall is.
        """
        key = (len(scan.ranges), scan.angle_min, scan.angle_increment)
        if key != self._beam_key:
            n = key[0]
            idx = np.unique(np.linspace(0, n - 1, min(n, self.params.max_beams)).round().astype(np.intp))
            self._beam_idx, self._beam_angles = idx, scan.angle_min + scan.angle_increment * idx
            self._beam_key = key
        ranges = scan.ranges[self._beam_idx]
        keep = (ranges >= scan.range_min) & (ranges < scan.range_max)  # also drops inf and NaN
        return self._beam_angles[keep], ranges[keep]

    def log_likelihood(self, scan: LaserScan, x: np.ndarray, y: np.ndarray, yaw: np.ndarray
                       ) -> tuple[np.ndarray, int]:
        """Sum over the scan's beams of log p(end point | pose), for each pose; and the beams used."""
        per_beam = self.beam_log_likelihoods(scan, x, y, yaw)
        return per_beam.sum(axis=1), per_beam.shape[1]

    def beam_log_likelihoods(self, scan: LaserScan, x: np.ndarray, y: np.ndarray, yaw: np.ndarray
                             ) -> np.ndarray:
        """log p(end point | pose) for each pose (rows) and each beam with a return (columns)."""
        angles, ranges = self.beams(scan)
        table = self._log_table(scan.range_max)
        if len(ranges) == 0:
            return np.zeros((len(x), 0))
        res, o = self._res, self._origin
        # Poses in the likelihood table's cell units (grid frame, plus the field's ring and the far ring);
        # float32 is ample for cell indices and halves the memory traffic of these (particles x beams) arrays.
        dx, dy = x - o.x, y - o.y
        gx = ((dx * self._c0 + dy * self._s0) / res + 2.0).astype(np.float32)[:, None]
        gy = ((-dx * self._s0 + dy * self._c0) / res + 2.0).astype(np.float32)[:, None]
        gyaw = yaw - o.yaw
        c, s = np.cos(gyaw).astype(np.float32), np.sin(gyaw).astype(np.float32)
        lx = (ranges * np.cos(angles) / res).astype(np.float32)
        ly = (ranges * np.sin(angles) / res).astype(np.float32)
        ex = np.multiply.outer(c, lx)
        ex -= np.multiply.outer(s, ly)
        ex += gx
        ey = np.multiply.outer(s, lx)
        ey += np.multiply.outer(c, ly)
        ey += gy
        # Clipped to the far ring first, so truncation is the floor.
        np.clip(ex, 0, self._tw - 1, out=ex)
        np.clip(ey, 0, self._th - 1, out=ey)
        flat = ey.astype(np.int32)
        flat *= self._tw
        flat += ex.astype(np.int32)
        return table.take(flat)

    def weigh(self, scan: LaserScan, expected: LaserScan | None = None) -> int:
        """Multiply the weights by the scan's likelihood; returns the number of beams used.

        With ``beam_skip`` (amcl's ``do_beamskip``), a beam is left out when its end point lies within
        ``beam_skip_distance`` of a mapped obstacle for fewer than ``beam_skip_threshold`` of the particles:
        it has hit something the map does not know (a box, a person), which no pose explains, and scoring it
        would drag the cloud towards poses where it happens to land on some wall. The distance grows to
        twice the cloud's spread when that is wider, so that a cloud still converging keeps the beams it
        converges on. When nearly all beams would go, the cloud is lost rather than the beams wrong, and
        all are kept (as amcl does).

        ``expected`` (the same beams cast on the map from the pose believed before the scan) adds the beam
        model's ``z_short``: a beam ending more than ``short_margin`` before the mapped wall it points at has
        hit something in front of it that the map lacks, and is left out. Beside a row of pillars an unmapped
        box is near some pillar for a cloud shifted by a pillar pitch, so the share test above keeps its beams
        and they drag the estimate; the short test does not depend on the cloud.
        """
        per_beam = self.beam_log_likelihoods(scan, self.x, self.y, self.yaw)
        used = per_beam.shape[1]
        if used == 0:
            return 0
        p = self.params
        self.skipped_beams = 0
        self.short_beams = 0
        # Only for a cloud narrower than the margin: from a wide cloud (a guess, a re-seed) the believed pose says
        # too little about where the walls are, and the beams that disagree with it are the ones that correct it.
        if (expected is not None and p.short_margin > 0 and len(expected.ranges) == len(scan.ranges)
                and self.spread() < p.short_margin):
            ranges = scan.ranges[self._beam_idx]
            valid = (ranges >= scan.range_min) & (ranges < scan.range_max)
            short = ranges[valid] < expected.ranges[self._beam_idx][valid] - p.short_margin
            n_short = int(np.count_nonzero(short))
            if 0 < n_short < p.beam_skip_error_threshold * used:
                per_beam = per_beam[:, ~short]
                used -= n_short
                self.short_beams = n_short
        if p.beam_skip:
            mx, my = float(np.dot(self.w, self.x)), float(np.dot(self.w, self.y))
            spread = math.sqrt(max(0.0, float(np.dot(self.w, self.x * self.x + self.y * self.y)) - mx * mx - my * my))
            d = min(max(p.beam_skip_distance, 2.0 * spread), p.likelihood_max_dist)
            near_log = math.log(p.z_hit * math.exp(-d * d / (2.0 * p.sigma_hit ** 2)) + self._rand)
            # Judged on an even subset of at most 128 particles: a share needs no more, and this runs every update.
            step = max(1, self.count // 128)
            sample = per_beam[::step]
            keep = np.count_nonzero(sample >= near_log, axis=0) >= p.beam_skip_threshold * len(sample)
            skipped = used - int(np.count_nonzero(keep))
            if 0 < skipped < p.beam_skip_error_threshold * used:
                per_beam = per_beam[:, keep]
                used -= skipped
                self.skipped_beams = skipped
            elif skipped:
                log.debug("%d of %d beams far from the map for most particles: the cloud is lost, all kept",
                          skipped, used)
        ll = per_beam.sum(axis=1)
        w = self.w * np.exp(ll - ll.max())
        total = w.sum()
        self.w = w / total if total > 0 and math.isfinite(total) else np.full(self.count, 1.0 / self.count)
        return used

    def spread(self) -> float:
        """Root of the trace of the weighted position covariance (metres): how wide the cloud is."""
        mx, my = float(np.dot(self.w, self.x)), float(np.dot(self.w, self.y))
        return math.sqrt(max(0.0, float(np.dot(self.w, self.x * self.x + self.y * self.y)) - mx * mx - my * my))

    def score(self, scan: LaserScan, pose: Pose2D, expected: LaserScan | None = None
              ) -> tuple[float, float, float, int]:
        """(share of beams explained, share on the map, mean log-likelihood per beam, beams) for the scan seen
        from ``pose``.

        A beam is explained when it ends within ``score_distance`` of a mapped obstacle, or, given ``expected``
        (the same beams cast on the map from ``pose``), when it ends more than ``score_distance`` short of the
        mapped wall: the beam model's ``z_short`` part, something the map lacks (a box, a walker) in front of
        a wall that is where the map says; at most as many short beams are explained as land on the map. A
        beam that goes on through a mapped wall is never explained.
        """
        row = self.beam_log_likelihoods(scan, np.array([pose.x]), np.array([pose.y]), np.array([pose.yaw]))[0]
        if len(row) == 0:
            return 1.0, 1.0, 0.0, 0
        p = self.params
        d = p.score_distance
        near_log = math.log(p.z_hit * math.exp(-d * d / (2.0 * p.sigma_hit ** 2)) + self._rand)
        on_map = row >= near_log
        explained = on_map.copy()
        if expected is not None and len(expected.ranges) == len(scan.ranges):
            ranges = scan.ranges[self._beam_idx]
            keep = (ranges >= scan.range_min) & (ranges < scan.range_max)
            explained |= ranges[keep] < expected.ranges[self._beam_idx][keep] - d
        n = len(row)
        hits = int(np.count_nonzero(on_map))
        # Something unmapped hides some walls, not most: short beams are credited up to as many as land on the
        # map. A robot carried off to a cramped place sees every wall nearer than the map says; that is no box.
        short = min(int(np.count_nonzero(explained)) - hits, hits)
        return (hits + short) / n, hits / n, float(row.mean()), n

    def seed_free_space(self, count: int, clearance: float = SEED_CLEARANCE) -> None:
        """Particles spread evenly over the map's free cells at least ``clearance`` from obstacles, with any
        heading: the global re-seed of augmented MCL, when no guess of the pose is left."""
        self.x, self.y, self.yaw = self.free_space_poses(count, clearance)
        self.w = np.full(count, 1.0 / count)

    def free_space_poses(self, count: int, clearance: float = SEED_CLEARANCE) -> tuple[np.ndarray, np.ndarray,
                                                                                        np.ndarray]:
        """``count`` poses (x, y, yaw arrays) drawn evenly over the free cells at least ``clearance`` from
        obstacles, with any heading."""
        rows, cols = np.nonzero(self.field.dist >= clearance)
        if len(rows) == 0:
            raise ValueError("the map has no free cell to seed particles in")
        pick = self.rng.integers(0, len(rows), count)
        gx = cols[pick] - 1 + self.rng.random(count)  # the field's grid has one ring more than the map's
        gy = rows[pick] - 1 + self.rng.random(count)
        m = self.field.map
        u, v = gx * self._res, gy * self._res
        return (m.origin.x + u * self._c0 - v * self._s0, m.origin.y + u * self._s0 + v * self._c0,
                self.rng.uniform(-math.pi, math.pi, count))

    @property
    def effective_count(self) -> float:
        return 1.0 / float(np.dot(self.w, self.w))

    def _systematic(self, n: int) -> np.ndarray:
        cum = np.cumsum(self.w)
        cum[-1] = 1.0
        return np.searchsorted(cum, (self.rng.random() + np.arange(n)) / n)

    def occupied_bins(self, idx: np.ndarray) -> int:
        """How many (x, y, yaw) histogram bins the particles ``idx`` fall in (the k of the KLD bound)."""
        p = self.params
        # One float key per bin (exact: bin numbers are small integers), counted after a sort.
        key = np.floor(self.x[idx] / p.bin_xy) * 1e6 + np.floor(self.y[idx] / p.bin_xy)
        key *= 1024.0
        key += np.floor(np.mod(self.yaw[idx], 2.0 * math.pi) / p.bin_yaw)
        key.sort()
        return int(np.count_nonzero(np.diff(key))) + 1 if len(key) else 0

    def resample(self) -> None:
        """Low-variance resampling to as many particles as the KLD bound asks for (within min/max)."""
        p = self.params
        drawn = self._systematic(self.count)
        need = kld_sample_count(self.occupied_bins(drawn), p.kld_err, p.kld_z)
        n = max(p.min_particles, min(p.max_particles, need))
        if n < self.count:
            idx = drawn[np.arange(n) * self.count // n]  # an even thinning of a systematic draw is one too
        else:
            idx = drawn if n == self.count else self._systematic(n)
        self.x, self.y, self.yaw = self.x[idx], self.y[idx], self.yaw[idx]
        self.w = np.full(n, 1.0 / n)

    def estimate(self) -> Pose2D:
        """The weighted mean of the main cluster: particles within cluster_radius of the overall mean,
        re-centred twice, so that a few stray particles do not pull the estimate off."""
        w, x, y, yaw = self.w, self.x, self.y, self.yaw
        mx, my = float(np.dot(w, x)), float(np.dot(w, y))
        r2 = self.params.cluster_radius ** 2
        sel = w
        for _ in range(2):
            near = (x - mx) ** 2 + (y - my) ** 2 <= r2
            if near.all() or not near.any():
                break  # the usual case once converged: one cluster, the plain weighted mean
            sel = w * near
            total = sel.sum()
            mx, my = float(np.dot(sel, x) / total), float(np.dot(sel, y) / total)
        return Pose2D(mx, my, math.atan2(float(np.dot(sel, np.sin(yaw))), float(np.dot(sel, np.cos(yaw)))))


class ErrorStats:
    """Distance between the estimate and the true pose, sampled every step (the truth is never fed back)."""

    def __init__(self) -> None:
        self.count = 0
        self.total = 0.0
        self.max = 0.0
        self.last = 0.0
        self.last_yaw = 0.0

    def record(self, estimate: Pose2D, truth: Pose2D) -> None:
        e = math.hypot(estimate.x - truth.x, estimate.y - truth.y)
        self.count += 1
        self.total += e
        self.last = e
        self.last_yaw = abs(wrap_angle(estimate.yaw - truth.yaw))
        if e > self.max:
            self.max = e

    @property
    def mean(self) -> float:
        return self.total / self.count if self.count else 0.0


class Localizer:
    """Where the navigation believes the robot is; :meth:`step` is called once per simulation step.

    ``estimate`` is the pose in the map frame; the odometry frame starts at ``start`` (the robot's pose
    when the odometry read zero). The true pose passed to :meth:`step` only feeds :attr:`errors` and the
    ``localization`` events, never the estimate. Events go out every ``event_period`` simulated seconds
    and at every goal result, so the error at each goal is on record.
    """

    mode = ""

    def __init__(self, start: Pose2D, events: EventLog | None = None, now: Callable[[], float] | None = None,
                 event_period: float = 10.0) -> None:
        self.start = start
        self.estimate = start
        self.errors = ErrorStats()
        self.updates = 0
        self._events = events
        self._now = now or (lambda: 0.0)
        self._event_period = event_period
        self._next_event = 0.0
        self.truth = start
        self.lost = False
        self.lost_count = 0
        self.confidence = Confidence()
        if events is not None:
            events.subscribe(self._on_event)

    @property
    def particles(self) -> int:
        return 0

    def step(self, odom: Pose2D, truth: Pose2D) -> None:
        raise NotImplementedError

    def _measured(self, truth: Pose2D) -> None:
        """Book the new estimate's error and write the periodic event when it is due."""
        self.truth = truth
        self.errors.record(self.estimate, truth)
        if self._events is not None and self._now() >= self._next_event:
            self._next_event = self._now() + self._event_period
            self._emit("period")

    def _emit(self, cause: str) -> None:
        if self._events is None:
            return
        e = self.estimate
        self._events.emit("localization", mode=self.mode, cause=cause, x=round(e.x, 4), y=round(e.y, 4),
                          yaw=round(e.yaw, 4), error=round(self.errors.last, 4),
                          yaw_error=round(self.errors.last_yaw, 4), particles=self.particles, updates=self.updates,
                          **self.pose_fields())

    def pose_fields(self) -> dict[str, Any]:
        """The believed and the true pose and the confidence, as event fields: ``believed`` and ``true`` are
        {x, y, yaw} in the map frame, ``spread`` (m) and ``score`` (0..1) the filter's confidence, ``lost``
        whether navigation currently distrusts the estimate."""
        c = self.confidence
        return {"believed": _rounded(self.estimate), "true": _rounded(self.truth), "spread": round(c.spread, 4),
                "score": round(c.score, 3), "lost": self.lost}

    def _on_event(self, event: Event) -> None:
        if event["type"] == "goal_result":
            self._emit("goal_result")
            if event.get("status") == "ABORTED":
                self._doubt()

    def _doubt(self) -> None:
        """A goal was aborted: a localizer that can look again does (see :meth:`Amcl._doubt`)."""


def _rounded(pose: Pose2D) -> dict[str, float]:
    return {"x": round(pose.x, 4), "y": round(pose.y, 4), "yaw": round(pose.yaw, 4)}


class OdometryLocalizer(Localizer):
    """Dead reckoning alone: the estimate is wherever the wheels say, drift included."""

    mode = "odometry"

    def step(self, odom: Pose2D, truth: Pose2D) -> None:
        self.estimate = compose(self.start, odom)
        self._measured(truth)


class Amcl(Localizer):
    """The amcl node: runs the filter when the robot has moved enough, and keeps the map -> odom correction.

    ``scan`` is called with the laser parameters to use: the simulated laser restricted to the
    ``max_beams`` beams the filter reads, so that no time goes into casting beams it would drop.
    """

    mode = "amcl"

    def __init__(self, field: ObstacleField, start: Pose2D, scan: ScanSource, laser: LaserParams,
                 params: AmclParams | None = None, rng: np.random.Generator | None = None,
                 events: EventLog | None = None, now: Callable[[], float] | None = None) -> None:
        p = params or AmclParams()
        super().__init__(start, events, now, p.event_period)
        self.params = p
        self.filter = ParticleFilter(field, p, rng)
        self.filter.initialize(start)
        self.estimate = self.filter.estimate()
        self._scan = scan
        self._laser = replace(laser, beams=min(laser.beams, p.max_beams))
        self._odom = self._odom_at_update = Pose2D(0.0, 0.0, 0.0)
        self._map_odom = self.estimate  # the odometry reads zero at the start
        self._first = True  # amcl weighs the first scan whether or not the robot has moved
        self.resamples = 0
        self.beams_used = 0
        self._bad = 0
        self._good = 0
        self._scores: list[float] = []
        self._found_scores: list[float] = []
        self._strict_next = False
        self.regained_count = 0
        self.last_good = self.estimate  # the last estimate the filter trusted: where a local re-seed starts
        self.views: deque[ScanView] = deque(maxlen=VIEWS_KEPT)  # the latest scans weighed, for global search
        self.lost_at = 0.0  # simulated time of the latest localization_lost
        # A second opinion asked before a lost filter trusts a pose again: why not, or "" (see Relocalize).
        self.confirm: Callable[[Pose2D], str] | None = None
        self.rejected = 0

    @property
    def particles(self) -> int:
        return self.filter.count

    @property
    def odom(self) -> Pose2D:
        """The latest odometry pose the filter was stepped with."""
        return self._odom

    @property
    def laser(self) -> LaserParams:
        """The laser as the filter reads it: at most ``max_beams`` beams."""
        return self._laser

    def set_pose(self, pose: Pose2D, sigma_xy: float | None = None, sigma_yaw: float | None = None) -> None:
        """Start the cloud afresh around ``pose`` (amcl's ``initialpose``, rviz's "2D Pose Estimate");
        the next step weighs a scan whether or not the robot moves."""
        self.filter.initialize(pose, sigma_xy, sigma_yaw)
        self._restart()

    def seed_free_space(self, count: int | None = None) -> None:
        """Spread the cloud over the whole free map (global localisation); the next step weighs a scan."""
        self.filter.seed_free_space(count or self.params.global_particles)
        self._restart()

    def _restart(self) -> None:
        self._good = 0  # a re-seeded cloud proves itself afresh
        self._found_scores = []
        self.estimate = self.filter.estimate()
        self._map_odom = compose(self.estimate, inverse(self._odom))
        self._odom_at_update = self._odom
        self._first = True

    def step(self, odom: Pose2D, truth: Pose2D) -> None:
        self._odom = odom
        self.truth = truth
        last, p = self._odom_at_update, self.params
        dx, dy = odom.x - last.x, odom.y - last.y
        if (self._first or dx * dx + dy * dy >= p.update_min_d * p.update_min_d
                or abs(wrap_angle(odom.yaw - last.yaw)) >= p.update_min_a):
            self.update(odom)
        self.estimate = compose(self._map_odom, odom)
        self._measured(truth)

    def update(self, odom: Pose2D) -> None:
        """One filter update at odometry pose ``odom``: predict, weigh with a fresh scan, resample."""
        pf = self.filter
        believed = compose(self._map_odom, odom)  # where the robot believed it was before this scan
        if not self._first:
            pf.predict(self._odom_at_update, odom)
        self._first = False
        scan = self._scan(self._laser)
        self.views.append(ScanView(self._now(), odom, scan))
        expected = cast_scan(pf.field, believed, replace(self._laser, noise=0.0))
        self.beams_used = pf.weigh(scan, expected)
        estimate = pf.estimate()  # from the weighted cloud: resampling would only add sampling noise
        # The score is judged at the pose believed before the scan, not at the new estimate: after weighing, the
        # best-fitting particles always explain one wall of a 58 degree view, right or wrong.
        score, on_map, _, beams = pf.score(scan, believed, expected)
        likelihood = pf.score(scan, estimate)[2]
        self.confidence = Confidence(pf.spread(), score, likelihood, beams, on_map)
        self.estimate = estimate
        self._judge()
        if pf.effective_count < self.params.resample_threshold * pf.count:
            pf.resample()
            self.resamples += 1
        self.updates += 1
        self._map_odom = compose(estimate, inverse(odom))
        self._odom_at_update = odom


    def _doubt(self) -> None:
        """An aborted goal ("no path", "start is in an obstacle") is what a wrong pose looks like to move_base,
        and a robot that no longer moves gets no filter update. Weigh a fresh scan at once, and judge it
        strictly: without credit for short beams, which from a wrong pose are walls where the map has none."""
        self._first = True
        self._strict_next = True

    def _judge(self) -> None:
        """Raise ``localization_lost`` when the spread stays too wide for ``lost_after`` updates or the mean score
        of the last ``lost_after`` updates is too low; ``localization_regained`` after ``found_after`` updates in a
        row within ``lost_spread`` whose mean score reaches ``found_score``."""
        p, c = self.params, self.confidence
        if c.beams:  # a scan with no return says nothing about the map
            self._scores = [*self._scores[1 - p.lost_after:], c.score]
        if self.lost:
            self._found_scores = [*self._found_scores[1 - p.found_after:], c.on_map] if c.beams else self._found_scores
            self._good = 0 if c.spread > p.lost_spread else self._good + 1
            found = sum(self._found_scores) / len(self._found_scores) if self._found_scores else 0.0
            if self._good >= p.found_after and found >= p.found_score:
                why = self.confirm(self.estimate) if self.confirm is not None else ""
                if why:
                    self.rejected += 1
                    self._good = 0  # look for another full turn
                    self._found_scores = []
                    log.info("pose not trusted again: %s", why)
                    if self._events is not None:
                        self._events.emit("pose_rejected", reason=why, **self.pose_fields())
                    return
                self.lost = False
                self.regained_count += 1
                self._scores = []
                self.last_good = self.estimate
                log.info("localization regained")
                if self._events is not None:
                    self._events.emit("localization_regained", **self.pose_fields())
            return
        self._bad = self._bad + 1 if c.spread > p.lost_spread else 0
        mean = sum(self._scores) / len(self._scores) if len(self._scores) == p.lost_after else 1.0
        problem = c.problem(p) if self._bad >= p.lost_after else ""
        strict, self._strict_next = self._strict_next, False
        if not problem and strict and c.beams and c.on_map < p.lost_score:
            problem = f"a goal was aborted and only {c.on_map:.0%} of beams are on the map (< {p.lost_score:.0%})"
        if not problem and mean < p.lost_score:
            problem = f"only {mean:.0%} of beams on the map over the last {p.lost_after} updates (< {p.lost_score:.0%})"
        if not problem:
            self.last_good = self.estimate
            return
        self.lost = True
        self.lost_at = self._now()
        self.lost_count += 1
        self._good = 0
        self._found_scores = []
        log.info("localization lost: %s", problem)
        if self._events is not None:
            self._events.emit("localization_lost", reason=problem, **self.pose_fields())


def make_localizer(mode: str, *, field: ObstacleField, start: Pose2D, scan: ScanSource, laser: LaserParams,
                   params: AmclParams | None = None, rng: np.random.Generator | None = None,
                   events: EventLog | None = None, now: Callable[[], float] | None = None) -> Localizer | None:
    """The localizer for ``mode``; None for ``exact`` (navigation reads the true pose directly)."""
    if mode == "exact":
        return None
    if mode == "amcl":
        return Amcl(field, start, scan, laser, params, rng, events, now)
    if mode == "odometry":
        return OdometryLocalizer(start, events, now, (params or AmclParams()).event_period)
    raise ValueError(f"unknown localization mode {mode!r}: expected one of {', '.join(LOCALIZATION_MODES)}")
