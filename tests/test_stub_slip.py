"""The contact slip model (server_stub/physics/slip.py): its equations, checked against rigid-body
mechanics written out independently here, and the robot it keeps from exploding."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocol.nao import JOINTS
from server_stub.config import PhysicsConfig
from server_stub.physics import slip
from server_stub.physics.world import World

SLIP = PhysicsConfig().slip
H = PhysicsConfig().cycle


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _rotation(axis, angle):
    x, y, z = _unit(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


vectors = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 8), seed=st.integers(0, 2**32 - 1), mass=st.floats(0.5, 10.0), tilt=st.floats(0.0, 0.5))
def test_slip_forces_leave_each_point_sliding_at_slip_times_its_force(n, seed, mass, tilt):
    """Newton-Euler over one step with only the slip forces: the points' new tangential
    velocities are -slip x force (ODE's force-dependent slip), and no force has a normal part."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(-0.2, 0.2, (n, 3))
    normals = np.array([_unit([tilt * rng.normal(), tilt * rng.normal(), 1.0]) for _ in range(n)])
    velocities = rng.normal(0.0, 0.3, (n, 3))
    com = np.array([0.0, 0.0, 0.3])
    r = _rotation(rng.normal(size=3), rng.uniform(0, 3))
    inertia = r @ np.diag(rng.uniform(0.01, 0.2, 3)) @ r.T
    forces = slip.slip_forces(points, normals, velocities, com, mass, inertia, SLIP, H)

    assert np.abs((forces * normals).sum(axis=1)).max() < 1e-9
    dv = H * forces.sum(axis=0) / mass
    dw = H * np.linalg.solve(inertia, np.cross(points - com, forces).sum(axis=0))
    after = velocities + dv + np.cross(dw, points - com)
    tangential = after - (after * normals).sum(axis=1)[:, None] * normals
    assert tangential == pytest.approx(-SLIP * forces, abs=1e-9)


def test_one_point_on_a_heavy_body_is_held_almost_still():
    """Behind a whole robot's mass a foot corner barely slides: the force nearly stops it."""
    v = np.array([[0.1, 0.0, 0.0]])
    f = slip.slip_forces(
        np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), v, np.array([0, 0, 0.0]), 1e6, np.eye(3) * 1e6, SLIP, H
    )
    assert f[0] == pytest.approx([-0.1 / SLIP, 0.0, 0.0], rel=1e-4)


def test_composite_body_adds_masses_and_moves_inertia_by_the_parallel_axis_rule():
    masses = np.array([2.0, 1.0])
    centres = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])
    moments = np.array([[0.01, 0.02, 0.03], [0.004, 0.005, 0.006]])
    mass, com, inertia = slip.composite_body(masses, centres, np.stack([np.eye(3)] * 2), moments)
    assert mass == 3.0
    assert com == pytest.approx([0.1, 0.0, 0.0])
    # x: no offset along x counts; y and z: 2 kg at 0.1 m and 1 kg at 0.2 m
    assert np.diag(inertia) == pytest.approx([0.014, 0.025 + 0.06, 0.036 + 0.06])
    assert inertia == pytest.approx(inertia.T)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1), axis=vectors.filter(lambda v: np.linalg.norm(v) > 0.1), angle=st.floats(0.0, 6.0)
)
def test_composite_body_turns_with_the_frame(seed, axis, angle):
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.05, 1.0, 5)
    centres = rng.uniform(-0.3, 0.3, (5, 3))
    rotations = np.stack([_rotation(rng.normal(size=3), rng.uniform(0, 3)) for _ in range(5)])
    moments = rng.uniform(1e-4, 1e-2, (5, 3))
    r = _rotation(axis, angle)
    _, com, inertia = slip.composite_body(masses, centres, rotations, moments)
    _, com_r, inertia_r = slip.composite_body(masses, centres @ r.T, r @ rotations, moments)
    assert com_r == pytest.approx(r @ com, abs=1e-12)
    assert inertia_r == pytest.approx(r @ inertia @ r.T, abs=1e-12)
    assert np.linalg.eigvalsh(inertia).min() > 0.0


def test_loose_points_are_damped_against_their_own_sliding_only():
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    velocities = np.array([[0.2, -0.1, 0.5], [0.0, 0.0, -1.0]])  # the second only moves normally
    f = slip.loose_slip_forces(normals, velocities, np.array([0.2, 0.1]), SLIP, H)
    assert f[0] == pytest.approx([-0.2, 0.1, 0.0] / np.float64(SLIP + H / 0.2))
    assert f[1] == pytest.approx([0.0, 0.0, 0.0])


def test_no_point_gets_more_than_what_stops_it():
    normals = np.array([[0.0, 0.0, 1.0]] * 2)
    velocities = np.array([[0.01, 0.0, 0.0], [0.5, 0.0, 0.0]])
    forces = np.array([[30.0, 40.0, 0.0], [-10.0, 0.0, 0.0]])
    capped = slip.at_most_stopping(forces, normals, velocities, SLIP)
    assert np.linalg.norm(capped[0]) == pytest.approx(0.01 / SLIP)
    assert capped[0] == pytest.approx(forces[0] * (0.01 / SLIP) / 50.0)  # same direction
    assert capped[1] == pytest.approx(forces[1])  # within its limit: untouched


