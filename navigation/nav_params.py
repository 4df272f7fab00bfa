"""The navigation parameters file: inflation, controller settings and costmap filters, as a Nav2 user tunes them.

Nav2 keeps a robot's tuning in one parameters file; here it is a small YAML with three sections, every key
declared (an unknown key, a value out of range or a missing mask file is one line naming file, line, key and
value). The command line overrides the file, the file overrides the defaults::

    planner:
      inflation_margin: 0.10      # m of lethal inflation beyond the robot's radius
      cost_scaling_factor: 6.67   # 1/m, Nav2's name: how fast the cost beyond the lethal zone decays
    controller:
      max_speed: 0.4              # m/s, at most the base's 0.5
      acceleration: 0.8           # m/s^2 the controller plans its braking with, at most the base's 1.0
      lookahead: 0.35             # m, pure pursuit's carrot distance
    filters:
      keepout_mask: keepout.yaml  # a map_server YAML + image, relative to this file
      speed_mask: speed.yaml
      speed_limit: {type: percent, base: 100, multiplier: -1}

See :mod:`navigation.costmap_filters` for what the masks mean.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from declare import Choice, Float
from declare.fields import FilePath, Record, Value, read_document
from strictio import YAMLLimits
from strictio.cli_numbers import Number

from .costmap_filters import (
    SPEED_LIMIT_TYPES,
    SpeedLimitInfo,
    SpeedZones,
    load_keepout,
    load_speed_zones,
    zone_overlay,
)
from .follower import FollowerParams
from .maps import OccupancyMap
from .planner import Planner, PlannerParams
from .robot import RobotParams
from .simulation import SimConfig

#: A parameters file is a few dozen lines; 64 KiB leaves room for comments, never for a bomb.
NAV_PARAMS_LIMITS = YAMLLimits(max_bytes=64 * 1024, max_depth=8)
_BASE = RobotParams()
_PLANNER = PlannerParams()
_FOLLOWER = FollowerParams()
MAX_MARGIN = 2.0
MAX_COST_SCALING = 100.0


def _unset(declaration: Any) -> Value:
    """A declared value whose absence means "not set here" (None), so the command line and defaults decide."""
    return Value(declaration, default=None)


PLANNER_FIELDS = Record({
    "inflation_margin": _unset(Float(_PLANNER.inflation_margin, "metres of lethal inflation beyond the robot radius",
                                     min=0.0, max=MAX_MARGIN)),
    "cost_scaling_factor": _unset(Float(1.0 / _PLANNER.cost_decay, "1/m: decay of the cost beyond the lethal zone",
                                        min=0.0, min_open=True, max=MAX_COST_SCALING)),
})
CONTROLLER_FIELDS = Record({
    "max_speed": _unset(Float(_FOLLOWER.max_linear, "m/s, at most the base's maximum", min=0.0, min_open=True,
                              max=_BASE.max_linear)),
    "acceleration": _unset(Float(_FOLLOWER.linear_accel, "m/s^2 the controller brakes with, at most the base's",
                                 min=0.0, min_open=True, max=_BASE.linear_accel)),
    "lookahead": _unset(Float(_FOLLOWER.lookahead, "metres, pure pursuit's carrot distance", min=0.05, max=2.0)),
})
SPEED_LIMIT_FIELDS = Record({
    "type": Value(Choice("percent", SPEED_LIMIT_TYPES, "Nav2 filter type 1 (percent) or 2 (absolute, m/s)")),
    "base": Value(Float(100.0, "limit for mask value 0", min=-1e4, max=1e4)),
    "multiplier": Value(Float(-1.0, "change of the limit per unit of mask value", min=-1e4, max=1e4)),
})
FILTER_FIELDS = Record({
    "keepout_mask": FilePath(doc="keepout mask, a map_server YAML"),
    "speed_mask": FilePath(doc="speed mask, a map_server YAML"),
    "speed_limit": SPEED_LIMIT_FIELDS,
})
NAV_PARAMS_FIELDS = Record({"planner": PLANNER_FIELDS, "controller": CONTROLLER_FIELDS, "filters": FILTER_FIELDS},
                           null_is_empty=True)


@dataclass(frozen=True)
class NavParams:
    """Settings from the file and the command line; None: not set (the defaults apply)."""

    inflation_margin: float | None = None
    cost_scaling_factor: float | None = None
    max_speed: float | None = None
    acceleration: float | None = None
    lookahead: float | None = None
    keepout_mask: Path | None = None
    speed_mask: Path | None = None
    speed_limit: SpeedLimitInfo = field(default_factory=SpeedLimitInfo)

    def planner_params(self, base: PlannerParams, keepout: Any = None) -> PlannerParams:
        """``base`` with the inflation and cost shape set here, and ``keepout`` cells."""
        out = base
        if self.inflation_margin is not None:
            out = replace(out, inflation_margin=self.inflation_margin)
        if self.cost_scaling_factor is not None:
            out = replace(out, cost_decay=1.0 / self.cost_scaling_factor)
        return replace(out, keepout=keepout) if keepout is not None else out

    def follower_params(self, base: FollowerParams) -> FollowerParams:
        """``base`` with the controller settings set here."""
        changes = {name: value for name, value in (("max_linear", self.max_speed), ("linear_accel", self.acceleration),
                                                   ("lookahead", self.lookahead)) if value is not None}
        return replace(base, **changes) if changes else base

    @property
    def changes_planner(self) -> bool:
        """Whether the planner differs from the one the simulation builds from its config alone."""
        return self.cost_scaling_factor is not None or self.keepout_mask is not None

    def keepout(self, occ_map: OccupancyMap) -> Any:
        return load_keepout(self.keepout_mask, occ_map) if self.keepout_mask is not None else None

    def speed_zones(self, occ_map: OccupancyMap, follower: FollowerParams) -> SpeedZones | None:
        if self.speed_mask is None:
            return None
        return load_speed_zones(self.speed_mask, occ_map, self.speed_limit, follower.max_linear, follower.linear_accel)


def read_nav_params(path: str | Path) -> NavParams:
    """Read and validate a parameters file; every refusal is one DocumentError (file:line: key: value: rule)."""
    document = read_document(path, NAV_PARAMS_LIMITS, "navigation parameters")
    raw = NAV_PARAMS_FIELDS.read(document.data, document.root)
    planner, controller, filters = raw["planner"], raw["controller"], raw["filters"]
    speed = filters["speed_limit"]
    return NavParams(
        inflation_margin=planner["inflation_margin"], cost_scaling_factor=planner["cost_scaling_factor"],
        max_speed=controller["max_speed"], acceleration=controller["acceleration"],
        lookahead=controller["lookahead"], keepout_mask=filters["keepout_mask"], speed_mask=filters["speed_mask"],
        speed_limit=SpeedLimitInfo(speed["type"], speed["base"], speed["multiplier"]))


# -- command line -------------------------------------------------------------------------------------------
COST_SCALING = Number(0, MAX_COST_SCALING, above=True)


def add_nav_params_options(parser: argparse.ArgumentParser) -> argparse._ArgumentGroup:
    """The ``navigation parameters`` group: the file, and the options that override it."""
    group = parser.add_argument_group(
        "navigation parameters", "Nav2-style tuning (see docs/navigation.md); these options override the file.")
    group.add_argument("--nav-params", metavar="YAML",
                       help="parameters file: planner (inflation_margin, cost_scaling_factor), controller "
                            "(max_speed, acceleration, lookahead), filters (keepout_mask, speed_mask, speed_limit)")
    group.add_argument("--cost-scaling-factor", type=COST_SCALING, metavar="PER_METRE",
                       help=f"how fast the cost beyond the lethal zone decays, as Nav2's inflation layer "
                            f"(default {1.0 / _PLANNER.cost_decay:.2f}; {COST_SCALING.describe()})")
    group.add_argument("--keepout-mask", metavar="MASK_YAML",
                       help="Nav2 keepout mask (map_server YAML + image): occupied cells are never planned through")
    group.add_argument("--speed-mask", metavar="MASK_YAML",
                       help="Nav2 speed mask (map_server YAML + image): percent of the maximum speed, "
                            "base 100 - mask value, unless the parameters file says otherwise")
    return group


def nav_params_inputs(args: argparse.Namespace) -> list[tuple[str, str]]:
    """The files the navigation options name, each with how an error names it: a command's outputs must never
    replace them (:class:`strictio.output_paths.RunFiles`)."""
    return [(getattr(args, option), f"the file of --{option.replace('_', '-')}")
            for option in ("nav_params", "keepout_mask", "speed_mask") if getattr(args, option)]


def nav_params_from_args(args: argparse.Namespace) -> NavParams:
    """The parameters file (if any) with the command line's options laid over it."""
    params = read_nav_params(args.nav_params) if args.nav_params else NavParams()
    changes: dict[str, Any] = {}
    if getattr(args, "margin", None) is not None:
        changes["inflation_margin"] = args.margin
    if args.cost_scaling_factor is not None:
        changes["cost_scaling_factor"] = args.cost_scaling_factor
    if args.keepout_mask:
        changes["keepout_mask"] = Path(args.keepout_mask)
    if args.speed_mask:
        changes["speed_mask"] = Path(args.speed_mask)
    return replace(params, **changes) if changes else params


