"""The "ode" physics backend: one ODE-like constrained step per cycle, solved here, with pybullet
kept for collision detection and as the store of the robots' state (``PhysicsConfig.backend``).

Why: the real server (ODE 0.16, one exact ``dWorldStep`` of 0.02 s per cycle; facts in
docs/robot_and_server.md sections 3-4) solves contacts, friction with force-dependent slip and no
Coulomb limit, and the hinge motors in one linear complementarity problem, so within a step the
landing foot, the motors and the tipping body all feel friction. The "bullet" backend has no
friction row with a slip CFM and adds slip as an outside force from the step's start
(``server_stub.physics.slip``).

The step, for each robot, in reduced coordinates u = (torso velocity, torso spin, hinge rates),
every vector in the world frame (``server_stub.physics.ode_kernels``):

- dynamics: M(q) du/dt = Q(q, u) + J' lambda, with M = sum over bodies of Jv' m Jv + Jw' I Jw and
  Q the bodies' gravity, spin (w x I w) and velocity-product terms, mapped through the same
  Jacobians;
- rows, each J u_new = c - cfm lambda (ODE's soft constraint: its LCP adds cfm / h to the
  diagonal and solves for forces): per contact point a normal row (lambda >= 0, c = ERP x
  (depth - surface layer) / h, cfm the contact's soft CFM) and two friction rows in the contact
  plane (unbounded, mu infinite; cfm = slip, so a point slides at slip x its tangential force);
  per hinge a motor row (c = the target speed of ``server_stub.physics.motors``, |lambda| <= its force:
  10 N m, or the stop's force when the stop drives the joint back), cfm 1e-8 as every joint row;
- lambda from the boxed LCP on A = h J M^-1 J' + diag(cfm), b = c - J (u + h M^-1 Q), solved
  exactly (``ode_kernels.box_qp``, a primal active-set method);
- u_new = u + h M^-1 (Q + J' lambda); positions then move with u_new (semi-implicit Euler, as
  dWorldStep): torso centre by h v, torso orientation by the rotation h w, hinges by h qd.

Contacts with the ground are found at the step's start (as SimSpark collides before it steps) by
``ode_kernels.ground_contacts``, which makes them as ODE's plane colliders do: only for touching
or overlapping geometry; a box gets ODE's box-plane contacts (``ode_kernels.box_plane``: the
deepest corner, at most two neighbours and, SimSpark asking for 4, the face's fourth corner); a
sphere its lowest point; a capsule its two ends. Bullet no longer collides the robots with the ground. The new state is
written back into pybullet, so sensors, the monitor and vision read it as before, and each robot's
contact points carry the solved forces in pybullet's tuple layout for the FRP perceptor.

Every body has SimSpark's drag (docs/robot_and_server.md section 2): a force -0.01 v at its centre and a torque
-0.01 w, added before the step as its DragController does (``linear_damping``, ``angular_damping``).

With ``PhysicsConfig.ode_maximal`` the step is ODE's own in maximal coordinates instead
(``server_stub.physics.ode_maximal``, ``_solve_maximal`` here): every body integrated on its own,
the hinges held by ODE's joint rows with the world ERP 0.2 and CFM 1e-5, so their anchor copies
drift apart by millimetres as on the real server; the same contacts and motor rules.

Contacts besides the ground (robot-robot, robot-ball, robot-goal/border, with the ball a body of
the stub's own solve and touching robots solved in one island) are the maximal step's only
(``server_stub.physics.ode_contacts``, ``PhysicsConfig.ode_contacts``). The reduced step stays
without them: there each robot meets only the ground, the ball moves in Bullet's step and the
robots are not pushed back by it; nor has it ODE's joint-row softness and maximal coordinates
(see ``ode_maximal``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial
from typing import NamedTuple

import numpy as np
import pybullet as pb
from numba import njit

from server_stub.physics import nao_model, ode_kernels, ode_maximal
from server_stub.physics.ode_kernels import BOX, CAPSULE, SPHERE
from server_stub.physics.robot import _MAX

#: ODE joint rows' CFM (docs/robot_and_server.md section 3), used for the motor rows.
MOTOR_CFM = 1e-8
#: SimSpark's hinge fudge factor (hingejoint.rsg): a motor driving away from the stop it stands
#: at pushes with this fraction of its force (ODE's dxJointLimitMotor); the maximal step only.
FUDGE_FACTOR = 1e-5
#: Most contact points per shape and the ground in ``warm_up``.
MAX_POINTS = 4
#: ODE's world ERP (its default 0.2; SimSpark sets none), which pulls a hinge's drifted anchor
#: copies back together.
JOINT_ERP = 0.2


class _Static:
    """What does not change about one robot body: masses, inertias, tree, hinge axes, shapes."""

    def __init__(self, client: int, body: int, ground: int, robot_type: int | None = None) -> None:
        """``robot_type``: take each part's principal moments from the model (``nao_model``), as
        the real server's bodies have them, instead of pybullet's (raised to the inertia floor
        that Bullet's own solver needs)."""
        n = pb.getNumJoints(body, physicsClientId=client)
        self.indices = list(range(n))
        dyn = [pb.getDynamicsInfo(body, k, physicsClientId=client) for k in range(-1, n)]
        infos = [pb.getJointInfo(body, j, physicsClientId=client) for j in range(n)]
        self.masses = np.array([d[0] for d in dyn], dtype=float)
        self.principal = np.array([d[2] for d in dyn], dtype=float)
        if robot_type is not None:
            parts = {part.name: part for part in nao_model.body_parts(robot_type)}
            names = ["torso"] + [i[12].decode() for i in infos]
            self.principal = np.array([nao_model.inertia_diagonal(parts[name]) for name in names], dtype=float)
        self.parents = np.zeros(n + 1, dtype=np.int64)
        self.joint_of = np.zeros(n + 1, dtype=np.int64)
        self.local_axes = np.array([i[13] for i in infos], dtype=float)
        chains = np.zeros((n + 1, n), dtype=np.bool_)
        for j, info in enumerate(infos):
            k = j + 1
            parent = info[16] + 1
            if parent >= k:
                raise ValueError("links must follow their parents")
            self.parents[k] = parent
            self.joint_of[k] = j
            chains[k] = chains[parent]
            chains[k, j] = True
        self.chains = chains
        self.motor_state = np.zeros(n, dtype=np.int64)
        #: each hinge's gap between its two anchor copies (world, m): ODE's joint drift
        self.gap = np.zeros((n, 3))
        #: each hinge's child turned off its hinge (world rotation vector, rad): ODE's joint drift
        self.turn = np.zeros((n, 3))
        shapes = [d for k in range(-1, n) for d in pb.getCollisionShapeData(body, k, physicsClientId=client)]
        self.shape_body = np.array([d[1] + 1 for d in shapes], dtype=np.int64)
        self.shape_kind = np.array([d[2] for d in shapes], dtype=np.int64)
        self.shape_size = np.array([d[3] for d in shapes], dtype=float)
        if any(abs(x) > 1e-12 for d in shapes for x in d[5]) or set(self.shape_kind) - {BOX, SPHERE, CAPSULE}:
            raise ValueError("shapes must be boxes, spheres or capsules at their body's centre")
        # the stub finds the robot's ground contacts itself: Bullet need not
        for k in range(-1, n):
            pb.setCollisionFilterPair(ground, body, -1, k, 0, physicsClientId=client)


class Solved(NamedTuple):
    """A robot's state after its step, and the step's contacts (pybullet's tuple layout, with the
    solved forces; made when a sensor first asks, as most steps' are never read) and motor
    torques."""

    position: list
    orientation: list
    velocity: list
    spin: list
    angles: np.ndarray
    rates: np.ndarray
    contacts: Callable[[], tuple]
    torques: np.ndarray
    iterations: int


def solve(robot, ground: int, config) -> Solved:
    """One ODE-like step of ``robot`` (its motors already set by ``Robot.begin_step``), from
    the state pybullet holds now; nothing is written."""
    robot.sync()
    client, body = robot._client, robot._body
    static = static_of(robot, ground, config)
    if config.ode_maximal:
        return _solve_maximal(robot, ground, static, config)
    h = config.cycle
    position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=client)
    v0, w0 = pb.getBaseVelocity(body, physicsClientId=client)
    states = pb.getJointStates(body, static.indices, physicsClientId=client)
    angles = np.array([s[0] for s in states])
    rates = np.array([s[1] for s in states])
    links = pb.getLinkStates(body, static.indices, computeForwardKinematics=1, physicsClientId=client)
    coms = np.array([position] + [link[0] for link in links], dtype=float)
    quats = np.array([orientation] + [link[1] for link in links], dtype=float)
    anchors = np.array([link[4] for link in links], dtype=float)
    placed, turned = coms, quats
    if config.ode_joint_drift:
        placed, turned = ode_kernels.drifted_poses(
            static.parents, static.joint_of, coms, quats, anchors, static.gap, static.turn
        )
    parts, points, depths = ode_kernels.ground_contacts(
        static.shape_body, static.shape_kind, static.shape_size, placed, turned, config.ode_box_points
    )
    nc = parts.shape[0]
    normals = np.zeros((nc, 3))
    normals[:, 2] = 1.0
    target, force = robot._sent
    nj = len(static.indices)
    if target.shape[0] != nj:
        target = np.zeros(nj)
        force = np.full(nj, config.motor_torque)
    lo, hi, push = _motor_rows(
        angles, np.asarray(force, dtype=float), robot._motor, config.motor_torque, config.ode_limits
    )
    u, forces, tangents, torques, iterations = ode_kernels.step(
        static.masses,
        static.principal,
        static.chains,
        static.parents,
        static.joint_of,
        static.local_axes,
        coms,
        quats,
        anchors,
        np.array(v0, dtype=float),
        np.array(w0, dtype=float),
        rates,
        np.array([0.0, 0.0, config.gravity]),
        config.linear_damping,
        config.angular_damping,
        parts,
        points,
        normals,
        depths,
        np.asarray(target, dtype=float),
        lo,
        hi,
        push,
        static.motor_state,
        h,
        config.contact_erp,
        config.contact_cfm,
        config.slip,
        config.contact_slop,
        MOTOR_CFM,
    )
    v, w, qd = u[0:3], u[3:6], u[6:]
    if config.ode_joint_drift:
        gap, turn = ode_kernels.joint_drift(
            static.parents, static.joint_of, static.local_axes, coms, quats, anchors, w, qd, h
        )
        static.gap *= 1.0 - JOINT_ERP
        static.gap += gap
        static.turn *= 1.0 - JOINT_ERP
        static.turn += turn
    new_position = np.array(position) + h * v
    new_orientation = ode_kernels.integrate_orientation(np.array(orientation, dtype=float), w, h)
    new_angles = angles + h * qd
    contacts = partial(ground_tuples, body, ground, parts, points, depths, forces, tangents)
    return Solved(
        new_position.tolist(),
        new_orientation.tolist(),
        v.tolist(),
        w.tolist(),
        new_angles,
        qd,
        contacts,
        torques,
        iterations,
    )


