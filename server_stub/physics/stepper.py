"""The per-cycle step of the whole world (``Stepper``): it keeps what the step knows of every robot and
the ball, finds the contacts besides the ground (robot-robot, robot-ball, robot-goal/border and
ball-goal/border) as SimSpark and ODE make them, groups touching bodies into islands and solves
each: a robot alone on the ground by ``robot_step``, an island by ``island_step``.

Facts (SimSpark's odecontactjointhandler.cpp, contactjointhandler.cpp, collider.cpp, space.cpp,
odespace.cpp; rsg/agent/nao/contactjointhandler.rsg, nao_hetero.rsg, ball.rsg, soccer.rsg,
goal.rsg; each value's source is in ``PhysicsConfig``):

- which pairs collide: any two colliders in different spaces (each robot has its own space with
  inner collision disabled, so its own parts never touch each other); the goal's sensor box has
  no contact handler and makes no contacts; the goals' side boxes, back walls and top plates and
  the four border walls do (a default handler is added to a collider without one);
- a pair makes up to 4 contact points (``dCollide`` asked for 4), each one contact joint whose
  surface is the two colliders' surfaces combined (``surface``);
- ODE groups bodies connected by joints or contacts into islands and solves each in one LCP.

Here the contacts are found by Bullet's collision pass on the bodies pybullet holds (the robots
as the last step wrote them, the ball, the static boxes of SimSpark's field); Bullet's manifold
keeps up to 4 points a pair of shapes, and only touching or overlapping points are taken (ODE's
colliders make no others). A robot's point is carried from its pybullet link into its own
maximal body (which may have drifted off the exact joints by millimetres) by the link's pose.
Two robots beamed into each other make hundreds of points: at most ``MAX_PAIR_POINTS`` a pair of
robots are kept, the deepest (a departure from ODE for such pile-ups only).
Robots (and the ball) joined by contacts are one island, solved by ``island_step.step_island``;
a robot that touches nothing but the ground takes ``robot_step``'s per-robot path unchanged.
Robot-ground contacts are the per-robot path's own (``collision.ground_contacts``); the ball's
ground contact is ODE's sphere-plane one (the lowest point, depth radius - height).

A beam or a trainer's move is told to the stepper (``moved``, by ``Robot.on_move``) and the
robot's bodies follow it rigidly; the ball's placement likewise (``ball_moved``).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from functools import partial

import numpy as np
import pybullet as pb

from server_stub import field
from server_stub.physics import collision, contact, island_step, robot_step
from server_stub.physics.bundles import Contacts, Forces, IslandSolve, Model, Motors, PairContacts, State
from server_stub.physics.lanes import LaneGroup
from server_stub.physics.robot import Robot
from server_stub.physics.rows import Surfaces

#: Most contact points between two robots (or a robot and the ball) in one step, the deepest
#: kept. ODE has no such limit (4 a pair of shapes, 529 pairs of shapes between two NAOs), but two
#: robots beamed into each other make hundreds (4 robots on one spot: 1600 rows, 15-165 s for the
#: first step); robots bumping into each other make 1-20.
MAX_PAIR_POINTS = 32
#: ODE's auto-disable, on in SimSpark (spark.rb: setAutoDisableFlag true) with ODE 0.16's
#: defaults (dWorldCreate: 10 idle steps, no idle time, 1 sample, thresholds 0.01^2 on |v|^2 and
#: |w|^2), applied to the ball only: a ball resting that long is no longer stepped (nor costs a
#: solve) until a robot touches it (ODE enables a disabled body joined to an enabled one) or the
#: trainer or the referee moves it (trainercommandparser.cpp, soccerruleaspect.cpp: Enable()).
BALL_IDLE_STEPS = 10
BALL_IDLE_SPEED = 0.01
#: How far any point of a robot's shapes lies from the centre of its body (m), at most, and then
#: some: a NAO part's shape reaches 0.12 m from its centre at most (the torso box's corners), and
#: Bullet's collision margins add a few centimetres. Things farther apart cannot touch.
_REACH = 0.25
#: Most lone-ball steps remembered (``Stepper._step_lone_ball``); a walk's settling ball needs 43.
_LONE_BALL_MEMORY = 4096


def _joined(ground_contacts: Callable[[], tuple], others: tuple) -> tuple:
    """A robot's ground contacts (made now) and its other ones, as ``Robot.contact_points`` has them."""
    return ground_contacts() + others


