"""One robot's part of the stand-in's ODE step: what the step keeps of it, its motor rows, and its
step against the ground alone.

The real server (ODE 0.16, one exact ``dWorldStep`` of 0.02 s per cycle; facts in
docs/robot_and_server.md sections 3-4) solves contacts, friction with force-dependent slip and no
Coulomb limit, and the hinge motors in one linear complementarity problem. The stand-in does the
same in maximal coordinates (``tree_step``): every body integrated on its own, the hinges held by
ODE's joint rows with the world ERP 0.2 and CFM 1e-5, so their anchor copies drift apart by
millimetres as on the real server.

Kept per robot (``RobotPhysics``, owned by ``stepper.Stepper``): what never changes (``RobotModel``:
the kernels' ``Model`` of its bodies, its shapes and joint limits), and its lane (``lanes``): its
row of its type's ``LaneGroup``, which holds its bodies' ``State`` (placed from pybullet's exact
joints before the first step, moved rigidly by a beam or a trainer's move), as MuJoCo's model and
data. Each cycle ``place`` makes its bodies ready; the robots touching nothing but the ground are
stepped in one call per type (``load_commands``, ``LaneGroup.step``, ``finish_lane``); robots
touching each other, the ball or the field's boxes are solved as one island (``prepared`` makes
their motor rows; ``stepper``, ``island_step``). ``ground_tuples`` gives a robot's contacts in
pybullet's tuple layout, with their solved forces, for the foot sensors.

Every body has SimSpark's drag (docs/robot_and_server.md section 2): a force -0.01 v at its centre
and a torque -0.01 w, added before the step as its DragController does.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import NamedTuple

import numpy as np
import pybullet as pb

from server_stub.config import PhysicsConfig
from server_stub.physics import bodies as kinematics
from server_stub.physics import contact, nao_model
from server_stub.physics.bundles import Forces, Model, Motors, Params, State
from server_stub.physics.collision import BOX, CAPSULE, SPHERE, ground_contacts
from server_stub.physics.lanes import LaneGroup, LaneModel
from server_stub.physics.rows import FUDGE_FACTOR, MOTOR_CFM, motor_rows

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
        #: joints where the bodies are first placed (``place``), none before
        no_anchors = np.zeros((0, 3))
        self.model = Model(masses, principal, parents, joint_of, local_axes, no_anchors, no_anchors)
        shapes = [d for k in range(-1, n) for d in pb.getCollisionShapeData(body, k, physicsClientId=client)]
        self.shape_body = np.array([d[1] + 1 for d in shapes], dtype=np.int64)
        self.shape_kind = np.array([d[2] for d in shapes], dtype=np.int64)
        self.shape_size = np.array([d[3] for d in shapes], dtype=float)
        #: what the type's lanes share (``lanes.LaneModel``)
        self.lane_model = LaneModel(
            masses,
            principal,
            parents,
            joint_of,
            local_axes,
            np.asarray(self.upper, dtype=float),
            self.shape_body,
            self.shape_kind,
            self.shape_size,
        )
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
    """All the step keeps of one robot: its model (read at its first step), its lane (``lanes``:
    its row of its type's ``LaneGroup``, which holds its bodies' state, what the last step measured
    of it and which row each hinge's motor held), whether its bodies have been placed, and whether
    a beam or a trainer's move has put it elsewhere since its last step (``moved``). The bodies'
    state is kept between steps: pybullet's exact joints cannot hold the joints' drift."""

    def __init__(self) -> None:
        self.model: RobotModel | None = None
        self.group: LaneGroup | None = None
        self.row = -1
        self.placed = False
        self.moved = False

    @property
    def state(self) -> State | None:
        """Its bodies' state (views of its lane's rows), None before its first step."""
        if not self.placed:
            return None
        assert self.group is not None  # given a lane before its bodies are placed
        return self.group.state(self.row)

    @property
    def written(self) -> np.ndarray | None:
        """What its last step measured of the torso and the hinges (``bodies.measured_state``)."""
        return None if self.group is None else self.group.written[self.row]

    def positions(self) -> np.ndarray:
        """Its bodies' centres (a view of its lane's row)."""
        assert self.group is not None
        return self.group.pos[self.row]

    def keep(self, pos: np.ndarray, quat: np.ndarray, vel: np.ndarray, spin: np.ndarray) -> None:
        """Its bodies' new state, into its lane's rows."""
        group = self.group
        assert group is not None
        row = self.row
        group.pos[row] = pos
        group.quat[row] = quat
        group.vel[row] = vel
        group.spin[row] = spin
        self.placed = True


class Prepared(NamedTuple):
    """A robot ready for its step in an island: its bodies' state, the forces before the step (its
    drag one value for all its bodies), its motor rows."""

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


def ground_tuples(body: int, ground: int, parts, points, depths, forces, tangents) -> tuple:
    """A robot's ground contacts in pybullet's tuple layout (``contact.point``), with their solved
    forces."""
    return tuple(
        contact.point(body, ground, k - 1, -1, p, (p[0], p[1], 0.0), (0.0, 0.0, 1.0), -d, f, t)
        for k, p, d, f, t in zip(parts.tolist(), points.tolist(), depths.tolist(), forces.tolist(), tangents.tolist())
    )


def place(robot, physics: RobotPhysics) -> None:
    """Make ``robot``'s bodies ready for this step: placed from pybullet before its first step,
    moved rigidly with the torso after a beam or a trainer's move (``moved``); else they go on
    from their own state. Its lane's ``beamed`` says whether its drag acts on the velocities
    before a beam (its ``drag_vel`` / ``drag_spin`` rows) this step."""
    group = physics.group
    assert group is not None  # given a lane with its model, at its first step
    row = physics.row
    group.beamed[row] = False
    state = physics.state
    moved, physics.moved = physics.moved, False
    if state is not None and not moved:
        return
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
        group.drag_vel[row] = 0.0
        group.drag_spin[row] = 0.0
        group.drag_vel[row, 0] = state.vel[0]
        group.drag_spin[row, 0] = state.spin[0]
        group.beamed[row] = True
        state.vel[:] = 0.0
        state.spin[:] = 0.0
        return
    # every body where pybullet's exact joints put it
    model = physics.model
    assert model is not None
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
    group.anchor_child[row] = child
    group.anchor_parent[row] = parent
    physics.keep(coms, quats, vel, spin)


def _commands(robot, config, nj: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """This step's motor targets and forces and the sticky target speeds (``Robot.motor_commands``);
    before the robot's first step, targets 0 at the full torque."""
    target, force, sticky = robot.motor_commands()
    if target.shape[0] != nj:
        return np.zeros(nj), np.full(nj, config.motor_torque), sticky
    return target, force, sticky


