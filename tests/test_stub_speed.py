"""What the maximal step's shortcuts (issue 19, speed) take for granted, checked on this machine:
they may change how fast a step is, never a bit of what it computes.

- ``Robot.hold``: pybullet gives back exactly what the step wrote into it (centre, velocities,
  hinge angles and rates; its motors, never stepped, report no torque), so the sensors and the
  next step read the held numbers instead of asking pybullet;
- ``ode_step.prepare_maximal`` on a held robot equals the same preparation from pybullet's state;
- ``ode_maximal._mat_mul3`` is numba's ``@`` (OpenBLAS's dgemm) to the last bit.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet as pb
from numba import njit

from server_stub.config import PhysicsConfig
from server_stub.physics import calibration_walk, ode_maximal, ode_step
from server_stub.physics.world import World

MAX = dataclasses.replace(PhysicsConfig(), backend="ode", ode_maximal=True, ode_contacts=True)


def _walking_robot(world: World, cycles: int):
    """A robot walking the calibration gait, stepped ``cycles`` times; yields after each step."""
    robot = world.add_robot()
    robot.beam(-3.0, 0.0, 0.0)
    for cycle in range(cycles):
        calibration_walk._act(robot, cycle * 0.02)
        world.step()
        yield robot


def test_a_held_robot_reads_what_pybullet_gives_back() -> None:
    with World(MAX) as world:
        for robot in _walking_robot(world, 150):
            assert robot.held
            angles, rates, torques = robot._joint_state()
            velocity, spin = robot._base_motion()
            states = pb.getJointStates(robot.body_id, list(range(22)), physicsClientId=world._client)
            assert angles.tolist() == [s[0] for s in states]
            assert rates.tolist() == [s[1] for s in states]
            assert torques.tolist() == [s[3] for s in states] == [0.0] * 22
            assert (velocity, spin) == pb.getBaseVelocity(robot.body_id, physicsClientId=world._client)


def test_preparing_a_held_robot_equals_preparing_it_from_pybullet() -> None:
    with World(MAX) as world:
        for robot in _walking_robot(world, 100):
            static = ode_step.static_of(robot, world._ground, MAX)
            held = ode_step.prepare_maximal(robot, static, MAX)
            robot.held = False  # as if pybullet had been written by someone else
            read = ode_step.prepare_maximal(robot, static, MAX)
            robot.held = True
            assert read.bodies is held.bodies
            for a, b in zip(held[1:], read[1:]):
                assert np.array_equal(a, b)


@njit
def _mismatches(a: np.ndarray, b: np.ndarray) -> int:
    bad = 0
    for t in range(a.shape[0]):
        if not np.array_equal(a[t] @ b[t], ode_maximal._mat_mul3(a[t], b[t])):
            bad += 1
    return bad


def test_the_fused_product_is_numbas_matrix_product() -> None:
    rng = np.random.default_rng(3)
    n = 20_000
    a = rng.normal(size=(n, 3, 3)) * 10.0 ** rng.integers(-6, 3, size=(n, 1, 1))
    b = rng.normal(size=(n, 3, 3)) * 10.0 ** rng.integers(-2, 6, size=(n, 1, 1))
    assert _mismatches(a, b) == 0
