"""The "ode" physics backend (``server_stub.physics.ode_step``): its dynamics against Bullet's, its LCP
solver, its ODE-style contacts, and the real server's standing numbers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet as pb
import pytest

from server_stub.config import PhysicsConfig
from server_stub.physics import calibration_walk, ode_kernels, ode_step
from server_stub.physics.world import World

ODE = dataclasses.replace(PhysicsConfig(), backend="ode")


def test_the_environment_picks_the_backend(monkeypatch):
    monkeypatch.setenv("NAO_STUB_PHYSICS", "ode")
    assert PhysicsConfig().backend == "ode"
    monkeypatch.delenv("NAO_STUB_PHYSICS")
    assert PhysicsConfig().backend == "bullet"


def test_free_flight_velocity_change_matches_bullets_multibody_step():
    """M du = h Q with the kernel's mass matrix and forces gives Bullet's own step (no contacts,
    motors off, no damping) for a tumbling robot with random joint rates; and u'Mu/2 is the
    kinetic energy summed over the links."""
    config = dataclasses.replace(PhysicsConfig(), linear_damping=0.0, angular_damping=0.0)
    with World(config) as world:
        robot = world.add_robot()
        c, b = robot._client, robot.body_id
        for link in range(-1, 22):
            pb.changeDynamics(b, link, linearDamping=0.0, angularDamping=0.0, physicsClientId=c)
        pb.setJointMotorControlArray(
            b, list(range(22)), pb.VELOCITY_CONTROL, targetVelocities=[0.0] * 22, forces=[0.0] * 22, physicsClientId=c
        )
        rng = np.random.default_rng(1)
        pb.resetBasePositionAndOrientation(
            b, (0, 0, 3), pb.getQuaternionFromEuler(rng.normal(size=3) * 0.5), physicsClientId=c
        )
        pb.resetBaseVelocity(b, rng.normal(size=3).tolist(), (rng.normal(size=3) * 3).tolist(), physicsClientId=c)
        rates = rng.normal(size=22) * 3
        pb.resetJointStatesMultiDof(
            b,
            list(range(22)),
            [[x] for x in rng.normal(size=22) * 0.5],
            targetVelocities=[[x] for x in rates],
            physicsClientId=c,
        )
        static = ode_step._Static(c, b, world._ground)
        position, orientation = pb.getBasePositionAndOrientation(b, physicsClientId=c)
        v0, w0 = pb.getBaseVelocity(b, physicsClientId=c)
        links = pb.getLinkStates(
            b, static.indices, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=c
        )
        coms = np.array([position] + [s[0] for s in links])
        quats = np.array([orientation] + [s[1] for s in links])
        m, q, _ = ode_kernels.dynamics(
            static.masses,
            static.principal,
            static.chains,
            static.parents,
            static.joint_of,
            static.local_axes,
            coms,
            quats,
            np.array([s[4] for s in links]),
            np.array(v0),
            np.array(w0),
            rates,
            np.array([0.0, 0.0, -9.81]),
            0.0,
            0.0,
        )
        u = np.concatenate([v0, w0, rates])
        energy = 0.0
        for k, (mass, moments) in enumerate(zip(static.masses, static.principal)):
            quat, v, w = (orientation, v0, w0) if k == 0 else (links[k - 1][1], links[k - 1][6], links[k - 1][7])
            r = np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
            energy += 0.5 * mass * np.dot(v, v) + 0.5 * np.array(w) @ r @ np.diag(moments) @ r.T @ np.array(w)
        assert 0.5 * u @ m @ u == pytest.approx(energy, rel=1e-6)
        predicted = np.linalg.solve(m, q) * 0.02
        pb.stepSimulation(physicsClientId=c)
        v1, w1 = pb.getBaseVelocity(b, physicsClientId=c)
        rates1 = [s[1] for s in pb.getJointStates(b, static.indices, physicsClientId=c)]
        assert np.abs(np.concatenate([v1, w1, rates1]) - u - predicted).max() < 1e-4


@pytest.mark.parametrize("seed", range(20))
def test_box_qp_solves_the_boxed_lcp_exactly(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    g = rng.normal(size=(n, n))
    a = g @ g.T + 1e-3 * np.eye(n)
    b = rng.normal(size=n) * 10
    kind = rng.integers(0, 3, size=n)  # 0 unbounded, 1 >= 0, 2 boxed
    lo = np.where(kind == 0, -np.inf, np.where(kind == 1, 0.0, -rng.uniform(0.1, 2, size=n)))
    hi = np.where(kind == 0, np.inf, np.where(kind == 1, np.inf, rng.uniform(0.1, 2, size=n)))
    state = rng.integers(-1, 2, size=n).astype(np.int64)  # any guess, even a wrong one
    x, _ = ode_kernels.box_qp(a, b, lo, hi, state)
    w = a @ x - b
    tol = 1e-7 * (1 + np.abs(b).max())
    assert np.all(x >= lo - 1e-12) and np.all(x <= hi + 1e-12)
    inside = (x > lo + 1e-9) & (x < hi - 1e-9)
    assert np.all(np.abs(w[inside]) < tol)
    assert np.all(w[(x <= lo + 1e-9) & ~inside] > -tol)
    assert np.all(w[(x >= hi - 1e-9) & ~inside] < tol)


def _contacts(kind, size, centre, quat=(0.0, 0.0, 0.0, 1.0)):
    return ode_kernels.ground_contacts(
        np.array([0], dtype=np.int64),
        np.array([kind], dtype=np.int64),
        np.array([size], dtype=float),
        np.array([centre], dtype=float),
        np.array([quat], dtype=float),
        4,
    )


def test_ground_contacts_follow_odes_plane_colliders():
    # a flat foot 1 mm into the ground: its 4 sole corners, nothing above
    bodies, points, depths = _contacts(ode_kernels.BOX, (0.08, 0.16, 0.02), (0.0, 0.0, 0.009))
    assert len(bodies) == 4 and np.allclose(depths, 0.001)
    assert sorted(map(tuple, np.round(points[:, :2], 3))) == [
        (-0.04, -0.08),
        (-0.04, 0.08),
        (0.04, -0.08),
        (0.04, 0.08),
    ]
    # just above: no contact at all (ODE makes none for separated geometry)
    assert len(_contacts(ode_kernels.BOX, (0.08, 0.16, 0.02), (0.0, 0.0, 0.0101))[0]) == 0
    # a heel strike: only the corners that reach the ground
    tilt = pb.getQuaternionFromEuler((0.2, 0.0, 0.0))
    bodies, points, depths = _contacts(ode_kernels.BOX, (0.08, 0.16, 0.02), (0.0, 0.0, 0.025), tilt)
    assert len(bodies) == 2 and np.all(depths >= 0.0) and np.all(points[:, 1] < 0.0)
    bodies, points, depths = _contacts(ode_kernels.SPHERE, (0.065, 0.065, 0.065), (1.0, 2.0, 0.06))
    assert len(bodies) == 1 and depths[0] == pytest.approx(0.005) and points[0] == pytest.approx([1.0, 2.0, -0.005])
    lying = pb.getQuaternionFromEuler((np.pi / 2, 0.0, 0.0))
    bodies, points, depths = _contacts(ode_kernels.CAPSULE, (0.08, 0.015, 0.0), (0.0, 0.0, 0.014), lying)
    assert len(bodies) == 2 and np.allclose(depths, 0.001)


@pytest.fixture(scope="module")
def standing():
    world = World(ODE)
    robot = world.add_robot()
    robot.beam(-3.0, 2.0, 0.0)
    for _ in range(150):
        world.step()
    yield world, robot
    world.close()


def test_standing_numbers_match_the_real_server(standing):
    """docs/robot_and_server.md section 2: torso at 0.383 m, each foot 22.59 N; all 4 sole corners of each foot
    carry load; nothing drifts."""
    world, robot = standing
    assert robot.torso_position()[2] == pytest.approx(0.383, abs=0.002)
    pressure = robot.foot_pressure()
    assert sorted(pressure) == ["lf", "rf"]
    for _, force in pressure.values():
        assert force[2] == pytest.approx(22.59, abs=0.1)
    loaded = [c for c in robot._contacts() if c[9] > 0.0]
    assert len(loaded) == 8
    start = robot.torso_position()
    for _ in range(100):
        world.step()
    assert np.allclose(robot.torso_position(), start, atol=1e-4)


@pytest.mark.xfail(
    reason="measured: the ode backend falls in this start (walk probe: 10 of 24 perturbed "
    "starts ok, the rest fall in the first 1.5 s); the bullet backend stays the default",
    strict=False,
)
def test_calibration_walk_on_the_ode_backend():
    with World(ODE) as world:
        result = calibration_walk.run(world)
    assert not result.fell
    assert result.dx == pytest.approx(3.0, rel=0.15)
    assert abs(result.dy) <= 1.5 * 0.988


def test_odes_box_plane_rule_gives_the_deepest_corner_and_at_most_two_neighbours():
    """``ode_box_points`` 3: a flat foot 1 mm deep touches at 3 corners (the deepest and its two
    neighbours along the sole's sides, never the diagonal one); the third is counted as deep as
    the second less its own side's projection, as ODE counts it."""
    tilt = pb.getQuaternionFromEuler((0.001, 0.002, 0.0))  # a hair off flat picks the deepest corner
    bodies, points, depths = ode_kernels.ground_contacts(
        np.array([0], dtype=np.int64),
        np.array([ode_kernels.BOX], dtype=np.int64),
        np.array([[0.08, 0.16, 0.02]]),
        np.array([[0.0, 0.0, 0.009]]),
        np.array([tilt]),
        3,
    )
    assert len(bodies) == 3
    corners = {tuple(np.sign(p[:2]).astype(int)) for p in points}
    assert len(corners) == 3 and all(abs(x) == 1 for c in corners for x in c)
    assert depths[0] == max(depths) and depths[2] <= depths[1] <= depths[0]
    r = np.array(pb.getMatrixFromQuaternion(tilt)).reshape(3, 3)
    projections = sorted(abs(np.array([0.08, 0.16, 0.02]) * r[2]))
    assert depths[1] == pytest.approx(depths[0] - projections[0], abs=1e-12)
    assert depths[2] == pytest.approx(depths[0] - projections[0] - projections[1], abs=1e-12)
    # standing on an edge (a heel strike): only the corners that reach the ground
    heel = pb.getQuaternionFromEuler((0.2, 0.0, 0.0))
    bodies, points, depths = ode_kernels.ground_contacts(
        np.array([0], dtype=np.int64),
        np.array([ode_kernels.BOX], dtype=np.int64),
        np.array([[0.08, 0.16, 0.02]]),
        np.array([[0.0, 0.0, 0.025]]),
        np.array([heel]),
        3,
    )
    assert len(bodies) == 2 and np.all(points[:, 1] < 0.0) and np.all(depths >= 0.0)