def _rotation(q) -> np.ndarray:
    return np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)


class _Frames:
    """Contacts Bullet found on pybullet's links, carried onto the island's own bodies (which may
    have drifted off the exact joints by millimetres): a point is rotated back into its link's
    frame and out of its body's, from the link's centre to the body's; a direction only rotated.
    The ball's points are its own. Each link's frames are read from pybullet once, when a contact
    first needs them; all the points go through one stacked product, which has the same operands
    and layouts, hence the same bits, as a product a point."""

    def __init__(self, state: State, members: list[tuple[Robot | None, int, int]]) -> None:
        """``members``: each member's robot (None: the ball), first body and number of bodies."""
        n = state.pos.shape[0]
        self.state = state
        self.robot_body = np.zeros(n, dtype=bool)
        self._link: list[tuple[Robot, int] | None] = [None] * n
        for robot, first, count in members:
            if robot is not None:
                self.robot_body[first : first + count] = True
                self._link[first : first + count] = [(robot, link) for link in range(-1, count - 1)]
        self._known = np.zeros(n, dtype=bool)
        self._centres = np.zeros((n, 3))
        self._rotations = np.zeros((n, 3, 3))
        self._body_rotations = np.zeros((n, 3, 3))

    def carry(self, bodies: np.ndarray, vectors: np.ndarray, points: bool) -> np.ndarray:
        """``vectors`` (world points if ``points``, else directions; one a row, on the link of
        body ``bodies[i]``) where they are on the island's bodies."""
        on_robot = self.robot_body[bodies]
        if on_robot.all():
            return self._turn(bodies, vectors, points)
        out = vectors.copy()
        rows = np.flatnonzero(on_robot)
        if rows.size:
            out[rows] = self._turn(bodies[rows], vectors[rows], points)
        return out

    def _turn(self, bodies: np.ndarray, vectors: np.ndarray, points: bool) -> np.ndarray:
        if not self._known[bodies].all():
            for k in set(bodies[~self._known[bodies]].tolist()):
                robot, link = self._link[k]
                centre, quat = robot.link_frame(link)
                self._centres[k] = centre
                self._rotations[k] = _rotation(quat)
                self._body_rotations[k] = _rotation(self.state.quat[k])
                self._known[k] = True
        # a C-ordered stack turned round by a view: a copied transpose changes the bits
        to_link = self._rotations[bodies].transpose(0, 2, 1)
        to_world = self._body_rotations[bodies]
        if not points:
            return np.matmul(to_world, np.matmul(to_link, vectors[:, :, None]))[:, :, 0]
        local = np.matmul(to_link, (vectors - self._centres[bodies])[:, :, None])
        return self.state.pos[bodies] + np.matmul(to_world, local)[:, :, 0]


class _Island:
    """One island being solved: its members (robot indices, the ball's is the number of robots),
    where each member's bodies and hinges start in the island's arrays, where its ground contacts
    start among the one-body contacts and how many goal/wall contacts follow them, and the members
    and links of each two-body contact."""

    def __init__(self, group: list[int], robots: int) -> None:
        self.group = group
        self._robots = robots
        self.offsets: dict[int, int] = {}
        self.joint_offsets: dict[int, int] = {}
        self.ground: dict[int, tuple[int, np.ndarray, np.ndarray, np.ndarray]] = {}
        self.static_count: dict[int, int] = {}
        self.pairs: list[tuple[int, int, int, int]] = []

    def is_robot(self, member: int) -> bool:
        return member < self._robots


def _ball_on_ground(position) -> list[tuple[np.ndarray, float]]:
    """The ball's contact with the ground at ``position``, ODE's sphere-plane one: its lowest point
    and the depth radius - height, if it touches (a list of none or one)."""
    centre = np.array(position)
    depth = field.BALL_RADIUS - centre[2]
    if not depth >= 0.0:
        return []
    return [(centre - np.array([0.0, 0.0, field.BALL_RADIUS]), depth)]


def _rows(values: list, width: int) -> np.ndarray:
    """A list of points, normals or surfaces as an (n, width) array (n may be 0)."""
    return np.array(values, dtype=float).reshape(-1, width)


