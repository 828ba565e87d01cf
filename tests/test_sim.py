"""Discrete-action simulator: collisions against walls, turns, sliding, steps, conventions."""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import box_scene, room_boxes
from rvn_data.conventions import Action, AgentConfig, to_planar
from rvn_data.navmesh import NavMesh
from rvn_data.sim import Simulator

R = 0.18
WALL_X = 3.305  # threshold x = 3.125: targets 3.0 and 3.25 are half a step away from it


@pytest.fixture(scope="module")
def wall_navmesh():
    boxes = room_boxes(6.0, 4.0) + [((WALL_X, 0, 0), (WALL_X + 0.1, 2.5, 4.0))]
    return NavMesh.build(box_scene(boxes, "wall"))


def test_collision_on_exactly_the_step_that_comes_too_close(wall_navmesh):
    sim = Simulator(wall_navmesh, AgentConfig())
    sim.reset(np.array([1.0, 0.0, 2.0]), 0.0)  # yaw 0 heads +x
    expected = next(k for k in range(1, 20) if 1.0 + 0.25 * k > WALL_X - R)
    for k in range(1, expected + 3):
        before = sim.position.copy()
        res = sim.step(Action.MOVE_FORWARD)
        assert np.allclose(res.commanded, before + [0.25, 0, 0])
        if k < expected:
            assert not res.collided and res.contact is None
            assert res.displacement == pytest.approx(0.25, abs=1e-6)
        else:
            assert res.collided, f"step {k}"
            assert res.position[0] == pytest.approx(WALL_X - R, abs=2e-3)
            assert res.contact[0] == pytest.approx(WALL_X, abs=2e-3)
            assert res.contact[2] == pytest.approx(2.0, abs=2e-3)
            assert res.displacement < 0.25 - 1e-3
    assert wall_navmesh.is_navigable(sim.position)


def test_turns_never_collide(wall_navmesh):
    sim = Simulator(wall_navmesh, AgentConfig())
    sim.reset(np.array([WALL_X - R - 0.001, 0.0, 2.0]), 0.0)
    p = sim.position.copy()
    for i in range(14):
        action = Action.TURN_LEFT if i < 7 else Action.TURN_RIGHT
        yaw = sim.yaw
        res = sim.step(action)
        assert not res.collided and res.contact is None and res.displacement == 0.0
        assert np.array_equal(res.position, p)
        step = math.radians(30) * (1 if action == Action.TURN_LEFT else -1)
        assert math.isclose(math.remainder(res.yaw - yaw - step, 2 * math.pi), 0.0, abs_tol=1e-9)
    assert not sim.step(Action.STOP).collided


def test_planar_convention_and_floor_following():
    nm = NavMesh.build(box_scene(room_boxes() + [((2.0, 0, 0), (4.0, 0.15, 4.0))], "step"))
    sim = Simulator(nm, AgentConfig())
    sim.reset(np.array([1.0, 0.0, 3.0]), math.radians(30))
    q0 = to_planar(sim.position)
    res = sim.step(Action.MOVE_FORWARD)
    assert np.allclose(to_planar(res.position) - q0, 0.25 * np.array([math.cos(math.pi / 6), math.sin(math.pi / 6)]))
    sim.reset(np.array([1.0, 0.0, 2.0]), 0.0)
    for _ in range(8):  # up the 0.15 m step without a collision
        res = sim.step(Action.MOVE_FORWARD)
        assert not res.collided
    assert res.position[1] == pytest.approx(0.15, abs=0.011)


def test_sliding_moves_along_the_wall(wall_navmesh):
    start, yaw = np.array([WALL_X - R - 0.05, 0.0, 2.0]), math.radians(-40)  # towards the wall and +z
    no_slide = Simulator(wall_navmesh, AgentConfig())
    slide = Simulator(wall_navmesh, AgentConfig(allow_sliding=True))
    no_slide.reset(start, yaw)
    slide.reset(start, yaw)
    a, b = no_slide.step(Action.MOVE_FORWARD), slide.step(Action.MOVE_FORWARD)
    assert a.collided and b.collided
    assert b.displacement > a.displacement + 0.05
    assert b.position[2] > a.position[2] + 0.05
    assert b.position[0] <= WALL_X - R + 1e-3
    assert wall_navmesh.is_navigable(b.position)


def test_random_walk_stays_navigable(wall_navmesh, rng):
    sim = Simulator(wall_navmesh, AgentConfig())
    sim.reset(wall_navmesh.sample(rng), 0.0)
    for a in rng.integers(1, 4, size=300):
        res = sim.step(int(a))
        assert wall_navmesh.is_navigable(res.position)
        assert res.collided == (a == Action.MOVE_FORWARD and res.displacement < 0.25 - 1e-3)


def test_bad_reset_and_radius_mismatch(wall_navmesh):
    sim = Simulator(wall_navmesh, AgentConfig())
    with pytest.raises(ValueError, match="not near the navigable surface"):
        sim.reset(np.array([50.0, 0.0, 50.0]), 0.0)
    with pytest.raises(ValueError, match="agent_radius"):
        Simulator(wall_navmesh, AgentConfig(r_robot=0.25))
