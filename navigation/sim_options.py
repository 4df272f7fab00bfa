"""The simulator's command-line options, declared once for every command that runs it.

objrec-patrol and objrec-inspect drive the same :class:`~navigation.simulation.Simulation`; a user who
learns ``--dt`` or ``--localization amcl`` on one finds it, with the same range, default and meaning, on the
other. Each command adds :func:`add_simulation_options` to its parser and turns the parsed values into its
:class:`~navigation.simulation.SimConfig` with :func:`simulation_config`.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from strictio.cli_numbers import Number

from .localization import LOCALIZATION_MODES
from .simulation import SimConfig

# A time step below 10 ms buys nothing and multiplies the steps; above 0.5 s the follower and the dock overshoot.
SEED = Number(0, 2**32 - 1, whole=True)
ODOM_NOISE = Number(0, 1)  # a fraction of each step's motion
TIME_STEP = Number(0.01, 0.5)  # seconds
MARGIN = Number(0, 2)  # metres


def add_simulation_options(parser: argparse.ArgumentParser) -> argparse._ArgumentGroup:
    """The ``simulation`` group: seed, odometry noise, localization, time step, real time, planning margin."""
    sim = parser.add_argument_group("simulation")
    sim.add_argument("--seed", type=SEED, default=0,
                     help=f"random seed for sensor noise (default 0; {SEED.describe()})")
    sim.add_argument("--odom-noise", type=ODOM_NOISE, default=0.0, metavar="FRACTION",
                     help=f"relative odometry noise per step, e.g. 0.05 (default 0; {ODOM_NOISE.describe()})")
    sim.add_argument("--localization", choices=LOCALIZATION_MODES, default="exact",
                     help="pose the robot drives on and places what it sees with: exact (the true pose, default), "
                          "amcl (a particle filter matching laser scans to the map), odometry (dead reckoning "
                          "alone)")
    sim.add_argument("--dt", type=TIME_STEP, default=0.1, metavar="SECONDS",
                     help=f"time step (default 0.1; {TIME_STEP.describe()})")
    sim.add_argument("--realtime", action="store_true", help="run at wall-clock speed instead of flat out")
    sim.add_argument("--margin", type=MARGIN, metavar="METRES",  # None: the parameters file or 0.10 decides
                     help=f"obstacle inflation beyond the robot radius for planning (default 0.10; "
                          f"{MARGIN.describe()})")
    return sim


def simulation_config(args: argparse.Namespace, base: SimConfig | None = None) -> SimConfig:
    """``base`` (the defaults) with the simulation options of ``args``; noise applies to both odometry axes."""
    base = base or SimConfig()
    margin = base.inflation_margin if args.margin is None else args.margin
    return replace(base, dt=args.dt, seed=args.seed, inflation_margin=margin,
                   odom_linear_noise=args.odom_noise, odom_angular_noise=args.odom_noise,
                   localization=args.localization)
