"""What the step's speed shortcuts take for granted, checked on this machine:
they may change how fast a step is, never a bit of what it computes.

- ``Robot.hold``: pybullet gives back exactly what the step wrote into it (centre, velocities,
  hinge angles and rates), so the sensors and the
  next step read the held numbers instead of asking pybullet;
- ``Robot.keep_unwritten``: a lone walker's state is written into pybullet only when pybullet is
  asked (``Robot.sync``), its orientation read as pybullet rebuilds it (``rotations.read_back``,
  ``rotations.stored_matrix``: pybullet's own numbers, to the last bit);
- ``linalg.mat_mul3`` is numba's ``@`` (OpenBLAS's dgemm) to the last bit.
"""

from __future__ import annotations

import numpy as np
import pybullet as pb
from numba import njit

from server_stub.config import PhysicsConfig
from server_stub.physics import calibration_walk, rotations
from server_stub.physics.linalg import mat_mul3
from server_stub.physics.world import World

MAX = PhysicsConfig()


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
            assert robot.held and robot.pending_write  # alone on the field: nothing written yet
            angles, rates = robot.joint_state()
            velocity, spin = robot.stored_motion()
            position, orientation = robot.stored_pose()
            rotation = tuple(robot.torso_rotation().ravel().tolist())
            robot.sync()
            assert (position, orientation) == pb.getBasePositionAndOrientation(
                robot.body_id, physicsClientId=world._client
            )
            assert rotation == pb.getMatrixFromQuaternion(orientation)
            states = pb.getJointStates(robot.body_id, list(range(22)), physicsClientId=world._client)
            assert angles.tolist() == [s[0] for s in states]
            assert rates.tolist() == [s[1] for s in states]
            assert (velocity, spin) == pb.getBaseVelocity(robot.body_id, physicsClientId=world._client)


def test_an_orientation_reads_back_as_pybullet_rebuilds_it() -> None:
    rng = np.random.default_rng(11)
    turns = rng.normal(size=(5000, 4))
    turns /= np.linalg.norm(turns, axis=1, keepdims=True)
    axes = [(0.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)]
    with World(MAX) as world:
        body, client = world.add_robot().body_id, world._client
        for q in [tuple(t) for t in turns.tolist()] + axes:
            pb.resetBasePositionAndOrientation(body, (0.5, -1.0, 0.3), q, physicsClientId=client)
            back = pb.getBasePositionAndOrientation(body, physicsClientId=client)[1]
            assert rotations.read_back(q) == back
            assert rotations.stored_matrix(back) == pb.getMatrixFromQuaternion(back)


def test_only_things_far_apart_skip_bullets_collision_pass(monkeypatch) -> None:
    """A ball touching a walker's foot is found by Bullet (the robot written first) and pushed away;
    a ball across the field is not looked for, and the walker is not written."""
    passes = []
    real_pass = pb.performCollisionDetection
    monkeypatch.setattr(pb, "performCollisionDetection", lambda **kw: passes.append(1) or real_pass(**kw))
    with World(MAX) as world:
        robot = world.add_robot()
        robot.beam(-3.0, 0.0, 0.0)
        for _ in range(20):  # settle
            world.step()
        foot = robot.part_positions(["lfoot"])["lfoot"]
        world.set_ball((foot[0] + 0.1, foot[1], 0.042))  # overlapping the foot's front
        passes.clear()
        for _ in range(5):
            world.step()
        assert len(passes) == 5
        assert world.ball_position()[0] > foot[0] + 0.1 + 0.001  # pushed out of the foot
        world.set_ball((5.0, 5.0, 0.042))
        passes.clear()
        for _ in range(5):
            world.step()
        assert passes == [] and robot.pending_write


@njit
def _mismatches(a: np.ndarray, b: np.ndarray) -> int:
    bad = 0
    for t in range(a.shape[0]):
        if not np.array_equal(a[t] @ b[t], mat_mul3(a[t], b[t])):
            bad += 1
    return bad


def test_the_fused_product_is_numbas_matrix_product() -> None:
    rng = np.random.default_rng(3)
    n = 20_000
    a = rng.normal(size=(n, 3, 3)) * 10.0 ** rng.integers(-6, 3, size=(n, 1, 1))
    b = rng.normal(size=(n, 3, 3)) * 10.0 ** rng.integers(-2, 6, size=(n, 1, 1))
    assert _mismatches(a, b) == 0