class _Bodies:
    """The maximal-coordinate state of one robot (``ode_maximal``): every body's centre,
    quaternion, velocity and spin, kept between steps (pybullet's exact joints cannot hold the
    joints' drift), and the reduced state last written into pybullet, to notice a beam or a
    trainer's move (then the bodies are placed anew from pybullet)."""

    def __init__(self, pos, quat, vel, spin, anchor_child, anchor_parent) -> None:
        self.pos, self.quat, self.vel, self.spin = pos, quat, vel, spin
        self.anchor_child, self.anchor_parent = anchor_child, anchor_parent
        self.written: np.ndarray | None = None


#: how far pybullet's state may differ from what the maximal step wrote before the bodies are
#: placed anew from it (a beam, a trainer's move, a reset)
_RESYNC_TOLERANCE = 1e-7


def _reduced(position, orientation, velocity, spin, angles, rates) -> np.ndarray:
    return np.concatenate((position, orientation, velocity, spin, angles, rates))


def _is_rigid_move(written: np.ndarray, now: np.ndarray) -> bool:
    """Whether pybullet's state differs from the one written only by the torso's pose and by
    every velocity being zero (``Robot.beam`` / ``Robot.place``): joint angles kept."""
    n = (written.shape[0] - 13) // 2
    angles_kept = np.max(np.abs(written[13 : 13 + n] - now[13 : 13 + n]), initial=0.0) <= _RESYNC_TOLERANCE
    still = not np.any(now[7:13]) and not np.any(now[13 + n :])
    return bool(angles_kept and still)


