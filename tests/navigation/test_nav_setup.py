"""Setting a run up: the planner is built once, with the keepout cells and cost shape of the navigation parameters,
and a refused start pose names the file that puts something there (the map, or the world and its objects)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import navigation
from navigation.cli import main
from navigation.geometry import Pose2D
from navigation.maps import load_map
from navigation.nav_params import NavParams, apply_to_simulation, configure_simulation
from navigation.planner import Planner
from navigation.simulation import SimConfig, Simulation, StartPoseError
from navigation.world import World, WorldObject

DATA = Path(navigation.__file__).parent / "data"
POSES, MAP = str(DATA / "b5203.txt"), str(DATA / "b5203.yaml")


@pytest.fixture
def planners_built(monkeypatch) -> list[Planner]:
    built: list[Planner] = []
    init = Planner.__init__

    def counted(self, *args, **kwargs):
        built.append(self)
        init(self, *args, **kwargs)

    monkeypatch.setattr(Planner, "__init__", counted)
    return built


@pytest.mark.parametrize("options", [
    [], ["--nav-params", str(DATA / "b5203_nav.yaml")],
    ["--keepout-mask", str(DATA / "b5203_keepout.yaml"), "--cost-scaling-factor", "4"]])
def test_objrec_patrol_builds_its_planner_once(planners_built, capsys, options):
    assert main([POSES, "--map", MAP, "--time-limit", "5", *options]) == 0
    assert len(planners_built) == 1
    planner = planners_built[0]
    assert (planner.params.keepout is not None) == bool(options)
    if "--cost-scaling-factor" in options:
        assert planner.params.cost_decay == pytest.approx(0.25)


def test_configured_simulation_needs_no_second_planner(planners_built):
    occ_map = load_map(MAP)
    params = NavParams(keepout_mask=DATA / "b5203_keepout.yaml", inflation_margin=0.12, cost_scaling_factor=5.0)
    config = configure_simulation(SimConfig(), params, occ_map)
    assert config.inflation_margin == 0.12 and config.planner is not None
    sim = Simulation(occ_map, Pose2D(14.4, 12.8, 0.0), config)
    keepout = sim.planner.params.keepout
    assert keepout is not None and keepout.shape == occ_map.data.shape and keepout.any()
    assert (sim.planner.params.inflation_margin, sim.planner.params.cost_decay) == (0.12, pytest.approx(0.2))
    assert apply_to_simulation(sim, params) is not None  # the zones' layer, for the picture
    assert len(planners_built) == 1 and sim.move_base.planner is sim.planner
    # A simulation built without them still gets them, with a second planner (library use, as before).
    plain = Simulation(occ_map, Pose2D(14.4, 12.8, 0.0), replace(SimConfig(), inflation_margin=0.12))
    apply_to_simulation(plain, params)
    assert len(planners_built) == 3 and plain.planner.params.keepout is not None
    assert np.array_equal(plain.planner.params.keepout, keepout)


def test_a_start_in_the_map_names_the_map_file():
    with pytest.raises(StartPoseError) as refused:
        Simulation(load_map(MAP), Pose2D(12.7, 12.2, 0.0))  # inside the central table
    assert str(refused.value) == (f"{MAP}: start pose (12.700, 12.200) puts the robot (radius 0.18 m) off the map or "
                                  "inside an obstacle")


def test_a_start_in_an_object_names_the_world_and_the_object(tmp_path):
    world = World((WorldObject("can", "cylinder", 14.4, 12.8, radius=0.3, height=1.0),), source=tmp_path / "w.yaml")
    with pytest.raises(StartPoseError, match=r"w\.yaml: start pose \(14\.400, 12\.800\) puts the robot \(radius "
                                             r"0\.18 m\) inside an obstacle of the world: 'can'$"):
        Simulation(load_map(MAP), Pose2D(14.4, 12.8, 0.0), world=world)


def test_the_command_names_the_map_file(capsys):
    assert main([POSES, "--map", MAP, "--start", "12.7", "12.2", "0"]) == 2
    err = capsys.readouterr().err
    assert err == f"objrec-patrol: error: {MAP}: start pose (12.700, 12.200) puts the robot (radius 0.18 m) off the " \
                  "map or inside an obstacle\n"