def _two_hinge_pose() -> slip.Pose:
    """A torso at the origin, a thigh-like part below it on hinge 0 (at z -0.1, about x) and a
    shank-like part below that on hinge 1 (at z -0.3, about y)."""
    parts = 3
    return slip.Pose(
        np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -0.2], [0.0, 0.0, -0.4]]),
        np.tile([0.0, 0.0, 0.0, 1.0], (parts, 1)),
        np.zeros((parts, 3)),
        np.zeros((parts, 3)),
        np.array([[0.0, 0.0, -0.1], [0.0, 0.0, -0.3]]),
    )


_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # of the two hinges above, in the world


def test_hinge_torques_count_a_force_on_every_hinge_up_its_chain_only():
    pose = _two_hinge_pose()
    point = np.array([[0.0, 0.0, -0.5]])
    force = np.array([[2.0, 3.0, 0.0]])
    below_both = slip.hinge_torques(point, force, np.array([[True, True]]), pose.anchors, _AXES)
    # about x at z -0.1: lever (0, 0, -0.4) x (2, 3, 0) = (1.2, -0.8, 0); about y at -0.3: -0.4
    assert below_both == pytest.approx([1.2, -0.4])
    below_first = slip.hinge_torques(point, force, np.array([[True, False]]), pose.anchors, _AXES)
    assert below_first == pytest.approx([1.2, 0.0])


def _skeleton(limit: float = 10.0) -> slip.Skeleton:
    return slip.Skeleton(
        np.array([4.0, 0.5, 0.2]),
        np.array([[0.03, 0.03, 0.02], [1e-3] * 3, [1e-3] * 3]),
        np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        np.array([[False, False], [True, False], [True, True]]),
        limit,
    )


def test_a_point_behind_a_yielding_motor_gets_its_own_links_damper():
    pose = _two_hinge_pose()
    points = np.array([[0.05, 0.0, -0.5]])
    normals = np.array([[0.0, 0.0, 1.0]])
    velocity = np.array([0.3, 0.0, 0.0])
    pose.velocities[2] = velocity
    args = (points, normals, np.zeros(2), np.array([False, True]), np.zeros(2), SLIP, H)
    loose, _ = slip.contact_forces(_skeleton(), pose, np.array([2]), *args)
    expected = slip.loose_slip_forces(normals, velocity[None, :], np.array([0.2]), SLIP, H)
    assert loose == pytest.approx(expected)
    held, _ = slip.contact_forces(
        _skeleton(), pose, np.array([2]), points, normals, np.zeros(2), np.array([False, False]), np.zeros(2), SLIP, H
    )
    assert np.linalg.norm(held) > 1.5 * np.linalg.norm(loose)  # the whole body stands behind it


def test_a_point_whose_force_would_overload_a_motor_is_let_go():
    pose = _two_hinge_pose()
    pose.velocities[2] = [0.0, 4.0, 0.0]  # fast: the rigid damper would want ~70 N, 28 N m
    points, normals = np.array([[0.0, 0.0, -0.5]]), np.array([[0.0, 0.0, 1.0]])
    forces, torque = slip.contact_forces(
        _skeleton(), pose, np.array([2]), points, normals, np.zeros(2), np.array([False, False]), np.zeros(2), SLIP, H
    )
    assert forces == pytest.approx(
        slip.loose_slip_forces(normals, pose.velocities[2][None, :], np.array([0.2]), SLIP, H)
    )
    assert torque == pytest.approx(slip.hinge_torques(points, forces, np.array([[True, True]]), pose.anchors, _AXES))
    strong, _ = slip.contact_forces(
        _skeleton(limit=1000.0),
        pose,
        np.array([2]),
        points,
        normals,
        np.zeros(2),
        np.array([False, False]),
        np.zeros(2),
        SLIP,
        H,
    )
    assert np.linalg.norm(strong) > 1.5 * np.linalg.norm(forces)  # held when the motors can take it


@pytest.mark.parametrize("seed", range(6))
def test_a_flailing_robot_never_flies_off(seed):
    """Random motor speeds every 0.2 s for 12 s: the robot falls, lies and kicks. A damper that
    treated its limbs as rigid, or links with their raw tiny inertias, launched such robots at
    over 100 m/s in a few of a hundred runs; here the torso stays below 5 m/s."""
    rng = np.random.default_rng(1000 + seed)
    fastest = 0.0
    with World() as world:
        robot = world.add_robot()
        robot.beam(0.0, 0.0, 0.0)
        for cycle in range(600):
            if cycle % 10 == 0:
                for joint in JOINTS:
                    robot.command(joint.effector, float(rng.normal(0.0, 6.0)))
            world.step()
            fastest = max(fastest, float(np.linalg.norm(robot._velocity)))
    assert fastest < 5.0