class Prepared(NamedTuple):
    """A robot ready for its maximal step: its bodies (synchronised with pybullet), the
    velocities its drag acts on, and its motor rows."""

    bodies: _Bodies
    drag_vel: np.ndarray
    drag_spin: np.ndarray
    target: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    push: np.ndarray


def static_of(robot, ground: int, config) -> _Static:
    """What does not change about ``robot``'s body (made on first use)."""
    static = getattr(robot, "_ode_static", None)
    if static is None or static.masses.shape[0] != len(robot._indices) + 1:
        true_inertia = config.ode_true_inertia or config.ode_maximal
        static = _Static(robot._client, robot._body, ground, robot.robot_type if true_inertia else None)
        robot._ode_static = static
    return static


def _solve_maximal(robot, ground: int, static: _Static, config) -> Solved:
    """One step of ``ode_maximal`` (every body on its own, ODE's joint rows)."""
    return solve_prepared(robot, static, prepare_maximal(robot, static, config), ground, config)


def solve_prepared(robot, static: _Static, prep: Prepared, ground: int, config) -> Solved:
    """The maximal step of a prepared robot against the ground alone."""
    bodies = prep.bodies
    parts, points, depths = ode_kernels.ground_contacts(
        static.shape_body, static.shape_kind, static.shape_size, bodies.pos, bodies.quat, config.ode_box_points
    )
    pos, quat, vel, spin, forces, tangents, torques, iterations = ode_maximal.step_tree(
        static.masses,
        static.principal,
        static.parents,
        static.joint_of,
        static.local_axes,
        bodies.anchor_child,
        bodies.anchor_parent,
        bodies.pos,
        bodies.quat,
        bodies.vel,
        bodies.spin,
        np.array([0.0, 0.0, config.gravity]),
        config.linear_damping,
        config.angular_damping,
        prep.drag_vel,
        prep.drag_spin,
        config.ode_gyroscopic == "implicit",
        parts,
        points,
        depths,
        prep.target,
        prep.lo,
        prep.hi,
        prep.push,
        static.motor_state,
        config.cycle,
        config.ode_joint_erp,
        config.global_cfm,
        MOTOR_CFM,
        config.contact_erp,
        config.contact_cfm,
        config.slip,
        config.contact_slop,
    )
    contacts = partial(ground_tuples, robot._body, ground, parts, points, depths, forces, tangents)
    return finish_maximal(robot, static, bodies, pos, quat, vel, spin, contacts, torques, iterations)