def configure_simulation(config: SimConfig, params: NavParams, occ_map: OccupancyMap) -> SimConfig:
    """``config`` with what ``params`` set before the simulation is built: the inflation margin, the controller
    settings and the planner's cost shape and keepout cells (the mask read here, once), so the simulation builds
    its planner once. The speed zones act on a built simulation: :func:`apply_to_simulation`."""
    margin = config.inflation_margin if params.inflation_margin is None else params.inflation_margin
    config = replace(config, inflation_margin=margin, follower=params.follower_params(config.follower))
    if params.changes_planner or config.planner is not None:
        config = replace(config, planner=params.planner_params(config.planner_params(), params.keepout(occ_map)))
    return config


def apply_to_simulation(sim: Any, params: NavParams) -> np.ndarray | None:
    """Give a built :class:`~navigation.simulation.Simulation` the speed zones of ``params``, and the planner (keepout,
    cost shape) when its config did not already carry it (:func:`configure_simulation` does, and then no second
    planner is built); returns the zones' picture layer for :class:`~navigation.render.RunPicture` (None: no
    zones)."""
    wanted = params.planner_params(sim.planner.params)
    keepout = sim.planner.params.keepout  # the map's cells (the planner's own copy is padded)
    if params.keepout_mask is not None and keepout is None:
        keepout = params.keepout(sim.map)
    if wanted != sim.planner.params or keepout is not sim.planner.params.keepout:  # set after the simulation: rebuilt
        planner = Planner(sim.planner.field, replace(wanted, keepout=keepout))
        sim.planner = planner
        sim.move_base.planner = planner
    follower = sim.config.follower
    zones = params.speed_zones(sim.map, follower)
    if zones is not None:
        sim.move_base.speed_limit = zones.cap
    return zone_overlay(keepout if params.keepout_mask is not None else None,
                        None if zones is None else zones.limits, follower.max_linear)


def in_keepout(planner: Planner, pose: Any) -> bool:
    """Whether a goal lies in a keepout cell of ``planner`` (so the patrol can warn before it drives)."""
    if planner.keepout is None:
        return False
    i, j = planner.field.cell(pose.x, pose.y)
    return planner.field.inside(i, j) and bool(planner.keepout[j, i])
