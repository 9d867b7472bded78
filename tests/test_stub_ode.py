"""The "ode" physics backend (``server_stub.physics.ode_step``): its dynamics against Bullet's, its LCP
solver, its ODE-style contacts, and the real server's standing numbers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet as pb
import pytest

from protocol.nao import JOINTS
from server_stub.config import PhysicsConfig
from server_stub.physics import calibration_walk, contact, ode_kernels, ode_maximal, ode_step
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
    loaded = contact.loaded(robot.contact_points())
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


# ----- the maximal-coordinate step (``PhysicsConfig.ode_maximal``, ``server_stub.physics.ode_maximal``) -----

MAX = dataclasses.replace(PhysicsConfig(), backend="ode", ode_maximal=True)


def _gaps(robot):
    bodies, static = robot._ode_bodies, robot._ode_static
    return ode_maximal.anchor_gaps(
        static.parents, static.joint_of, bodies.pos, bodies.quat, bodies.anchor_child, bodies.anchor_parent
    )


@pytest.fixture(scope="module")
def standing_max():
    world = World(MAX)
    robot = world.add_robot()
    robot.beam(-3.0, 2.0, 0.0)
    for _ in range(150):
        world.step()
    yield world, robot
    world.close()


def test_maximal_standing_numbers_match_the_real_server(standing_max):
    """docs section 2: torso at 0.383 m, each foot 22.59 N, dead still; the hinges' anchor copies
    stay together (the real server's monitor stream: 0.02 mm standing)."""
    world, robot = standing_max
    assert robot.torso_position()[2] == pytest.approx(0.383, abs=0.002)
    pressure = robot.foot_pressure()
    assert sorted(pressure) == ["lf", "rf"]
    for _, force in pressure.values():
        assert force[2] == pytest.approx(22.59, abs=0.1)
    start = robot.torso_position()
    for _ in range(100):
        world.step()
    assert np.allclose(robot.torso_position(), start, atol=1e-4)
    assert np.abs(robot.gyro()).max() < 0.05
    assert _gaps(robot).max() < 5e-5


def _free_robot(seed):
    """A tumbling robot's bodies (exact joints, random angles and rates) and its static data."""
    world = World(MAX)
    robot = world.add_robot()
    c, b = robot._client, robot.body_id
    rng = np.random.default_rng(seed)
    pb.resetBasePositionAndOrientation(
        b, (0, 0, 3), pb.getQuaternionFromEuler(rng.normal(size=3) * 0.5), physicsClientId=c
    )
    pb.resetBaseVelocity(b, rng.normal(size=3).tolist(), (rng.normal(size=3) * 3).tolist(), physicsClientId=c)
    pb.resetJointStatesMultiDof(
        b,
        list(range(22)),
        [[x] for x in rng.normal(size=22) * 0.5],
        targetVelocities=[[x] for x in rng.normal(size=22) * 3],
        physicsClientId=c,
    )
    static = ode_step._Static(c, b, world._ground, robot.robot_type)
    position, orientation = pb.getBasePositionAndOrientation(b, physicsClientId=c)
    v0, w0 = pb.getBaseVelocity(b, physicsClientId=c)
    links = pb.getLinkStates(b, static.indices, computeForwardKinematics=1, physicsClientId=c)
    coms = np.array([position] + [s[0] for s in links])
    quats = np.array([orientation] + [s[1] for s in links])
    anchors = np.array([s[4] for s in links])
    rates = np.array([s[1] for s in pb.getJointStates(b, static.indices, physicsClientId=c)])
    angles = np.array([s[0] for s in pb.getJointStates(b, static.indices, physicsClientId=c)])
    vel, spin = ode_maximal.body_velocities(
        static.parents, static.joint_of, static.local_axes, coms, quats, anchors, np.array(v0), np.array(w0), rates
    )
    child, parent = ode_maximal.local_anchors(static.parents, static.joint_of, coms, quats, anchors)
    world.close()
    return static, coms, quats, vel, spin, child, parent, angles, rates


def _free_step(static, coms, quats, vel, spin, child, parent, gravity=0.0, erp=0.2, implicit=True):
    none = np.zeros(0)
    return ode_maximal.step(
        static.masses,
        static.principal,
        static.parents,
        static.joint_of,
        static.local_axes,
        child,
        parent,
        coms,
        quats,
        vel,
        spin,
        np.array([0.0, 0.0, gravity]),
        0.0,
        0.0,
        vel,
        spin,
        implicit,
        np.zeros(0, dtype=np.int64),
        np.zeros((0, 3)),
        none,
        np.zeros(22),
        np.zeros(22),
        np.zeros(22),
        np.zeros(22),
        np.zeros(22, dtype=np.int64),
        0.02,
        erp,
        1e-5,
        1e-8,
        0.4,
        1e-4,
        0.005,
        0.001,
    )


def test_maximal_bodies_measure_the_joint_angles_pybullet_holds():
    """dJointGetHingeAngle and its rate, from the bodies placed by pybullet's exact joints, give
    pybullet's angles and rates back."""
    static, coms, quats, vel, spin, _, _, angles, rates = _free_robot(3)
    measured, measured_rates = ode_maximal.measure(quats, spin, static.parents, static.joint_of, static.local_axes)
    assert np.allclose(measured, angles, atol=1e-9)
    assert np.allclose(measured_rates, rates, atol=1e-9)


def test_maximal_free_flight_keeps_momentum_and_loses_no_more_than_the_gyroscopic_damping():
    """Without gravity, drag, contacts or motor torque (motor bounds 0), the joint forces are
    internal: the total linear momentum is kept exactly. The angular momentum about the centre of
    mass is not quite (the anchor copies drift apart, by up to 1 cm at these 3 rad/s rates and
    spins, and the rows pulling them back act at two different points; measured 5% over 25 steps
    with either gyroscopic form); the kinetic energy never grows and keeps 95%."""
    static, coms, quats, vel, spin, child, parent, _, _ = _free_robot(5)
    m = static.masses

    def momentum_and_energy(coms, quats, vel, spin):
        p = (m[:, None] * vel).sum(axis=0)
        centre = (m[:, None] * coms).sum(axis=0) / m.sum()
        ang = np.zeros(3)
        energy = 0.0
        for k in range(len(m)):
            r = np.array(pb.getMatrixFromQuaternion(quats[k])).reshape(3, 3)
            inertia = r @ np.diag(static.principal[k]) @ r.T
            ang += np.cross(coms[k] - centre, m[k] * vel[k]) + inertia @ spin[k]
            energy += 0.5 * m[k] * vel[k] @ vel[k] + 0.5 * spin[k] @ inertia @ spin[k]
        return p, ang, energy

    p0, l0, e0 = momentum_and_energy(coms, quats, vel, spin)
    state = (coms, quats, vel, spin)
    energies = [e0]
    for _ in range(25):
        out = _free_step(static, *state, child, parent)
        state = out[:4]
        energies.append(momentum_and_energy(*state)[2])
    p1, l1, e1 = momentum_and_energy(*state)
    assert np.allclose(p1, p0, atol=1e-9)
    assert np.linalg.norm(l1 - l0) < 0.08 * np.linalg.norm(l0)
    assert max(energies) <= e0 * 1.001
    assert e1 > 0.9 * e0
    assert _free_gaps(static, state, child, parent).max() < 0.015


def _free_gaps(static, state, child, parent):
    return ode_maximal.anchor_gaps(static.parents, static.joint_of, state[0], state[1], child, parent)


def test_maximal_joint_rows_pull_a_drifted_anchor_back_by_the_world_erp():
    """Every body at rest, one body moved 2 mm off its hinge: one step closes the gap by ERP 0.2
    (ODE's joint error reduction), to within the rows' CFM and the other joints' give."""
    static, coms, quats, vel, spin, child, parent, _, _ = _free_robot(7)
    vel, spin = np.zeros_like(vel), np.zeros_like(spin)
    foot = static.masses.shape[0] - 1
    moved = coms.copy()
    moved[foot] += np.array([0.002, 0.0, 0.0])
    gap = _free_gaps(static, (moved, quats), child, parent)[foot - 1]
    out = _free_step(static, moved, quats, vel, spin, child, parent)
    after = _free_gaps(static, out, child, parent)[foot - 1]
    assert gap == pytest.approx(0.002, rel=1e-6)
    assert after == pytest.approx(0.8 * gap, rel=0.02)


def test_odes_implicit_gyroscopic_torque_tends_to_the_explicit_one_for_small_steps():
    """ODE 0.16's implicit gyroscopic torque (I (I - h [L]x)^-1 - 1) L / h is -w x I w as h -> 0
    and smaller than it at h = 0.02 for a fast-spinning thin body (it damps the tumbling)."""
    inertia = np.diag([3.6e-6, 2e-4, 2e-4])
    w = np.array([1.0, 20.0, 5.0])
    explicit = -np.cross(w, inertia @ w)
    assert np.allclose(ode_maximal.gyroscopic_torque(inertia, w, 1e-7, True), explicit, rtol=1e-4, atol=1e-7)
    assert np.allclose(ode_maximal.gyroscopic_torque(inertia, w, 0.02, False), explicit)
    implicit = ode_maximal.gyroscopic_torque(inertia, w, 0.02, True)
    assert np.linalg.norm(implicit) < 0.9 * np.linalg.norm(explicit)


def test_calibration_walk_on_the_maximal_step():
    """The calibration walk from its default start walks 3.0 m +-15% without falling (real:
    2.91-3.14 m); every hinge's anchor copies stay within 1 cm and the knees part by millimetres,
    as the real server's do on walking gaits (3-6 mm on the 13.26 m gait)."""
    gaps = []
    original = ode_step.apply

    def apply(robot, solved):
        original(robot, solved)
        gaps.append(_gaps(robot))

    ode_step.apply = apply
    try:
        with World(MAX) as world:
            result = calibration_walk.run(world)
    finally:
        ode_step.apply = original
    assert not result.fell
    assert result.dx == pytest.approx(3.0, rel=0.15)
    assert abs(result.dy) <= 1.5 * 0.988
    gaps_mm = np.array(gaps) * 1000.0
    knees = [i for i, j in enumerate(JOINTS) if j.effector in ("rle4", "lle4")]
    assert gaps_mm.max() < 10.0
    assert 0.5 < gaps_mm[:, knees].max() < 8.0


def test_maximal_step_keeps_a_flailing_robot_together():
    """Random motor speeds (3 rad/s spread, new every 0.2 s) for 4 s: no blow-up (torso under
    5 m/s), every hinge's anchor copies within 2 cm."""
    rng = np.random.default_rng(11)
    with World(MAX) as world:
        robot = world.add_robot()
        robot.beam(-3.0, 2.0, 0.0)
        worst_speed = 0.0
        worst_gap = 0.0
        for step in range(200):
            if step % 10 == 0:
                for joint, speed in zip(JOINTS, rng.normal(size=22) * 3.0):
                    robot.command(joint.effector, float(speed))
            world.step()
            worst_speed = max(worst_speed, float(np.linalg.norm(robot._base_motion()[0])))
            worst_gap = max(worst_gap, float(_gaps(robot).max()))
    assert worst_speed < 5.0
    assert worst_gap < 0.02


def test_the_tree_solve_equals_the_dense_solve(monkeypatch):
    """``ode_maximal.step_tree`` (Baraff's tree elimination, the bounded rows on a Schur
    complement) gives ``step``'s velocities and contact forces (one dense LCP) on a flailing
    robot: stops hit, feet and hands on the ground, motors at their torque limit; to rounding."""
    tree = ode_maximal.step_tree
    worst = [0.0, 0.0]
    limits = [0]

    def both(*args):
        args = list(args)
        state = args[24].copy()
        dense = ode_maximal.step(*args)
        args[24] = state
        out = tree(*args)
        worst[0] = max(worst[0], np.abs(out[2] - dense[2]).max(), np.abs(out[3] - dense[3]).max())
        if out[4].size:
            worst[1] = max(worst[1], np.abs(out[4] - dense[4]).max())
        limits[0] += int(np.sum(np.abs(out[6]) >= 9.999))
        return out

    monkeypatch.setattr(ode_maximal, "step_tree", both)
    rng = np.random.default_rng(4)
    with World(MAX) as world:
        robot = world.add_robot()
        robot.beam(-3.0, 2.0, 0.0)
        for step in range(150):
            if step % 10 == 0:
                for joint, speed in zip(JOINTS, rng.normal(size=22) * 5.0):
                    robot.command(joint.effector, float(speed))
            world.step()
    assert limits[0] > 0
    assert worst[0] < 1e-6  # m/s, rad/s (measured 5e-8: the stops' CFM 1e-8 makes it stiff)
    assert worst[1] < 1e-4  # N


def test_a_beam_moves_the_maximal_bodies_rigidly_and_keeps_the_joints_drift():
    """SimSpark's beam (SoccerBase::MoveAndRotateAgent) moves every body with the torso and stops
    them, keeping each hinge's anchor gap: after a beam the gaps are the ones before (then pulled
    in by ERP 0.2 per step), not closed as a fresh placement from exact joints would close them."""
    rng = np.random.default_rng(2)
    with World(MAX) as world:
        robot = world.add_robot()
        robot.beam(-3.0, 2.0, 0.0)
        for step in range(60):
            if step % 10 == 0:
                for joint, speed in zip(JOINTS, rng.normal(size=22) * 4.0):
                    robot.command(joint.effector, float(speed))
            world.step()
        before = _gaps(robot)
        bodies = robot._ode_bodies
        centre = bodies.pos[0].copy()
        robot.beam(-6.0, -1.0, 45.0)
        world.step()
        after = _gaps(robot)
    worst = int(np.argmax(before))
    assert before[worst] > 1e-4
    assert after[worst] > 0.5 * before[worst]
    assert np.linalg.norm(robot._ode_bodies.pos[0] - centre) > 3.0


def test_moving_bodies_rigidly_keeps_their_relative_poses():
    static, coms, quats, _, _, child, parent, _, _ = _free_robot(9)
    coms = coms + np.random.default_rng(0).normal(size=coms.shape) * 1e-3  # drifted bodies
    gaps = _free_gaps(static, (coms, quats), child, parent)
    new_orientation = np.array(pb.getQuaternionFromEuler((0.0, 0.0, 0.7)))
    ode_maximal.move_rigidly(coms, quats, coms[0].copy(), quats[0].copy(), np.array([1.0, 2.0, 0.4]), new_orientation)
    assert np.allclose(coms[0], [1.0, 2.0, 0.4])
    assert abs(abs(quats[0] @ new_orientation) - 1.0) < 1e-12
    assert np.allclose(_free_gaps(static, (coms, quats), child, parent), gaps, atol=1e-12)


def test_after_a_beam_the_torso_feels_the_drag_of_its_velocity_before_it():
    """SimSpark runs the torso's DragController before the BeamEffector in a cycle (children first
    in nao_hetero.rsg), so the step after a beam drags the torso by -0.01 x its spin before the
    beam; every other body has been stopped by then. A torso spinning at 5 rad/s about z before
    the beam ends the next step turning the other way, by about h 0.01 x 5 / (the robot's yaw
    inertia), against one that was still."""
    yaw = []
    for spin in (0.0, 5.0):
        with World(MAX) as world:
            robot = world.add_robot()
            robot.beam(-3.0, 2.0, 0.0)
            for _ in range(40):
                world.step()
            robot._ode_bodies.spin[0] = (0.0, 0.0, spin)
            robot.beam(-3.0, 2.0, 0.0)
            world.step()
            yaw.append(robot._base_motion()[1][2])
    change = yaw[1] - yaw[0]
    assert -0.1 < change < -1e-4