def ground_tuples(body: int, ground: int, parts, points, depths, forces, tangents) -> tuple:
    """A robot's ground contacts in pybullet's tuple layout, with their solved forces."""
    return tuple(
        (
            0,
            body,
            ground,
            k - 1,
            -1,
            p,
            (p[0], p[1], 0.0),
            (0.0, 0.0, 1.0),
            -d,
            f[0],
            f[1],
            tuple(t[0]),
            f[2],
            tuple(t[1]),
        )
        for k, p, d, f, t in zip(parts.tolist(), points.tolist(), depths.tolist(), forces.tolist(), tangents.tolist())
    )


def prepare_maximal(robot, static: _Static, config) -> Prepared:
    """Bring ``robot``'s bodies in line with pybullet (a beam or a trainer's move shifts them
    rigidly, anything else re-places them) and make its motor rows."""
    bodies: _Bodies | None = getattr(robot, "_ode_bodies", None)
    written = None if bodies is None else bodies.written
    if bodies is not None and written is not None and _holds_written(robot, written):
        # pybullet holds what the last step wrote: the bodies go on from their own state
        return _prepared(robot, bodies, bodies.vel, bodies.spin, robot._joint_state()[0], config)
    robot.sync()
    client, body = robot._client, robot._body
    position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=client)
    v0, w0 = pb.getBaseVelocity(body, physicsClientId=client)
    states = pb.getJointStates(body, static.indices, physicsClientId=client)
    angles = np.array([s[0] for s in states])
    rates = np.array([s[1] for s in states])
    now = _reduced(position, orientation, v0, w0, angles, rates)
    drag_vel = drag_spin = None
    if bodies is not None and written is not None and np.max(np.abs(written - now)) <= _RESYNC_TOLERANCE:
        pass  # pybullet holds what the last step wrote: the bodies go on from their own state
    elif bodies is not None and written is not None and _is_rigid_move(written, now):
        # a beam or a trainer's move: SimSpark moves every body rigidly with the torso (keeping
        # the joints' drift) and stops them all (SoccerBase::MoveAndRotateAgent). The torso's
        # DragController ran before the BeamEffector in that cycle's PrePhysicsUpdate (children
        # first, the torso's body before the effectors in nao_hetero.rsg), so its drag in the
        # next step is the one of its velocity before the beam; every other body's comes after.
        ode_maximal.move_rigidly(bodies.pos, bodies.quat, written[0:3], written[3:7], now[0:3], now[3:7])
        drag_vel = np.zeros_like(bodies.vel)
        drag_spin = np.zeros_like(bodies.spin)
        drag_vel[0] = bodies.vel[0]
        drag_spin[0] = bodies.spin[0]
        bodies.vel[:] = 0.0
        bodies.spin[:] = 0.0
    else:
        links = pb.getLinkStates(body, static.indices, computeForwardKinematics=1, physicsClientId=client)
        coms = np.array([position] + [link[0] for link in links], dtype=float)
        quats = np.array([orientation] + [link[1] for link in links], dtype=float)
        anchors = np.array([link[4] for link in links], dtype=float)
        vel, spin = ode_maximal.body_velocities(
            static.parents,
            static.joint_of,
            static.local_axes,
            coms,
            quats,
            anchors,
            np.array(v0, dtype=float),
            np.array(w0, dtype=float),
            rates,
        )
        if bodies is None:
            child, parent = ode_maximal.local_anchors(static.parents, static.joint_of, coms, quats, anchors)
        else:
            child, parent = bodies.anchor_child, bodies.anchor_parent
        bodies = _Bodies(coms, quats, vel, spin, child, parent)
        robot._ode_bodies = bodies
    if drag_vel is None or drag_spin is None:
        drag_vel, drag_spin = bodies.vel, bodies.spin
    return _prepared(robot, bodies, drag_vel, drag_spin, angles, config)


