"""Robots as lanes (``server_stub.physics.lanes``): each lone robot a row of its type's arrays, all
of a type stepped in one call, each exactly as it would step alone."""

from __future__ import annotations

import numpy as np

from protocol.nao import joints_of
from server_stub.physics.lanes import LaneGroup
from server_stub.physics.robot import Robot
from server_stub.physics.world import World

#: Where each robot of the field stands (far apart: never touching), and its type.
_SPOTS = ((-10.0, 4.0, 0.0, 0), (-2.0, -5.0, 90.0, 4), (6.0, 3.0, 200.0, 1), (11.0, -6.0, -45.0, 0))


def _drive(robot: Robot, rng: np.random.Generator) -> None:
    for joint, speed in zip(joints_of(robot.robot_type), rng.normal(size=len(joints_of(robot.robot_type))) * 4.0):
        robot.command(joint.effector, float(speed))


def _trace(robot: Robot) -> bytes:
    """Everything a robot's step leaves, as bits."""
    angles, rates = robot.joint_state()
    position, orientation = robot.stored_pose()
    velocity, spin = robot.stored_motion()
    feet = robot.foot_pressure()
    numbers = [*position, *orientation, *velocity, *spin, *robot.gyro(), *robot.accelerometer()]
    numbers += [x for key in sorted(feet) for pair in feet[key] for x in pair]
    return angles.tobytes() + rates.tobytes() + np.array(numbers).tobytes()


def _walk(spots, steps: int, seed: int) -> list[list[bytes]]:
    """Robots at ``spots`` in one world, driven at random speeds (each robot its own draws): each
    robot's trace after every step."""
    with World() as world:
        robots = [world.add_robot(kind) for *_, kind in spots]
        for robot, (x, y, heading, _) in zip(robots, spots):
            robot.beam(x, y, heading)
        rngs = [np.random.default_rng([seed, round(x) + 100, round(y) + 100]) for x, y, *_ in spots]
        traces: list[list[bytes]] = [[] for _ in robots]
        for step in range(steps):
            if step % 8 == 0:
                for robot, rng in zip(robots, rngs):
                    _drive(robot, rng)
            world.step()
            for robot, trace in zip(robots, traces):
                trace.append(_trace(robot))
        return traces


def test_each_lane_of_a_field_steps_as_its_robot_alone():
    """Four robots of three types far apart on one field (three lanes of type 0 and 1 besides one
    of type 4 with toes: three groups, one call each a cycle) leave, at every step, the very bits
    each leaves alone on its own field: falling, landing, flailing."""
    together = _walk(_SPOTS, 90, seed=3)
    for spot, trace in zip(_SPOTS, together):
        alone = _walk((spot,), 90, seed=3)[0]
        assert alone == trace


def _stood(world: World, robot: Robot, steps: int) -> list[bytes]:
    """``robot`` beamed to (-5, 0) facing +x, then its trace after each of ``steps`` steps."""
    robot.beam(-5.0, 0.0, 0.0)
    traces = []
    for _ in range(steps):
        world.step()
        traces.append(_trace(robot))
    return traces


def test_a_robot_that_leaves_frees_its_lane_for_the_next():
    """A robot taken off the field gives its row back; the next robot of its type takes it, and
    walks as a robot on a fresh field does."""
    with World() as world:
        first = world.add_robot()
        _stood(world, first, 1)
        row = world.physics_of(first).row
        world.remove_robot(first)
        second = world.add_robot()
        traces = _stood(world, second, 30)
        assert world.physics_of(second).row == row
    with World() as world:
        alone = _stood(world, world.add_robot(), 30)
    assert traces == alone


def test_a_group_grows_keeping_its_rows_and_hands_freed_rows_out_again():
    with World() as world:
        robot = world.add_robot()
        world.step()
        physics = world.physics_of(robot)
        model = physics.model
        assert model is not None
        group = LaneGroup(model.lane_model, 4)
        rows = [group.add() for _ in range(5)]
        assert rows == [0, 1, 2, 3, 4]
        assert group.capacity >= 5
        group.pos[3] = 7.0
        group.motor_state[3] = 1
        group.add()
        group.add()
        group.add()  # grows again
        assert (group.pos[3] == 7.0).all() and (group.motor_state[3] == 1).all()
        group.remove(3)
        assert group.add() == 3
        assert (group.motor_state[3] == 0).all()  # the motor rows' state starts afresh
        assert group.matches(model.lane_model)
        other = world.add_robot(4)
        world.step()
        other_model = world.physics_of(other).model
        assert other_model is not None
        assert not group.matches(other_model.lane_model)