def load_commands(robot, physics: RobotPhysics, config) -> None:
    """A placed robot's hinge angles and motor commands into its lane, for ``LaneGroup.step``."""
    group = physics.group
    assert group is not None
    row = physics.row
    angles = robot.joint_state()[0]
    target, force, sticky = _commands(robot, config, angles.shape[0])
    group.angles[row] = angles
    group.target[row] = target
    group.force[row] = force
    group.sticky[row] = sticky


def prepared(robot, physics: RobotPhysics, config, gravity: np.ndarray) -> Prepared:
    """A placed robot's step as an island takes it: its bodies' state, the forces (its drag acting
    on its bodies' velocities, or on those before a beam), its motor rows (``gravity``: the
    world's, one array for every robot and step; the kernels only read it)."""
    group, state, model = physics.group, physics.state, physics.model
    assert group is not None and state is not None and model is not None
    row = physics.row
    if group.beamed[row]:
        drag_vel, drag_spin = group.drag_vel[row], group.drag_spin[row]
    else:
        drag_vel, drag_spin = state.vel, state.spin
    angles = robot.joint_state()[0]
    target, force, sticky = _commands(robot, config, angles.shape[0])
    lo, hi, push = motor_rows(
        angles, model.upper, np.asarray(force, dtype=float), sticky, config.motor_torque, FUDGE_FACTOR
    )
    return Prepared(
        state,
        Forces(gravity, config.linear_damping, config.angular_damping, drag_vel, drag_spin),
        Motors(np.asarray(target, dtype=float), lo, hi, push, group.motor_state[row]),
    )


def finish_lane(robot, physics: RobotPhysics, ground: int) -> Solved:
    """A lone robot's step (``LaneGroup.step``) as the robot takes it: what the step measured, and
    its ground contacts with their solved forces (made from its lane's rows when a sensor asks,
    before its next step)."""
    group = physics.group
    assert group is not None
    row = physics.row
    n = int(group.contact_count[row])
    contacts = partial(
        ground_tuples,
        robot.body_id,
        ground,
        group.contact_body[row, :n],
        group.contact_point[row, :n],
        group.contact_depth[row, :n],
        group.contact_force[row, :n],
        group.contact_tangent[row, :n],
    )
    return _solved(group.written[row].copy(), contacts, group.torques[row].copy(), int(group.iterations[row]))


def finish_maximal(robot, physics: RobotPhysics, pos, quat, vel, spin, contacts, torques, iterations) -> Solved:
    """Keep a robot's solved bodies (an island's) and measure what pybullet gets: torso state, hinge
    angles and rates as the real server reads them."""
    physics.keep(pos, quat, vel, spin)
    static, group = physics.model, physics.group
    assert static is not None and group is not None  # read before its first step
    tree = static.model
    written = kinematics.measured_state(pos, quat, vel, spin, tree.parents, tree.joint_of, tree.local_axes)
    group.written[physics.row] = written
    return _solved(written, contacts, torques, iterations)


def _solved(written: np.ndarray, contacts, torques: np.ndarray, iterations: int) -> Solved:
    """A step's ``Solved`` from what it measured (``bodies.measured_state``'s layout)."""
    nj = (written.shape[0] - 13) // 2
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
    # sooner, while a helper compiles them from the other end (``server_stub.kernels``); a lane of
    # two bodies, a ball under the second touching the ground
    model = LaneModel(
        np.ones(2),
        np.full((2, 3), 0.01),
        *two,
        axes,
        np.ones(1),
        np.array([1], dtype=np.int64),
        np.array([SPHERE], dtype=np.int64),
        np.full((1, 3), 0.1),
    )
    group = LaneGroup(model, MAX_POINTS)
    row = group.add()
    group.pos[row], group.quat[row], group.vel[row], group.spin[row] = centres, quats, vel, spin
    group.anchor_child[row], group.anchor_parent[row] = child, parent
    group.force[row] = 10.0
    params = Params(0.02, 0.2, 1e-5, MOTOR_CFM, 0.001, True, 0.4, 1e-4, 0.005)
    config = PhysicsConfig(ode_box_points=MAX_POINTS)
    group.step(np.array([row], dtype=np.int64), np.array([0.0, 0.0, -9.81]), config, tuple(params))
    written = kinematics.measured_state(centres, quats, vel, spin, *two, axes)
    # a beam's rigid move (``place``), with the argument types it is given there: compiled at a
    # game's first beam it would stall that cycle by seconds on a fresh clone
    kinematics.move_rigidly(
        centres.copy(), quats.copy(), written[0:3], written[3:7], np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])
    )