def _holds_written(robot, written: np.ndarray) -> bool:
    """Whether pybullet holds the state the last maximal step wrote, within ``_RESYNC_TOLERANCE``,
    without reading it all: a robot that ``held`` it gets its centre, velocities, angles and rates
    back exactly, and its orientation rebuilt from a matrix (compared here; the sensors read that
    one too)."""
    if not robot.held or not math.isfinite(written.sum()):
        return False
    (x, y, z, w), (wx, wy, wz, ww) = robot._base_pose()[2], written[3:7].tolist()
    return max(abs(x - wx), abs(y - wy), abs(z - wz), abs(w - ww)) <= _RESYNC_TOLERANCE


def _prepared(robot, bodies: _Bodies, drag_vel, drag_spin, angles: np.ndarray, config) -> Prepared:
    """A robot's prepared step: its bodies, the velocities the drag acts on, its motor rows."""
    target, force = robot._sent
    nj = angles.shape[0]
    if target.shape[0] != nj:
        target = np.zeros(nj)
        force = np.full(nj, config.motor_torque)
    lo, hi, push = _motor_rows(
        angles, np.asarray(force, dtype=float), robot._motor, config.motor_torque, True, FUDGE_FACTOR
    )
    return Prepared(bodies, drag_vel, drag_spin, np.asarray(target, dtype=float), lo, hi, push)


