"""Fixtures for the navigation tests: the shipped B5.2.03 map and poses, and a simulation factory."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import navigation
from navigation.docking import DockingStation
from navigation.geometry import Pose2D
from navigation.maps import OccupancyMap, load_map
from navigation.patrol import PatrolMachine
from navigation.poses import PoseFile, load_poses
from navigation.simulation import SimConfig, Simulation

DATA = Path(navigation.__file__).parent / "data"
STATION = Pose2D(14.4, 12.8, 0.0)


@pytest.fixture(scope="session")
def b5203_map() -> OccupancyMap:
    return load_map(DATA / "b5203.yaml")


@pytest.fixture(scope="session")
def b5203_poses() -> PoseFile:
    return load_poses(DATA / "b5203.txt")


@pytest.fixture
def make_patrol(b5203_map: OccupancyMap) -> Callable[..., PatrolMachine]:
    """Build a patrol on the B5.2.03 map (or ``occ_map``) starting at the station pose."""

    def build(goals: list[Pose2D], station: Pose2D | None = STATION, occ_map: OccupancyMap | None = None,
              start: Pose2D = STATION, dock: DockingStation | None = None, max_laps: int | None = None,
              resume: bool = False, **config: Any) -> PatrolMachine:
        cfg = replace(SimConfig(), **config)
        if dock is None and station is not None:
            dock = DockingStation.in_front_of(station)
        sim = Simulation(occ_map or b5203_map, start, cfg, station=dock)
        return PatrolMachine(sim, goals, station, max_laps=max_laps, resume_after_charging=resume)

    return build
