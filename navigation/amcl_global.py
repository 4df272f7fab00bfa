"""Global localisation from a full turn of scans, and the check that the map can tell where the robot is.

A particle cloud spread over the whole map and weighed one 58 degree scan at a time collapses after the first scan
onto whichever poses happen to see a wall where that scan saw one, and with few particles near the truth it may
never recover: augmented MCL's random injection relies on a scan that singles out the right place, which a narrow
view rarely is. A robot turning on the spot has a better piece of evidence: the ring of scans it took during one
turn (:attr:`navigation.localization.Amcl.views`), each at a known odometry pose relative to the others.
:func:`search` scores many poses spread over the free map against the whole ring at once (the likelihood field
summed over every view; on a large map first against a thinned ring, ``COARSE_BEAMS`` beams a view, and only the
``COARSE_KEEP`` best against the whole), keeps the best distinct hypotheses, refines each by local sampling, and
then checks each one the strict way: it casts the ring of scans on the map from the hypothesis and counts the beams
whose range agrees (:func:`agreement`). A pose that explains 90 % of a full turn is very likely right; two distinct
poses that both do mean the map itself cannot tell them apart (a symmetric room), and the robot should say so rather
than drive on either. When three or more such poses are strung along one line with the same heading (up to a half
turn), the robot stands in a corridor whose walls look the same all along within the laser's reach:
:func:`along_a_line` says so ("cannot tell where along the corridor") instead of naming two of the places as if they
were the only two.

How many poses are scored follows the map: ``seeds_per_square_metre`` of the free area the filter seeds in,
never fewer than ``min_seeds`` (a room of up to 22 m² keeps the lessons' 20,000) nor more than ``max_seeds`` (the
bound on the CPU of one search: the poses are scored in blocks of :data:`SCORE_BLOCK`, so memory stays bounded
too). A fixed count spreads thin on a large map (20,000 poses over the Willow Garage office's 857 m² are 23 per
square metre, one per 4 cm x 4 cm x 15 degrees nowhere near), and the true place may then have no pose near
enough to score well.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from .geometry import Pose2D, wrap_angle
from .laser import LaserParams, cast_scan
from .localization import SEED_CLEARANCE, ParticleFilter, ScanView, compose, inverse

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class GlobalSearchParams:
    """``seeds_per_square_metre`` poses per square metre of free space (at least ``min_seeds``, at most
    ``max_seeds``: :func:`seed_count`) are scored against the ring of views; the best ``hypotheses`` distinct ones
    (closer than
    ``separation`` m and ``separation_yaw`` rad are one) are refined in ``refine_rounds`` rounds of
    ``refine_samples`` samples, the spread halving each round from ``refine_xy`` m and ``refine_yaw`` rad. A
    beam agrees with the map when its range is within ``range_tolerance`` m of the range cast on the map (or
    both see nothing within the laser's reach). A hypothesis is worth trying when at least ``accept`` of the
    ring's beams agree; when a distinct runner-up comes within ``ambiguity_margin`` of the best, the map cannot
    tell the two apart; when three or more equally good ones lie within ``line_tolerance`` m of one line (or of it
    and a parallel line, for those facing the other way), it cannot tell where along a corridor the robot is."""

    seeds_per_square_metre: float = 900.0
    min_seeds: int = 20000
    max_seeds: int = 600000
    hypotheses: int = 8
    refine_rounds: int = 5
    refine_samples: int = 200
    refine_xy: float = 0.2
    refine_yaw: float = 0.15
    separation: float = 0.5
    separation_yaw: float = 0.5
    line_tolerance: float = 0.25
    range_tolerance: float = 0.15
    accept: float = 0.75
    ambiguity_margin: float = 0.08

    def __post_init__(self) -> None:
        for name in ("seeds_per_square_metre", "min_seeds", "max_seeds", "hypotheses", "refine_rounds",
                     "refine_samples", "refine_xy", "refine_yaw", "separation", "separation_yaw", "line_tolerance",
                     "range_tolerance",
                     "accept", "ambiguity_margin"):
            if not getattr(self, name) > 0:
                raise ValueError(f"global search {name} must be positive, got {getattr(self, name)}")
        if self.accept > 1:
            raise ValueError(f"global search accept must be at most 1, got {self.accept}")
        if self.min_seeds > self.max_seeds:
            raise ValueError(f"global search min_seeds ({self.min_seeds}) must not exceed max_seeds "
                             f"({self.max_seeds})")


@dataclass(frozen=True)
class Hypothesis:
    """A pose of the robot now (map frame), its summed log-likelihood over the ring of views and the share of
    the ring's beams whose range agrees with the map seen from it."""

    pose: Pose2D
    likelihood: float
    agreement: float

    def distinct_from(self, other: Hypothesis, params: GlobalSearchParams) -> bool:
        return (self.pose.distance_to(other.pose) > params.separation
                or abs(wrap_angle(self.pose.yaw - other.pose.yaw)) > params.separation_yaw)

    def describe(self) -> str:
        return f"({self.pose.x:.2f}, {self.pose.y:.2f}, {self.pose.yaw:.2f}) with {self.agreement:.0%} of beams"


def yaw_covered(views: Sequence[ScanView], fov: float) -> float:
    """How much of a full turn (radians, at most 2 pi) the views' headings and the laser's field of view cover."""
    if not views:
        return 0.0
    step = math.radians(1.0)
    seen = np.zeros(360, bool)
    for v in views:
        first = math.floor((v.odom.yaw - fov / 2) / step)
        seen[np.arange(first, first + math.ceil(fov / step) + 1) % 360] = True
    return float(np.count_nonzero(seen)) * step


def latest_turn(views: Sequence[ScanView], since: float, fov: float) -> list[ScanView]:
    """The latest views taken at or after ``since``, as few as cover a full turn; all of them when they do not."""
    recent = [v for v in views if v.t >= since]
    for k in range(len(recent) - 1, -1, -1):
        if yaw_covered(recent[k:], fov) >= 2.0 * math.pi - 1e-6:
            return recent[k:]
    return recent


#: Poses scored at once: their (poses x beams) arrays of one view stay a few tens of megabytes.
SCORE_BLOCK = 20000
#: A search of more than twice this many poses scores them first on a thinned ring (``COARSE_BEAMS`` beams a
#: view instead of amcl's ``max_beams``) and only this many best on the whole ring: scoring is nearly all of a
#: search's CPU, and poses that explain the thinned ring badly never win on the whole one. The lessons' rooms
#: (``min_seeds``, the same count) keep their one exact pass.
COARSE_KEEP = 20000
#: Beams a view keeps in the thinned ring (evenly over its field of view): a third of amcl's 30.
COARSE_BEAMS = 10
#: The thinned ring keeps every other view while those still cover this share of a full turn (12 views 30 degrees
#: apart, each 58 degrees wide: every other one covers 348 of 360). With ``COARSE_BEAMS`` the first pass costs
#: about a sixth of the whole ring's; a search on the Willow Garage office went from 2.1-2.6 s of CPU to 0.8-0.9 s,
#: the same place found.
COARSE_COVER = 0.9


def free_area(pf: ParticleFilter) -> float:
    """Square metres of the free space the filter seeds poses in (:meth:`ParticleFilter.free_space_poses`)."""
    return float(np.count_nonzero(pf.field.dist >= SEED_CLEARANCE)) * pf.field.map.resolution ** 2


def seed_count(pf: ParticleFilter, params: GlobalSearchParams) -> int:
    """How many poses a global search scores on this map: the density times the free area, within the bounds."""
    wanted = round(params.seeds_per_square_metre * free_area(pf))
    return int(min(params.max_seeds, max(params.min_seeds, wanted)))


def ring_log_likelihood(pf: ParticleFilter, views: Sequence[ScanView], odom_now: Pose2D, x: np.ndarray,
                        y: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """For each pose of the robot now (x, y, yaw), the likelihood field's log-likelihood summed over every beam
    of every view, each view placed by the odometry between when it was taken and now."""
    total = np.zeros(len(x))
    back = inverse(odom_now)
    c, s = np.cos(yaw), np.sin(yaw)
    for view in views:
        rel = compose(back, view.odom)  # where the view was taken, in the frame of the robot now
        vx = x + c * rel.x - s * rel.y
        vy = y + s * rel.x + c * rel.y
        total += pf.beam_log_likelihoods(view.scan, vx, vy, yaw + rel.yaw).sum(axis=1)
    return total


def thinned(views: Sequence[ScanView], beams: int) -> list[ScanView]:
    """The views with about ``beams`` beams each, evenly spaced (every k-th of the scan's, so the scan's angles
    stay evenly spaced as a LaserScan needs)."""
    out = []
    for view in views:
        scan = view.scan
        step = max(1, len(scan.ranges) // beams)
        out.append(replace(view, scan=replace(scan, angle_increment=scan.angle_increment * step,
                                              ranges=scan.ranges[::step])))
    return out


def coarse_ring(views: Sequence[ScanView], laser: LaserParams) -> list[ScanView]:
    """The ring the first pass of a large search scores: every other view while they still cover
    ``COARSE_COVER`` of a turn (all of them otherwise), each thinned to ``COARSE_BEAMS`` beams."""
    half = list(views[::2])
    ring = half if yaw_covered(half, laser.fov) >= COARSE_COVER * 2.0 * math.pi else list(views)
    return thinned(ring, COARSE_BEAMS)


def scores(pf: ParticleFilter, views: Sequence[ScanView], odom_now: Pose2D, x: np.ndarray, y: np.ndarray,
           yaw: np.ndarray) -> np.ndarray:
    """``ring_log_likelihood`` of many poses, in blocks of ``SCORE_BLOCK`` (memory stays bounded)."""
    return np.concatenate([ring_log_likelihood(pf, views, odom_now, x[k:k + SCORE_BLOCK], y[k:k + SCORE_BLOCK],
                                               yaw[k:k + SCORE_BLOCK]) for k in range(0, len(x), SCORE_BLOCK)])


def agreement(pf: ParticleFilter, views: Sequence[ScanView], odom_now: Pose2D, pose: Pose2D, laser: LaserParams,
              tolerance: float) -> float:
    """Share of the views' beams (every beam, those that saw nothing too) whose range is within ``tolerance`` of
    the range cast on the map from ``pose`` (the robot now): the beam model's strict test, which also counts a
    beam that runs on through a mapped wall, or stops where the map has nothing, against the pose."""
    back = inverse(odom_now)
    exact = replace(laser, noise=0.0)
    agree = total = 0
    for view in views:
        scan = view.scan
        expected = cast_scan(pf.field, compose(pose, compose(back, view.odom)), replace(exact, beams=len(scan.ranges)))
        seen, cast = scan.ranges, expected.ranges
        hit_seen, hit_cast = np.isfinite(seen), np.isfinite(cast)
        both = hit_seen & hit_cast
        near = np.abs(seen[both] - cast[both]) <= tolerance
        agree += int(np.count_nonzero(~hit_seen & ~hit_cast)) + int(np.count_nonzero(near))
        total += len(seen)
    return agree / total if total else 0.0


def _distinct_best(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, ll: np.ndarray, count: int,
                   params: GlobalSearchParams) -> list[int]:
    """Indices of up to ``count`` poses, best first, no two within the separation of each other."""
    chosen: list[int] = []
    for i in np.argsort(-ll)[: max(count * 400, 2000)]:
        if all(math.hypot(x[i] - x[j], y[i] - y[j]) > params.separation
               or abs(wrap_angle(float(yaw[i] - yaw[j]))) > params.separation_yaw for j in chosen):
            chosen.append(int(i))
            if len(chosen) == count:
                break
    return chosen


def refine(pf: ParticleFilter, views: Sequence[ScanView], odom_now: Pose2D, pose: Pose2D, params: GlobalSearchParams,
           likelihood: float | None = None) -> tuple[Pose2D, float]:
    """``pose`` moved to where the views fit best nearby, and its summed log-likelihood: rounds of random samples
    around the best so far, their spread halving each round."""
    p, rng = params, pf.rng
    best = pose
    best_ll = likelihood if likelihood is not None else float(ring_log_likelihood(
        pf, views, odom_now, np.array([pose.x]), np.array([pose.y]), np.array([pose.yaw]))[0])
    for r in range(p.refine_rounds):
        sxy, syaw = p.refine_xy / 2 ** r, p.refine_yaw / 2 ** r
        n = p.refine_samples
        sx = best.x + rng.normal(0.0, sxy, n)
        sy = best.y + rng.normal(0.0, sxy, n)
        syw = best.yaw + rng.normal(0.0, syaw, n)
        sll = ring_log_likelihood(pf, views, odom_now, sx, sy, syw)
        k = int(sll.argmax())
        if sll[k] > best_ll:
            best, best_ll = Pose2D(float(sx[k]), float(sy[k]), wrap_angle(float(syw[k]))), float(sll[k])
    return best, best_ll


def search(pf: ParticleFilter, views: Sequence[ScanView], odom_now: Pose2D, laser: LaserParams,
           params: GlobalSearchParams | None = None) -> list[Hypothesis]:
    """The distinct poses of the robot now that best explain the ring of ``views``, most agreeing first."""
    p = params or GlobalSearchParams()
    x, y, yaw = pf.free_space_poses(seed_count(pf, p), SEED_CLEARANCE)
    if len(x) > 2 * COARSE_KEEP:  # a large map: a thinned ring first, the whole ring for the best only
        coarse = scores(pf, coarse_ring(views, laser), odom_now, x, y, yaw)
        best = np.argpartition(-coarse, COARSE_KEEP)[:COARSE_KEEP]
        x, y, yaw = x[best], y[best], yaw[best]
    ll = scores(pf, views, odom_now, x, y, yaw)
    refined = [refine(pf, views, odom_now, Pose2D(float(x[i]), float(y[i]), float(yaw[i])), p, float(ll[i]))
               for i in _distinct_best(x, y, yaw, ll, p.hypotheses, p)]
    hypotheses: list[Hypothesis] = []
    for pose, likelihood in sorted(refined, key=lambda h: -h[1]):
        h = Hypothesis(pose, likelihood, agreement(pf, views, odom_now, pose, laser, p.range_tolerance))
        if all(h.distinct_from(other, p) for other in hypotheses):  # two seeds refined onto the same pose are one
            hypotheses.append(h)
    hypotheses.sort(key=lambda h: -h.agreement)
    log.debug("global search: %s", "; ".join(h.describe() for h in hypotheses))
    return hypotheses


def same_view(a: Hypothesis, b: Hypothesis) -> str:
    """The sentence for two places the map cannot tell apart."""
    return (f"the map looks the same from ({a.pose.x:.2f}, {a.pose.y:.2f}, {a.pose.yaw:.2f}) and from "
            f"({b.pose.x:.2f}, {b.pose.y:.2f}, {b.pose.yaw:.2f}) ({a.agreement:.0%} and {b.agreement:.0%} of a full "
            f"turn's beams agree)")


def ambiguity(hypotheses: Sequence[Hypothesis], params: GlobalSearchParams) -> Hypothesis | None:
    """The runner-up that explains the views about as well as the best (both acceptable): the map cannot tell
    the two apart. None when the best stands out."""
    if len(hypotheses) < 2:
        return None
    best, second = hypotheses[0], hypotheses[1]
    if second.agreement >= params.accept and best.agreement - second.agreement < params.ambiguity_margin:
        return second
    return None


def along_a_line(hypotheses: Sequence[Hypothesis], params: GlobalSearchParams) -> str:
    """The reason when the equally good hypotheses (acceptable, within ``ambiguity_margin`` of the best) are three
    or more places strung along one line: a corridor that looks the same all along. "" otherwise (no ambiguity,
    or places that are not on a line).

    The places must share a heading up to a half turn. Those facing one way must lie within ``line_tolerance`` m
    of a line, and those facing the other way within it of a parallel one: a bare corridor also looks the same
    turned half round about its centre line, which puts the robot's mirror image on the line across from it."""
    if not hypotheses:
        return ""
    best = max(h.agreement for h in hypotheses)
    equal = [h for h in hypotheses if h.agreement >= params.accept and h.agreement >= best - params.ambiguity_margin]
    if len(equal) < 3:
        return ""
    yaw0 = equal[0].pose.yaw
    if any(abs(wrap_angle(2.0 * (h.pose.yaw - yaw0))) / 2.0 > params.separation_yaw for h in equal):
        return ""  # headed different ways, not just the two ways along a line
    facing = np.array([abs(wrap_angle(h.pose.yaw - yaw0)) <= math.pi / 2 for h in equal])
    xy = np.array([(h.pose.x, h.pose.y) for h in equal])
    centred = xy.copy()
    for group in (facing, ~facing):
        if group.any():
            centred[group] -= xy[group].mean(axis=0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]  # the line the places of each heading follow
    if np.abs(centred @ np.array([-direction[1], direction[0]])).max() > params.line_tolerance:
        return ""
    along = xy @ direction
    a, b = sorted((xy[int(along.argmin())], xy[int(along.argmax())]), key=lambda q: (q[0], q[1]))
    low, high = min(h.agreement for h in equal), max(h.agreement for h in equal)
    mirror = " (and on its mirror image across the corridor, facing the other way)" if not facing.all() else ""
    return (f"cannot tell where along the corridor: the {len(equal)} best places found lie along one line from "
            f"({a[0]:.2f}, {a[1]:.2f}) to ({b[0]:.2f}, {b[1]:.2f}){mirror} and explain a full turn of scans equally "
            f"well ({low:.0%} to {high:.0%} of beams agree); the walls look the same all along within the laser's "
            "reach")


def second_opinion(pf: ParticleFilter, views: Sequence[ScanView], odom_now: Pose2D, laser: LaserParams, pose: Pose2D,
                   params: GlobalSearchParams | None = None) -> str:
    """Why ``pose`` (the robot now) should not be trusted on the evidence of ``views``, or "" when it should.

    The filter's own test looks at one narrow scan at a time from where it believes the robot is; a cloud that
    slid onto a place which looks alike from most headings passes it. Here the pose, refined on the views first
    (the filter's estimate jitters by a few centimetres, which near a wall moves many beams past the range
    tolerance), must explain the views as a whole (``accept`` of their beams agree with the map), and no
    distinct place may explain them about as well (the map cannot tell the two apart) or better (the filter
    settled on the wrong one).
    """
    p = params or GlobalSearchParams()
    pose = refine(pf, views, odom_now, pose, p)[0]  # the filter's estimate jitters by a few centimetres
    own = agreement(pf, views, odom_now, pose, laser, p.range_tolerance)
    if own < p.accept:
        return f"only {own:.0%} of the last turn's beams agree with the map from there (< {p.accept:.0%})"
    mine = Hypothesis(pose, 0.0, own)
    others = [h for h in search(pf, views, odom_now, laser, p) if h.distinct_from(mine, p)]
    for other in others:
        if other.agreement < own - p.ambiguity_margin:
            continue
        if other.agreement > own + p.ambiguity_margin:
            return f"{other.describe()} explains the last turn better than {mine.describe()}"
        return along_a_line([mine, *others], p) or same_view(mine, other)
    return ""