def finish_maximal(
    robot, static: _Static, bodies: _Bodies, pos, quat, vel, spin, contacts, torques, iterations
) -> Solved:
    """Keep a robot's solved bodies and measure what pybullet gets: torso state, hinge angles and
    rates as the real server reads them."""
    bodies.pos, bodies.quat, bodies.vel, bodies.spin = pos, quat, vel, spin
    written = ode_maximal.measured_state(pos, quat, vel, spin, static.parents, static.joint_of, static.local_axes)
    bodies.written = written
    nj = static.local_axes.shape[0]
    return Solved(
        written[0:3].tolist(),
        written[3:7].tolist(),
        written[7:10].tolist(),
        written[10:13].tolist(),
        written[13 : 13 + nj],
        written[13 + nj :],
        contacts,
        torques,
        iterations,
    )


@njit(cache=True)
def _motor_rows(angles, force, sticky, torque_limit, ode_limits, fudge=0.0):
    """Bounds of each hinge's row and the torque pushing hinges besides it. Inside its range a
    hinge's row is its motor's, |torque| <= 10 N m. Outside, ``server_stub.physics.motors`` has made the
    row its stop's (target: back by ERP 0.8 or the bounced speed, whichever is larger). With
    ``ode_limits`` the stop row is ODE's: one-sided (it only pushes the hinge back in), and the
    motor, which has no row of its own then, pushes with its full torque as an outside torque
    when its (sticky) target speed points into the stop or is 0, and not at all when it points
    out (SimSpark's fudge factor 1e-5; docs/robot_and_server.md section 3). Without, a two-sided row with the stop's
    force, as the "bullet" backend's stop is."""
    n = force.shape[0]
    lo = np.empty(n)
    hi = np.empty(n)
    push = np.zeros(n)
    for j in range(n):
        lo[j] = -force[j]
        hi[j] = force[j]
        if not ode_limits or not force[j] > torque_limit:
            continue
        if angles[j] >= _MAX[j]:
            lo[j], hi[j] = -np.inf, 0.0
            push[j] = torque_limit if sticky[j] >= 0.0 else -fudge * torque_limit
        else:
            lo[j], hi[j] = 0.0, np.inf
            push[j] = -torque_limit if sticky[j] <= 0.0 else fudge * torque_limit
    return lo, hi, push


def apply(robot, solved: Solved) -> None:
    """Hand a solved step to the robot (``Robot.hold``) and into pybullet: at once for a robot
    Bullet steps too (after Bullet's own step of the rest of the world), else when pybullet is
    next asked about it (``Robot.keep_unwritten``)."""
    robot.keep_unwritten(
        tuple(solved.position), tuple(solved.orientation), solved.velocity, solved.spin, solved.angles, solved.rates
    )
    if robot._bullet_steps:
        robot.sync()
    robot.hold(solved.angles, solved.rates, tuple(solved.velocity), tuple(solved.spin), solved.contacts)


