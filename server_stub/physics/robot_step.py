"""One robot's part of the stand-in's ODE step: what the step keeps of it, its motor rows, and its
step against the ground alone.

The real server (ODE 0.16, one exact ``dWorldStep`` of 0.02 s per cycle; facts in
docs/robot_and_server.md sections 3-4) solves contacts, friction with force-dependent slip and no
Coulomb limit, and the hinge motors in one linear complementarity problem. The stand-in does the
same in maximal coordinates (``tree_step``): every body integrated on its own, the hinges held by
ODE's joint rows with the world ERP 0.2 and CFM 1e-5, so their anchor copies drift apart by
millimetres as on the real server.

Kept per robot (``RobotPhysics``, owned by ``stepper.Stepper``): what never changes (``RobotModel``:
the kernels' ``Model`` of its bodies, its shapes and joint limits), and its bodies' ``State``
(placed from pybullet's exact joints before the first step, moved rigidly by a beam or a
trainer's move): as MuJoCo's model and data, one type each, the kernels' own bundles. Each cycle
``prepare`` makes the motor rows, and a robot touching nothing but the ground is stepped by
``solve_prepared``; robots touching each other, the ball or the field's boxes are solved as one
island (``stepper``, ``island_step``). ``ground_tuples`` gives a robot's contacts in pybullet's
tuple layout, with their solved forces, for the foot sensors.

Every body has SimSpark's drag (docs/robot_and_server.md section 2): a force -0.01 v at its centre
and a torque -0.01 w, added before the step as its DragController does.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import NamedTuple

import numpy as np
import pybullet as pb

from server_stub.physics import bodies as kinematics
from server_stub.physics import contact, nao_model
from server_stub.physics.bundles import Forces, GroundContacts, Model, Motors, Params, State
from server_stub.physics.collision import BOX, CAPSULE, SPHERE, ground_contacts
from server_stub.physics.rows import FUDGE_FACTOR, MOTOR_CFM, motor_rows
from server_stub.physics.tree_step import step_tree

#: Most contact points per shape and the ground in ``warm_up``.
MAX_POINTS = 4


class RobotModel:
    """What does not change about one robot body: its bodies as the kernels take them (``model``:
    masses, inertias, tree, hinge axes and anchors), its shapes and its joints' upper limits."""

    def __init__(self, client: int, body: int, ground: int, robot_type: int) -> None:
        """Each part's principal moments come from the model (``nao_model``), as the real
        server's bodies have them."""
        n = pb.getNumJoints(body, physicsClientId=client)
        self.indices = list(range(n))
        dyn = [pb.getDynamicsInfo(body, k, physicsClientId=client) for k in range(-1, n)]
        infos = [pb.getJointInfo(body, j, physicsClientId=client) for j in range(n)]
        masses = np.array([d[0] for d in dyn], dtype=float)
        parts = {part.name: part for part in nao_model.body_parts(robot_type)}
        names = ["torso"] + [i[12].decode() for i in infos]
        principal = np.array([nao_model.inertia_diagonal(parts[name]) for name in names], dtype=float)
        #: each hinge's upper limit (rad): which side of its range a hinge outside it is on
        self.upper = nao_model.joint_limits(robot_type)[1]
        parents = np.zeros(n + 1, dtype=np.int64)
        joint_of = np.zeros(n + 1, dtype=np.int64)
        local_axes = np.array([i[13] for i in infos], dtype=float)
        chains = np.zeros((n + 1, n), dtype=np.bool_)
        for j, info in enumerate(infos):
            k = j + 1
            parent = info[16] + 1
            if parent >= k:
                raise ValueError("links must follow their parents")
            parents[k] = parent
            joint_of[k] = j
            chains[k] = chains[parent]
            chains[k, j] = True
        self.chains = chains
        #: the bodies as the kernels take them; the hinges' anchors are read from pybullet's exact
        #: joints where the bodies are first placed (``prepare``), none before
        no_anchors = np.zeros((0, 3))
        self.model = Model(masses, principal, parents, joint_of, local_axes, no_anchors, no_anchors)
        shapes = [d for k in range(-1, n) for d in pb.getCollisionShapeData(body, k, physicsClientId=client)]
        self.shape_body = np.array([d[1] + 1 for d in shapes], dtype=np.int64)
        self.shape_kind = np.array([d[2] for d in shapes], dtype=np.int64)
        self.shape_size = np.array([d[3] for d in shapes], dtype=float)
        if any(abs(x) > 1e-12 for d in shapes for x in d[5]) or set(self.shape_kind) - {BOX, SPHERE, CAPSULE}:
            raise ValueError("shapes must be boxes, spheres or capsules at their body's centre")
        # the stub finds the robot's ground contacts itself: Bullet need not
        for k in range(-1, n):
            pb.setCollisionFilterPair(ground, body, -1, k, 0, physicsClientId=client)

    def ground_contacts(self, state: State, max_points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(body, point, depth) of each contact of the robot's shapes, where ``state`` puts them,
        with the ground (``collision.ground_contacts``): a ``GroundContacts``' fields."""
        return ground_contacts(self.shape_body, self.shape_kind, self.shape_size, state.pos, state.quat, max_points)


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


class RobotPhysics:
    """All the step keeps of one robot: its model, its bodies' state (None until its first step)
    and the reduced state (torso pose and motion, hinge angles and rates) last measured from it
    (``written``), which row each hinge's motor held in the last step, and whether a beam or a
    trainer's move has put it elsewhere since (``moved``). The bodies' state is kept between
    steps: pybullet's exact joints cannot hold the joints' drift."""

    def __init__(self) -> None:
        self.model: RobotModel | None = None
        self.state: State | None = None
        self.written: np.ndarray | None = None
        self.motor_state: np.ndarray | None = None
        self.moved = False


class Prepared(NamedTuple):
    """A robot ready for its step: its bodies' state, the forces before the step (its drag one
    value for all its bodies), its motor rows."""

    state: State
    forces: Forces
    motors: Motors


def params_of(config) -> Params:
    """The step's numbers from the physics settings, as the kernels take them."""
    return Params(
        config.cycle,
        config.ode_joint_erp,
        config.global_cfm,
        MOTOR_CFM,
        config.contact_slop,
        config.ode_gyroscopic == "implicit",
        config.contact_erp,
        config.contact_cfm,
        config.slip,
    )


def solve_prepared(robot, physics: RobotPhysics, prep: Prepared, ground: int, config, params: Params) -> Solved:
    """The maximal step of a prepared robot against the ground alone (``params``: ``params_of(config)``)."""
    static = physics.model
    assert static is not None  # read before ``prepare``
    contacts = static.ground_contacts(prep.state, config.ode_box_points)  # a plain tuple already
    pos, quat, vel, spin, forces, tangents, torques, iterations = step_tree(
        tuple(static.model), tuple(prep.state), tuple(prep.forces), contacts, tuple(prep.motors), tuple(params)
    )
    parts, points, depths = contacts
    solved = partial(ground_tuples, robot.body_id, ground, parts, points, depths, forces, tangents)
    return finish_maximal(robot, physics, pos, quat, vel, spin, solved, torques, iterations)


def ground_tuples(body: int, ground: int, parts, points, depths, forces, tangents) -> tuple:
    """A robot's ground contacts in pybullet's tuple layout (``contact.point``), with their solved
    forces."""
    return tuple(
        contact.point(body, ground, k - 1, -1, p, (p[0], p[1], 0.0), (0.0, 0.0, 1.0), -d, f, t)
        for k, p, d, f, t in zip(parts.tolist(), points.tolist(), depths.tolist(), forces.tolist(), tangents.tolist())
    )


def prepare(robot, physics: RobotPhysics, model: RobotModel, config, gravity: np.ndarray) -> Prepared:
    """Make ``robot``'s bodies ready for this step and its motor rows: placed from pybullet before
    its first step, moved rigidly with the torso after a beam or a trainer's move (``moved``).
    ``gravity``: the world's, one array for every robot and step (the kernels only read it)."""
    state = physics.state
    moved, physics.moved = physics.moved, False
    if state is not None and not moved:
        # nothing but the step has moved the robot: the bodies go on from their own state
        return _prepared(robot, physics, model, state, state.vel, state.spin, robot.joint_state()[0], config, gravity)
    robot.sync()
    angles, rates = robot.joint_state()
    position, orientation = robot.stored_pose()
    if state is not None and moved:
        # a beam or a trainer's move: SimSpark moves every body rigidly with the torso (keeping
        # the joints' drift) and stops them all (SoccerBase::MoveAndRotateAgent). The torso's
        # DragController ran before the BeamEffector in that cycle's PrePhysicsUpdate (children
        # first, the torso's body before the effectors in nao_hetero.rsg), so its drag in the
        # next step is the one of its velocity before the beam; every other body's comes after.
        written = physics.written
        assert written is not None  # set by every step
        kinematics.move_rigidly(
            state.pos, state.quat, written[0:3], written[3:7], np.array(position), np.array(orientation)
        )
        drag_vel = np.zeros_like(state.vel)
        drag_spin = np.zeros_like(state.spin)
        drag_vel[0] = state.vel[0]
        drag_spin[0] = state.spin[0]
        state.vel[:] = 0.0
        state.spin[:] = 0.0
        return _prepared(robot, physics, model, state, drag_vel, drag_spin, angles, config, gravity)
    # every body where pybullet's exact joints put it
    links = robot.link_frames()
    coms = np.array([position] + [link[0] for link in links], dtype=float)
    quats = np.array([orientation] + [link[1] for link in links], dtype=float)
    anchors = np.array([link[4] for link in links], dtype=float)
    velocity, spin = robot.stored_motion()
    tree = model.model
    vel, spin = kinematics.body_velocities(
        tree.parents,
        tree.joint_of,
        tree.local_axes,
        coms,
        quats,
        anchors,
        np.array(velocity, dtype=float),
        np.array(spin, dtype=float),
        rates,
    )
    # the first placement: the hinges' anchors in their bodies, for good
    child, parent = kinematics.local_anchors(tree.parents, tree.joint_of, coms, quats, anchors)
    model.model = tree._replace(anchor_child=child, anchor_parent=parent)
    state = physics.state = State(coms, quats, vel, spin)
    return _prepared(robot, physics, model, state, state.vel, state.spin, angles, config, gravity)


def _prepared(
    robot,
    physics: RobotPhysics,
    model: RobotModel,
    state: State,
    drag_vel: np.ndarray,
    drag_spin: np.ndarray,
    angles: np.ndarray,
    config,
    gravity: np.ndarray,
) -> Prepared:
    """A robot's prepared step: its bodies' state, the forces (its drag acting on ``drag_vel``
    and ``drag_spin``), its motor rows."""
    target, force, sticky = robot.motor_commands()
    nj = angles.shape[0]
    if target.shape[0] != nj:
        target = np.zeros(nj)
        force = np.full(nj, config.motor_torque)
    if physics.motor_state is None:
        physics.motor_state = np.zeros(nj, dtype=np.int64)
    lo, hi, push = motor_rows(
        angles, model.upper, np.asarray(force, dtype=float), sticky, config.motor_torque, FUDGE_FACTOR
    )
    return Prepared(
        state,
        Forces(gravity, config.linear_damping, config.angular_damping, drag_vel, drag_spin),
        Motors(np.asarray(target, dtype=float), lo, hi, push, physics.motor_state),
    )


def finish_maximal(robot, physics: RobotPhysics, pos, quat, vel, spin, contacts, torques, iterations) -> Solved:
    """Keep a robot's solved bodies and measure what pybullet gets: torso state, hinge angles and
    rates as the real server reads them."""
    physics.state = State(pos, quat, vel, spin)
    static = physics.model
    assert static is not None  # read before its first step
    tree = static.model
    written = kinematics.measured_state(pos, quat, vel, spin, tree.parents, tree.joint_of, tree.local_axes)
    physics.written = written
    nj = tree.local_axes.shape[0]
    torso = written[:13].tolist()  # one conversion, not four: the same floats
    return Solved(
        torso[0:3],
        torso[3:7],
        torso[7:10],
        torso[10:13],
        written[13 : 13 + nj],
        written[13 + nj :],
        contacts,
        torques,
        iterations,
    )


def apply(robot, solved: Solved) -> None:
    """Hand a solved step to the robot (``Robot.hold``); it goes into pybullet when pybullet is
    next asked about the robot (``Robot.keep_unwritten``)."""
    robot.keep_unwritten(
        tuple(solved.position), tuple(solved.orientation), solved.velocity, solved.spin, solved.angles, solved.rates
    )
    robot.hold(solved.angles, solved.rates, tuple(solved.velocity), tuple(solved.spin), solved.contacts)


def warm_up() -> None:
    """Compile (or load from numba's disk cache) the step's kernels on a two-body problem with one
    contact."""
    motor_rows(np.zeros(22), np.ones(22), np.full(22, 10.0), np.zeros(22), 10.0, FUDGE_FACTOR)
    ground_contacts(
        np.array([0, 0, 0], dtype=np.int64),
        np.array([BOX, SPHERE, CAPSULE], dtype=np.int64),
        np.array([[0.1, 0.1, 0.1], [0.1, 0.1, 0.1], [0.1, 0.02, 0.0]]),
        np.array([[0.0, 0.0, 0.05]]),
        np.array([[0.0, 0.0, 0.0, 1.0]]),
        MAX_POINTS,
    )
    two = (np.array([0, 0], dtype=np.int64), np.array([0, 0], dtype=np.int64))
    axes = np.array([[1.0, 0.0, 0.0]])
    centres = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.05]])
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    anchors = np.array([[0.0, 0.0, 0.1]])
    vel, spin = kinematics.body_velocities(*two, axes, centres, quats, anchors, np.zeros(3), np.zeros(3), np.ones(1))
    child, parent = kinematics.local_anchors(*two, centres, quats, anchors)
    # the step before the kernels it does not call: on a cold cache it meets the solver's kernels
    # sooner, while a helper compiles them from the other end (``server_stub.kernels``)
    bundles = (
        Model(np.ones(2), np.full((2, 3), 0.01), *two, axes, child, parent),
        State(centres, quats, vel, spin),
        Forces(np.array([0.0, 0.0, -9.81]), 0.01, 0.01, vel, spin),
        GroundContacts(np.array([1], dtype=np.int64), np.array([[0.0, 0.0, 0.0]]), np.array([0.002])),
        Motors(np.zeros(1), np.full(1, -10.0), np.full(1, 10.0), np.zeros(1), np.zeros(1, dtype=np.int64)),
        Params(0.02, 0.2, 1e-5, MOTOR_CFM, 0.001, True, 0.4, 1e-4, 0.005),
    )
    step_tree(*(tuple(bundle) for bundle in bundles))
    written = kinematics.measured_state(centres, quats, vel, spin, *two, axes)
    # a beam's rigid move (``prepare``), with the argument types it is given there: compiled at a
    # game's first beam it would stall that cycle by seconds on a fresh clone
    kinematics.move_rigidly(
        centres.copy(), quats.copy(), written[0:3], written[3:7], np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])
    )