class Stepper:
    """The maximal step of a whole world, contacts between its robots, ball and field included."""

    def __init__(self, config, client: int, ground: int, ball: int, static: int) -> None:
        self.config = config
        self.client = client
        self.ground = ground
        self.ball = ball
        self.static = static
        self.surfaces = Surfaces(config)
        self.params = robot_step.params_of(config)
        self.island_solve = IslandSolve(config.island_exact_rows, config.island_sweeps, config.island_tolerance)
        r = field.BALL_RADIUS
        self.ball_mass = field.BALL_MASS
        self.ball_inertia = 0.4 * field.BALL_MASS * r * r
        self.gravity = np.array([0.0, 0.0, config.gravity])
        #: the ball's model and drag in an island's columns (``_gather_bodies``): the same every step
        self._ball_columns = (
            np.array([self.ball_mass]),
            np.full((1, 3), self.ball_inertia),
            np.array([-1], dtype=np.int64),
            np.array([0], dtype=np.int64),
            np.zeros((0, 3)),
            np.zeros((0, 3)),
            np.zeros((0, 3)),
            np.array([config.ode_ball_drag_linear]),
            np.array([config.ode_ball_drag_angular]),
        )
        #: an island's two-body contacts when it has none (most islands: a lone ball settling after
        #: the trainer placed it), made once (empty, never written)
        self._no_pairs = PairContacts(
            np.zeros(0, dtype=np.int64),
            np.zeros(0, dtype=np.int64),
            np.zeros((0, 3)),
            np.zeros((0, 3)),
            np.zeros(0),
            np.zeros((0, 5)),
        )
        pb.setCollisionFilterPair(ground, ball, -1, -1, 0, physicsClientId=client)
        self._ball_written: tuple | None = None
        self._ball_moved = False
        self._ball_asleep = False
        self._ball_steps_left = BALL_IDLE_STEPS
        boxes = collision.static_boxes()
        self._static_lo = np.array([np.subtract(centre, half) for half, centre in boxes])
        self._static_hi = np.array([np.add(centre, half) for half, centre in boxes])
        #: what the step keeps of each robot on the field
        self._robots: dict[Robot, robot_step.RobotPhysics] = {}
        #: each robot type's lanes: its robots' bodies as rows (``lanes``)
        self._lanes: dict[int, LaneGroup] = {}
        self._param_tuple = tuple(self.params)
        #: ``_far_apart``'s owners of a lone robot's bodies (all 0), made once (never written)
        self._one_owner = np.zeros(0, dtype=np.int64)
        #: a lone ball's step by the exact bits of its state before (``_step_lone_ball``)
        self._lone_ball_steps: dict[bytes, tuple[np.ndarray, ...]] = {}

    def add(self, robot: Robot) -> None:
        """A new robot on the field (its model is read, and its lane given, at its first step)."""
        self._robots[robot] = robot_step.RobotPhysics()

    def forget(self, robot: Robot) -> None:
        """``robot`` has left the field: its lane is free."""
        physics = self._robots.pop(robot)
        if physics.group is not None:
            physics.group.remove(physics.row)

    def moved(self, robot: Robot) -> None:
        """A beam or a trainer's move has put ``robot`` elsewhere (``Robot.on_move``): its bodies
        follow rigidly at the next step."""
        self._robots[robot].moved = True

    def physics_of(self, robot: Robot) -> robot_step.RobotPhysics:
        """What this step keeps of ``robot``."""
        return self._robots[robot]

    def _model(self, robot: Robot) -> robot_step.RobotModel:
        """``robot``'s model, read at its first step, not when it was added: reading it sets the
        robot's ground filter in Bullet, whose later contacts depend on when that happens."""
        physics = self._robots[robot]
        if physics.model is None:
            model = physics.model = robot_step.RobotModel(self.client, robot.body_id, self.ground, robot.robot_type)
            group = self._lanes.get(robot.robot_type)
            if group is None:
                group = self._lanes[robot.robot_type] = LaneGroup(model.lane_model, self.config.ode_box_points)
            elif not group.matches(model.lane_model):
                raise ValueError(f"a robot of type {robot.robot_type} unlike the type's others")
            physics.group = group
            physics.row = group.add()
        return physics.model

    def step(self, robots) -> None:
        """One cycle of every robot and the ball. The ball's new state goes into pybullet at once,
        each robot's when pybullet is next asked about it (``Robot.keep_unwritten``)."""
        cfg = self.config
        c = self.client
        statics = [self._model(robot) for robot in robots]
        physics = [self._robots[robot] for robot in robots]
        for robot, kept in zip(robots, physics):
            robot_step.place(robot, kept)
        # each robot's and the ball's contacts with the field's boxes (pybullet's tuples)
        on_boxes: list[list] = [[] for _ in range(len(robots) + 1)]
        by_body = {robot.body_id: i for i, robot in enumerate(robots)}
        by_body[self.ball] = len(robots)
        # the ball's state; placed by the trainer or the referee since the last step, SimSpark
        # enables its body (trainercommandparser.cpp, soccerruleaspect.cpp: Enable())
        placed = self._ball_moved or self._ball_written is None
        ball_now = self.ball_now()
        self._ball_moved = False
        touching = []
        if not self._far_apart([kept.positions() for kept in physics], ball_now[0]):
            for robot in robots:
                robot.sync()
            pb.performCollisionDetection(physicsClientId=c)
            touching = [pt for pt in pb.getContactPoints(physicsClientId=c) if pt[8] <= 0.0]
        if touching:
            groups, pairs = self._islands(touching, on_boxes, by_body)
        else:  # every robot and the ball on its own (the usual cycle of a lone walker)
            groups, pairs = [[i] for i in range(len(on_boxes))], []
        if placed:
            self._wake_ball()
        ball_index = len(robots)
        lone: list[int] = []
        islands: list[list[int]] = []
        for group in groups:
            if group == [ball_index] and self._ball_asleep:
                continue  # ODE's auto-disable: a resting ball is not stepped until touched or moved
            if ball_index in group and self._ball_asleep:
                self._wake_ball()  # touched by an enabled body
            if len(group) == 1 and not on_boxes[group[0]]:
                if group[0] == ball_index:
                    self._step_lone_ball(ball_now)
                else:
                    lone.append(group[0])
                continue
            islands.append(group)
        self._step_lanes([robots[i] for i in lone], [physics[i] for i in lone])
        preps: list[robot_step.Prepared | None] = [None] * len(robots)
        for group in islands:
            for i in group:
                if i < ball_index:
                    preps[i] = robot_step.prepared(robots[i], physics[i], cfg, self.gravity)
            self._solve_island(group, robots, statics, preps, on_boxes, pairs, ball_now, by_body)

    def _step_lanes(self, robots: list[Robot], physics: list[robot_step.RobotPhysics]) -> None:
        """The robots touching nothing but the ground, each type's in one call (``lanes``)."""
        cfg = self.config
        by_group: dict[LaneGroup, list[int]] = {}
        for index, (robot, kept) in enumerate(zip(robots, physics)):
            robot_step.load_commands(robot, kept, cfg)
            assert kept.group is not None  # given at its first step
            by_group.setdefault(kept.group, []).append(index)
        for group, members in by_group.items():
            rows = np.array([physics[i].row for i in members], dtype=np.int64)
            group.step(rows, self.gravity, cfg, self._param_tuple)
            for i in members:
                robot_step.apply(robots[i], robot_step.finish_lane(robots[i], physics[i], self.ground))

    def _far_apart(self, robot_bodies: list[np.ndarray], ball: tuple) -> bool:
        """Whether no two of the robots, the ball and the goals and walls can touch: their boxes
        (every body's centre, grown by ``_REACH``; the ball's, by its radius and as much) do not
        overlap (``collision.far_apart``). Then Bullet would find no touching point, so it is not
        asked (nor told where the robots are): the usual cycle of a lone walker."""
        if len(robot_bodies) == 1:
            pos = robot_bodies[0]
            owner = self._one_owner
            if owner.shape[0] != pos.shape[0]:
                owner = self._one_owner = np.zeros(pos.shape[0], dtype=np.int64)
        else:  # none (the ball alone) or several
            pos = np.concatenate(robot_bodies) if robot_bodies else np.zeros((0, 3))
            owner = np.repeat(np.arange(len(robot_bodies)), [p.shape[0] for p in robot_bodies]).astype(np.int64)
        return bool(
            collision.far_apart(
                pos,
                owner,
                len(robot_bodies),
                np.asarray(ball, dtype=float),
                _REACH,
                field.BALL_RADIUS + _REACH,
                self._static_lo,
                self._static_hi,
            )
        )

    def _islands(self, touching: list, on_boxes: list[list], by_body: dict) -> tuple[list[list[int]], list]:
        """The touching points sorted out: each one-body contact (a goal, a wall) to its robot's or
        the ball's ``on_boxes``, the two-body ones (at most ``MAX_PAIR_POINTS`` a pair, the
        deepest) returned, and the robots and the ball joined by them grouped into islands (in
        order of their first member)."""
        parent = list(range(len(on_boxes)))

        def find(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        per_pair: dict[tuple[int, int], list] = {}
        for pt in touching:
            a = by_body.get(pt[1], -1)
            b = by_body.get(pt[2], -1)
            if a < 0 and b < 0:
                continue
            if a >= 0 and b >= 0:
                per_pair.setdefault((a, b), []).append(pt)
                ra, rb = find(a), find(b)
                if ra != rb:
                    parent[ra] = rb
            elif pt[1] == self.static or pt[2] == self.static:
                on_boxes[max(a, b)].append(pt)
        pairs: list = []
        for points in per_pair.values():
            if len(points) > MAX_PAIR_POINTS:
                points = sorted(points, key=lambda pt: pt[8])[:MAX_PAIR_POINTS]
            pairs.extend(points)
        members: dict[int, list[int]] = {}
        for i in range(len(on_boxes)):
            members.setdefault(find(i), []).append(i)
        return list(members.values()), pairs

    def ball_moved(self) -> None:
        """Someone besides this stepper wrote the ball into pybullet (``World.set_ball``)."""
        self._ball_moved = True

    def ball_now(self) -> tuple:
        """The ball's (position, orientation, velocity, spin) as pybullet gives them: what this
        stepper last wrote and read back (nothing else changes it), unless ``ball_moved``; so the
        referee's several looks at the ball a cycle cost no pybullet call."""
        if self._ball_written is not None and not self._ball_moved:
            return self._ball_written
        c = self.client
        position, orientation = pb.getBasePositionAndOrientation(self.ball, physicsClientId=c)
        velocity, spin = pb.getBaseVelocity(self.ball, physicsClientId=c)
        return (position, orientation, velocity, spin)

    def _step_lone_ball(self, ball_now: tuple) -> None:
        """The ball touching nothing but the ground (every walk's ball settling after the trainer
        placed it). Such a step depends on the ball's state alone, and the trainer places the
        ball at the same spot at every walk from the same start, so each walk's settling repeats
        the last one's bit for bit: a step is remembered by the exact bits of the state it starts
        from. (Solving each settling again was a sixth of the time of a walk that falls within a
        second, most of a GA's first generations.)"""
        key = struct.pack("13d", *ball_now[0], *ball_now[1], *ball_now[2], *ball_now[3])
        stepped = self._lone_ball_steps.get(key)
        if stepped is None:
            stepped = self._lone_ball_step(ball_now)
            if len(self._lone_ball_steps) >= _LONE_BALL_MEMORY:
                self._lone_ball_steps.clear()
            self._lone_ball_steps[key] = stepped
        self._write_ball(*stepped)

    def _lone_ball_step(self, ball_now: tuple) -> tuple[np.ndarray, ...]:
        """A lone ball's island of one body stepped, the arrays made at once: the very arrays
        ``_solve_island`` gathers for it (same values, types and layouts, so the same bits)
        without its bookkeeping of members, frames and scattering. Returns its new position,
        quaternion, velocity and spin."""
        position, orientation, velocity, spin = ball_now
        mass, principal, parents, joint_of, axes, anchor_child, anchor_parent, drag_linear, drag_angular = (
            column.copy() for column in self._ball_columns
        )
        vel = np.array([velocity], dtype=float)
        rot = np.array([spin], dtype=float)
        model = Model(mass, principal, parents, joint_of, axes, anchor_child, anchor_parent)
        state = State(np.array([position], dtype=float), np.array([orientation], dtype=float), vel, rot)
        forces = Forces(self.gravity, drag_linear, drag_angular, vel.copy(), rot.copy())
        empty = np.zeros(0)
        motors = Motors(empty, empty, empty, empty, np.zeros(0, dtype=np.int64))
        ground = _ball_on_ground(position)
        n = len(ground)
        contacts = Contacts(
            np.zeros(n, dtype=np.int64),
            _rows([lowest for lowest, _ in ground], 3),
            _rows([(0.0, 0.0, 1.0)] * n, 3),
            np.array([depth for _, depth in ground], dtype=float).reshape(-1),
            _rows([self.surfaces.ball_ground] * n, 5),
        )
        out = island_step.step_island(
            model, state, forces, motors, contacts, self._no_pairs, self.params, self.island_solve
        )
        npos, nquat, nvel, nspin = out[:4]
        return npos[0], nquat[0], nvel[0], nspin[0]

    def _solve_island(self, group, robots, statics, preps, on_boxes, pairs, ball_now, by_body) -> None:
        """Robots and the ball touching each other (``group``), solved as one LCP: their bodies and
        contacts gathered into the island's arrays, stepped, and the results handed back."""
        island = _Island(group, len(robots))
        model, state, forces, motors = self._gather_bodies(island, statics, preps, ball_now)
        members = [(robots[i], statics[i].model.masses.shape[0]) if island.is_robot(i) else (None, 1) for i in group]
        frames = _Frames(state, [(robot, island.offsets[i], count) for i, (robot, count) in zip(group, members)])
        contacts = self._gather_contacts(island, statics, preps, on_boxes, ball_now, frames, by_body)
        pair_contacts = self._gather_pairs(island, pairs, frames, by_body)
        out = island_step.step_island(
            model, state, forces, motors, contacts, pair_contacts, self.params, self.island_solve
        )
        self._scatter(island, out, robots, statics, preps, motors, contacts, pair_contacts, by_body)

    def _gather_bodies(self, island: _Island, statics, preps, ball_now) -> tuple[Model, State, Forces, Motors]:
        """Every member's bodies in one forest (a robot's tree, its torso a root; the ball a tree of
        one), their state, their forces and the robots' motor rows."""
        cfg = self.config
        ball_state = tuple(np.array([x]) for x in ball_now)
        parts = []  # per member: its bodies, hinges, state, drag
        n = 0
        nj = 0
        for i in island.group:
            island.offsets[i] = n
            island.joint_offsets[i] = nj
            if island.is_robot(i):
                st, pr = statics[i].model, preps[i]
                b = pr.state
                nb = st.masses.shape[0]
                par = st.parents.copy() + n
                par[0] = -1
                parts.append(
                    (
                        st.masses,
                        st.principal,
                        par,
                        st.joint_of + nj,
                        st.local_axes,
                        st.anchor_child,
                        st.anchor_parent,
                        b.pos,
                        b.quat,
                        b.vel,
                        b.spin,
                        pr.forces.drag_vel,
                        pr.forces.drag_spin,
                        np.full(nb, cfg.linear_damping),
                        np.full(nb, cfg.angular_damping),
                    )
                )
                n += nb
                nj += st.local_axes.shape[0]
            else:
                pos, quat, vel, spin = ball_state
                model_columns, drag = self._ball_columns[:7], self._ball_columns[7:]
                parts.append((*model_columns, pos, quat, vel, spin, vel, spin, *drag))
                n += 1
        cols = [np.concatenate(x) for x in zip(*parts)]
        masses, principal, parents, joint_of, local_axes, anchor_child, anchor_parent = cols[:7]
        model = Model(
            masses,
            principal,
            parents.astype(np.int64),
            joint_of.astype(np.int64),
            local_axes,
            anchor_child,
            anchor_parent,
        )
        state = State(*cols[7:11])
        drag_vel, drag_spin, drag_linear, drag_angular = cols[11:]
        forces = Forces(self.gravity, drag_linear, drag_angular, drag_vel, drag_spin)
        robots = [i for i in island.group if island.is_robot(i)]
        empty = np.zeros(0)

        def joined(rows: list[np.ndarray]) -> np.ndarray:
            return np.concatenate(rows) if rows else empty

        motors = Motors(
            joined([preps[i].motors.target for i in robots]),
            joined([preps[i].motors.lo for i in robots]),
            joined([preps[i].motors.hi for i in robots]),
            joined([preps[i].motors.push for i in robots]),
            np.concatenate([preps[i].motors.state for i in robots]) if robots else np.zeros(0, dtype=np.int64),
        )
        return model, state, forces, motors

    def _gather_contacts(
        self, island: _Island, statics, preps, on_boxes, ball_now, frames: _Frames, by_body
    ) -> Contacts:
        """Every member's contacts with something static: its ground contacts first (a robot's as
        ``robot_step`` makes them, the ball's ODE's sphere-plane one), then goals and walls."""
        cfg = self.config
        body: list[int] = []
        point: list = []
        normal: list = []
        depth: list[float] = []
        surface: list = []
        s = self.surfaces
        for i in island.group:
            off = island.offsets[i]
            if island.is_robot(i):
                gp, gpt, gd = statics[i].ground_contacts(preps[i].state, cfg.ode_box_points)
                island.ground[i] = (len(body), gp, gpt, gd)
                for k, p, d in zip(gp.tolist(), gpt, gd.tolist()):
                    body.append(off + k)
                    point.append(p)
                    normal.append((0.0, 0.0, 1.0))
                    depth.append(d)
                    surface.append(s.robot_ground)
                surf = s.robot_static
            else:
                island.ground[i] = (len(body), np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros(0))
                for lowest, ball_depth in _ball_on_ground(ball_now[0]):
                    body.append(off)
                    point.append(lowest)
                    normal.append((0.0, 0.0, 1.0))
                    depth.append(ball_depth)
                    surface.append(s.ball_ground)
                surf = s.ball_static
            boxes = on_boxes[i]
            island.static_count[i] = len(boxes)
            if not boxes:
                continue
            robot = island.is_robot(i)
            links, mids, towards = [], [], []
            for pt in boxes:
                mine_a = by_body.get(pt[contact.BODY_A]) == i
                links.append(pt[contact.LINK_A] if mine_a else pt[contact.LINK_B])
                mids.append(0.5 * (np.asarray(pt[contact.POSITION_ON_A]) + np.asarray(pt[contact.POSITION_ON_B])))
                normal_on_b = np.asarray(pt[contact.NORMAL_ON_B])
                towards.append(normal_on_b if mine_a else -normal_on_b)
                depth.append(-pt[contact.DISTANCE])
                surface.append(surf)
            on = off + np.array(links, dtype=np.int64) + 1 if robot else np.full(len(links), off, dtype=np.int64)
            body.extend(on.tolist())
            point.extend(frames.carry(on, np.array(mids), points=True))
            normal.extend(frames.carry(on, np.array(towards), points=False))
        return Contacts(
            np.array(body, dtype=np.int64),
            _rows(point, 3),
            _rows(normal, 3),
            np.array(depth, dtype=float).reshape(-1),
            _rows(surface, 5),
        )

    def _gather_pairs(self, island: _Island, pairs, frames: _Frames, by_body) -> PairContacts:
        """The contacts between two members: each point carried from Bullet's links into the
        bodies, the normal from body 2 into body 1."""
        members = set(island.group)
        kept = [pt for pt in pairs if by_body[pt[contact.BODY_A]] in members]
        if not kept:
            island.pairs = []
            return self._no_pairs
        n = len(kept)
        fields = list(zip(*kept))
        a = [by_body[body] for body in fields[contact.BODY_A]]
        b = [by_body[body] for body in fields[contact.BODY_B]]
        island.pairs = list(zip(a, b, fields[contact.LINK_A], fields[contact.LINK_B]))

        def bodies(who: list[int], links: tuple) -> np.ndarray:
            return np.array(
                [island.offsets[m] + (link + 1 if island.is_robot(m) else 0) for m, link in zip(who, links)],
                dtype=np.int64,
            )

        body1, body2 = bodies(a, fields[contact.LINK_A]), bodies(b, fields[contact.LINK_B])
        on_a = np.array(fields[contact.POSITION_ON_A], dtype=float).reshape(n, 3)
        on_b = np.array(fields[contact.POSITION_ON_B], dtype=float).reshape(n, 3)
        # both bodies' points in one product
        carried = frames.carry(np.concatenate([body1, body2]), np.concatenate([on_a, on_b]), points=True)
        normal_on_b = np.array(fields[contact.NORMAL_ON_B], dtype=float).reshape(n, 3)
        s = self.surfaces
        surfaces = [s.robot_robot if island.is_robot(i) and island.is_robot(j) else s.robot_ball for i, j in zip(a, b)]
        return PairContacts(
            body1,
            body2,
            0.5 * (carried[:n] + carried[n:]),
            frames.carry(body2, normal_on_b, points=False),
            -np.array(fields[contact.DISTANCE], dtype=float),
            _rows(surfaces, 5),
        )

    def _scatter(
        self, island: _Island, out, robots, statics, preps, motors: Motors, contacts: Contacts, pairs, by_body
    ) -> None:
        """The solved island handed back: motor states and each robot's new state and contacts (in
        pybullet's tuple layout, ``contact.point``), and the ball's new state."""
        npos, nquat, nvel, nspin, forces, tangents, p_forces, p_tangents, torques, iterations = out
        for i in island.group:
            if island.is_robot(i):
                jo = island.joint_offsets[i]
                nj = statics[i].model.local_axes.shape[0]
                preps[i].motors.state[:] = motors.state[jo : jo + nj]
        extra: dict[int, list] = {i: [] for i in island.group}
        bodies = {i: body for body, i in by_body.items()}
        for i in island.group:
            if not island.is_robot(i):
                continue
            first, gp, _, _ = island.ground[i]
            ng = gp.shape[0]
            for ci in range(first + ng, first + ng + island.static_count[i]):
                k = int(contacts.body[ci]) - island.offsets[i]
                p = tuple(contacts.point[ci])
                extra[i].append(
                    contact.point(
                        robots[i].body_id,
                        self.static,
                        k - 1,
                        -1,
                        p,
                        p,
                        tuple(contacts.normal[ci]),
                        -contacts.depth[ci],
                        forces[ci],
                        tangents[ci],
                    )
                )
        # as lists of floats: the same numbers as the arrays' own, hundreds of points a pile
        points, normals = pairs.point.tolist(), pairs.normal.tolist()
        depths, solved, along = (-pairs.depth).tolist(), p_forces.tolist(), p_tangents.tolist()
        for (a, b, la, lb), p, towards, depth, f, t in zip(island.pairs, points, normals, depths, solved, along):
            p = tuple(p)
            if island.is_robot(a):
                extra[a].append(contact.point(robots[a].body_id, bodies[b], la, lb, p, p, tuple(towards), depth, f, t))
            if island.is_robot(b):
                away = tuple(-x for x in towards)
                extra[b].append(contact.point(robots[b].body_id, bodies[a], lb, la, p, p, away, depth, f, t, sign=-1.0))
        for i in island.group:
            off = island.offsets[i]
            if not island.is_robot(i):
                self._write_ball(npos[off], nquat[off], nvel[off], nspin[off])
                continue
            robot = robots[i]
            st = statics[i].model
            nb = st.masses.shape[0]
            first, gp, gpt, gd = island.ground[i]
            ng = gp.shape[0]
            ground = partial(
                robot_step.ground_tuples,
                robot.body_id,
                self.ground,
                gp,
                gpt,
                gd,
                forces[first : first + ng],
                tangents[first : first + ng],
            )
            jo = island.joint_offsets[i]
            solved = robot_step.finish_maximal(
                robot,
                self._robots[robot],
                npos[off : off + nb].copy(),
                nquat[off : off + nb].copy(),
                nvel[off : off + nb].copy(),
                nspin[off : off + nb].copy(),
                partial(_joined, ground, tuple(extra[i])),
                torques[jo : jo + st.local_axes.shape[0]].copy(),
                iterations,
            )
            robot_step.apply(robot, solved)

    def _wake_ball(self) -> None:
        self._ball_asleep = False
        self._ball_steps_left = BALL_IDLE_STEPS

    def _write_ball(self, pos, quat, vel, spin) -> None:
        """The ball's new state into pybullet, after ODE's auto-disable check (util.cpp,
        dInternalHandleAutoDisabling, one sample): ``BALL_IDLE_STEPS`` steps in a row with
        |v|^2 and |w|^2 under ``BALL_IDLE_SPEED``^2 and the body is disabled, its velocities zeroed."""
        if float(vel @ vel) > BALL_IDLE_SPEED**2 or float(spin @ spin) > BALL_IDLE_SPEED**2:
            self._ball_steps_left = BALL_IDLE_STEPS
        else:
            self._ball_steps_left -= 1
            if self._ball_steps_left <= 0:
                self._ball_asleep = True
                vel = np.zeros(3)
                spin = np.zeros(3)
        c = self.client
        pb.resetBasePositionAndOrientation(self.ball, pos.tolist(), quat.tolist(), physicsClientId=c)
        pb.resetBaseVelocity(self.ball, vel.tolist(), spin.tolist(), physicsClientId=c)
        p, q = pb.getBasePositionAndOrientation(self.ball, physicsClientId=c)
        v, w = pb.getBaseVelocity(self.ball, physicsClientId=c)
        self._ball_written = (p, q, v, w)