def warm_up() -> None:
    """Compile (or load from numba's disk cache) the kernels on a two-body problem."""
    masses = np.ones(2)
    principal = np.full((2, 3), 0.01)
    chains = np.array([[False], [True]])
    ode_kernels.step(
        masses,
        principal,
        chains,
        np.array([0, 0], dtype=np.int64),
        np.array([0, 0], dtype=np.int64),
        np.array([[1.0, 0.0, 0.0]]),
        np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.05]]),
        np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)),
        np.array([[0.0, 0.0, 0.1]]),
        np.zeros(3),
        np.zeros(3),
        np.zeros(1),
        np.array([0.0, 0.0, -9.81]),
        0.01,
        0.01,
        np.array([1], dtype=np.int64),
        np.array([[0.0, 0.0, 0.0]]),
        np.array([[0.0, 0.0, 1.0]]),
        np.array([0.002]),
        np.zeros(1),
        np.full(1, -10.0),
        np.full(1, 10.0),
        np.zeros(1),
        np.zeros(1, dtype=np.int64),
        0.02,
        0.4,
        1e-4,
        0.005,
        0.001,
        MOTOR_CFM,
    )
    ode_kernels.integrate_orientation(np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]), 0.02)
    for limits in (True, False):  # as the maximal step and the reduced one call it
        _motor_rows(np.zeros(22), np.full(22, 10.0), np.zeros(22), 10.0, limits, FUDGE_FACTOR)
        _motor_rows(np.zeros(22), np.full(22, 10.0), np.zeros(22), 10.0, limits)
    _warm_up_maximal()
    two = (np.array([0, 0], dtype=np.int64), np.array([0, 0], dtype=np.int64))
    centres, quats = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.05]]), np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    ode_kernels.joint_drift(
        *two, np.array([[1.0, 0.0, 0.0]]), centres, quats, np.array([[0.0, 0.0, 0.1]]), np.zeros(3), np.ones(1), 0.02
    )
    ode_kernels.drifted_poses(
        *two, centres, quats, np.array([[0.0, 0.0, 0.1]]), np.full((1, 3), 1e-3), np.full((1, 3), 1e-3)
    )
    ode_kernels.ground_contacts(
        np.array([0, 0, 0], dtype=np.int64),
        np.array([BOX, SPHERE, CAPSULE], dtype=np.int64),
        np.array([[0.1, 0.1, 0.1], [0.1, 0.1, 0.1], [0.1, 0.02, 0.0]]),
        np.array([[0.0, 0.0, 0.05]]),
        np.array([[0.0, 0.0, 0.0, 1.0]]),
        MAX_POINTS,
    )
    ode_kernels.ground_contacts(
        np.array([0], dtype=np.int64),
        np.array([BOX], dtype=np.int64),
        np.array([[0.1, 0.1, 0.1]]),
        np.array([[0.0, 0.0, 0.05]]),
        np.array([[0.0, 0.0, 0.0, 1.0]]),
        3,
    )


def _warm_up_maximal() -> None:
    """Compile (or load) the maximal step's kernels on a two-body problem with one contact."""
    two = (np.array([0, 0], dtype=np.int64), np.array([0, 0], dtype=np.int64))
    axes = np.array([[1.0, 0.0, 0.0]])
    centres = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.05]])
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    anchors = np.array([[0.0, 0.0, 0.1]])
    vel, spin = ode_maximal.body_velocities(*two, axes, centres, quats, anchors, np.zeros(3), np.zeros(3), np.ones(1))
    child, parent = ode_maximal.local_anchors(*two, centres, quats, anchors)
    ode_maximal.anchor_gaps(*two, centres, quats, child, parent)
    ode_maximal.measure(quats, spin, *two, axes)
    ode_maximal.measured_state(centres, quats, vel, spin, *two, axes)
    for kernel in (ode_maximal.step, ode_maximal.step_tree):
        kernel(
            np.ones(2),
            np.full((2, 3), 0.01),
            *two,
            axes,
            child,
            parent,
            centres,
            quats,
            vel,
            spin,
            np.array([0.0, 0.0, -9.81]),
            0.01,
            0.01,
            vel,
            spin,
            True,
            np.array([1], dtype=np.int64),
            np.array([[0.0, 0.0, 0.0]]),
            np.array([0.002]),
            np.zeros(1),
            np.full(1, -10.0),
            np.full(1, 10.0),
            np.zeros(1),
            np.zeros(1, dtype=np.int64),
            0.02,
            0.2,
            1e-5,
            MOTOR_CFM,
            0.4,
            1e-4,
            0.005,
            0.001,
        )
