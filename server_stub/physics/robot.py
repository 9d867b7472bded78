"""One simulated NAO inside a ``World``: the server's motor rules and the robot's sensors.

The motor rules follow docs/robot_and_server.md sections 3 ("How a velocity command is applied"):
clip to the speed cap, sticky, dropped while the joint is not strictly inside (min, max), applied
with the two-cycle action latency; a joint that starts a step outside its range is pushed back by
the stop (ERP 0.8, bounce 1) instead of being held at the limit, as ODE's limit rows do (the
per-joint rule is compiled in ``server_stub.physics.motors``). Sensors (section 5) are read lazily and
cached until the next step, so a caller pays only for what it asks.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import pybullet as pb

from protocol.nao import PerceptionLayout, joints_of, perception_layout
from server_stub import field
from server_stub.config import PhysicsConfig
from server_stub.physics import contact, motors, nao_model
from server_stub.physics.rotations import body_poses, read_back, stored_matrix

#: Half sizes of the torso box along its own axes (docs/robot_and_server.md section 2).
_TORSO_HALF_SIZE = np.array([0.05, 0.05, 0.09])
#: Torso height of a beamed robot (docs/robot_and_server.md section 6): the referee's agent radius.
BEAM_HEIGHT = field.AGENT_RADIUS
#: Force large enough to make the stop's velocity win against anything in one step.
_STOP_FORCE = 1e4


def _yaw_quaternion(heading_deg: float) -> tuple[float, float, float, float]:
    """Upright orientation facing world heading ``heading_deg`` (0 = +x). The model is built
    facing +y (heading 90), so the body turns by heading - 90 about z."""
    half = math.radians(heading_deg - 90.0) / 2.0
    return (0.0, 0.0, math.sin(half), math.cos(half))


class Robot:
    """A NAO body in a pybullet world. Created by ``World.add_robot``; ``World.step`` drives it."""

    def __init__(
        self,
        client: int,
        body: int,
        robot_type: int,
        config: PhysicsConfig,
        command_delay_steps: int = 1,
        on_move: Callable[[Robot], None] | None = None,
    ) -> None:
        """``on_move`` is told of every beam and trainer's move, after pybullet holds the new pose:
        the physics moves the robot's bodies with it (``stepper.Stepper.moved``)."""
        self.robot_type = robot_type
        self._on_move = on_move
        #: 1: a command acts in the step after the next (the real server's latency, for callers
        #: that step right after commanding); 0: in the next step, for a server that produces the
        #: latency itself by sending each perception one step late (``server_stub.net.server``).
        self._delay = command_delay_steps
        self._client = client
        self._body = body
        self._config = config
        joints = joints_of(robot_type)
        n = len(joints)
        #: the joints in index order (``protocol.nao.joints_of``): the 22, then a type's toes
        self._effector_index = {j.effector: i for i, j in enumerate(joints)}
        self._perceptors = tuple(j.perceptor for j in joints)
        #: where this type's joints and foot sensors sit in its perception message
        self.perception_layout: PerceptionLayout = perception_layout(robot_type)
        self._lower, self._upper = nao_model.joint_limits(robot_type)
        self._indices = list(range(n))
        self._caps = [float(c) for c in nao_model.speed_caps(robot_type)]
        self._caps_array = np.array(self._caps)
        self._neg_caps = -self._caps_array
        names = [pb.getJointInfo(body, i, physicsClientId=client)[12].decode() for i in self._indices]
        self._part_names = nao_model.part_names(robot_type)
        #: ``part_poses``' rows (torso, then pybullet's links) in ``part_names``' order; None
        #: when that is pybullet's order (every type without toes)
        order = [0] + [names.index(name) + 1 for name in self._part_names[1:]]
        self._scene_order = None if order == list(range(n + 1)) else np.array(order)
        self._link_index = {name: i for i, name in enumerate(names)}
        self._head_link = self._link_index["head"]
        self._foot_keys = {names.index(part): key for key, part in nao_model.pressure_parts(robot_type).items()}
        # rad/s by joint index, NaN where no command came
        self._no_commands = np.full(n, np.nan)
        self._requested = np.full(n, np.nan)  # commands since the last step
        self._pending = np.full(n, np.nan)  # commands to apply at the start of the next step
        self._motor = np.zeros(n)  # sticky motor target velocities, rad/s
        #: this step's motor targets and forces, the solve's motor rows (none before the first step)
        self._sent: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros(0))
        #: the torso's velocity now: after the last step, or 0 after a beam or a move
        self._velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
        #: the accelerometer as SimSpark's (Accelerometer::PrePhysicsUpdateInternal): the reading
        #: perceived after a step, made before it from the velocity change since the last
        #: reading; the velocity it saw last; what it sees if a beam came after it this cycle
        self._acc: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._acc_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
        self._acc_view: tuple[tuple[float, ...], tuple[float, ...]] | None = None
        #: no step has run since this robot was made: it has touched nothing yet (a reused body
        #: may still hold its last life's contacts until the next collision pass)
        self._new = True
        #: a solved state not yet written into pybullet (``keep_unwritten``), or None
        self._unwritten: tuple | None = None
        self._invalidate()

    # ----- commands -----
    def command(self, effector: str, velocity: float) -> None:
        """Queue a hinge velocity (rad/s) as the server's effector would receive it.

        Unknown effector -> KeyError; non-finite -> ValueError. The value is clipped to the
        joint's speed cap now and applied (or dropped) in the step after the next one.
        """
        self.command_joint(self._effector_index[effector], velocity)

    def command_joint(self, index: int, velocity: float) -> None:
        """``command`` for the joint at ``index`` in ``protocol.nao.joints_of`` order: the server's
        path for the hinge commands of every cycle, without the name lookup."""
        if not math.isfinite(velocity):
            effector = joints_of(self.robot_type)[index].effector
            raise ValueError(f"velocity for {effector} must be finite, got {velocity!r}")
        cap = self._caps[index]
        self._requested[index] = min(cap, max(-cap, velocity))

    def command_joints(self, velocities: np.ndarray) -> None:
        """``command_joint`` for every joint at once, ``velocities`` in ``joints_of`` order (the
        optimizer's in-process episodes, which hand over an agent's commands without text)."""
        # np.logical_and.reduce: ``.all()`` without its Python wrapper, once a cycle
        if velocities.shape != self._requested.shape or not np.logical_and.reduce(np.isfinite(velocities)):
            raise ValueError(f"velocities must be {len(self._requested)} finite numbers, got {velocities!r}")
        # np.clip for finite numbers, without its checks
        np.minimum(np.maximum(velocities, self._neg_caps, out=self._requested), self._caps_array, out=self._requested)

    def motor_commands(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This step's motor targets and forces (``server_stub.physics.motors``; empty before the
        first step) and the sticky target speeds: what the step's motor rows are made of."""
        target, force = self._sent
        return target, force, self._motor

    # ----- the step, as ``World.step`` drives it: begin_step, the solve (which ends in ``hold``),
    # end_step -----
    def begin_step(self) -> None:
        """Read the accelerometer, apply last interval's commands (the latency rule) and set this
        step's motors (``server_stub.physics.motors``)."""
        if not self._new:
            self._sense_acceleration()
        angles, rates = self.joint_state()
        if self._delay:
            due, self._pending = self._pending, self._requested
        else:
            due = self._requested
        self._requested = self._no_commands.copy()
        cfg = self._config
        self._sent = motors.motor_step(
            angles,
            rates,
            self._lower,
            self._upper,
            due,
            self._motor,
            cfg.motor_torque,
            cfg.stop_erp,
            cfg.stop_bounce,
            cfg.cycle,
            _STOP_FORCE,
        )

    def _stepped(self) -> None:
        """The bodies moved: every cached reading is stale."""
        self._new = False
        self._invalidate()

    def end_step(self) -> None:
        """Keep the torso's velocity after the step for the next accelerometer reading."""
        self._velocity = self._base_motion()[0]

    def _sense_acceleration(self) -> None:
        """SimSpark's accelerometer reads in the pass before the physics step: the torso's velocity
        change since its last reading over one cycle, less gravity, in the torso's frame then. So
        the perception after step k carries the acceleration of step k - 1: on a recorded walk the
        real server's ACC equals, line for line from the 6th, what a reading after each step gives
        one line earlier. Of that pass, a robot's ``init`` and a trainer's move come before it, a
        beam after it (nao_hetero.rsg lists the torso's accelerometer before its BeamEffector):
        the reading after an ``init`` spikes (29.42 recorded: the fall stopped), the one after a
        beam does not. A new robot's first reading is 0 (the real one is created a step before
        its first perception, so its reading after the ``init`` is 29.42 where ours is 19.62)."""
        velocity, rotation = self._acc_view or (self._velocity, self._base_pose()[1])
        dt = self._config.cycle
        (vx, vy, vz), (px, py, pz) = velocity, self._acc_velocity
        world = ((vx - px) / dt, (vy - py) / dt, (vz - pz) / dt - self._config.gravity)
        self._acc = _to_local(rotation, world)
        self._acc_velocity = velocity
        self._acc_view = None

    def _invalidate(self) -> None:
        self._joints: tuple[np.ndarray, np.ndarray] | None = None
        self._pose: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]] | None = None
        self._motion: tuple[tuple[float, ...], tuple[float, ...]] | None = None
        self._contact_points: tuple | None = None
        self._contact_maker: Callable[[], tuple] | None = None
        self.held = False
        self._parts: np.ndarray | None = None
        self._links: list[tuple] | None = None
        self._table: np.ndarray | None = None

    def keep_unwritten(
        self, position: tuple, orientation: tuple, velocity: tuple, spin: tuple, angles: np.ndarray, rates: np.ndarray
    ) -> None:
        """A step's solved state, kept instead of written into pybullet: it is written (``sync``)
        only before pybullet is asked about this robot (a link's pose, a collision pass, a beam), so
        a walker far from everything costs no pybullet call a cycle; ``hold`` follows."""
        self._unwritten = (position, orientation, velocity, spin, angles, rates)

    @property
    def pending_write(self) -> bool:
        """Whether a solved state waits to be written into pybullet (``keep_unwritten``)."""
        return self._unwritten is not None

    def sync(self) -> None:
        """Write the kept state (``keep_unwritten``) into pybullet, as the step would have at once."""
        if self._unwritten is None:
            return
        position, orientation, velocity, spin, angles, rates = self._unwritten
        self._unwritten = None
        client, body = self._client, self._body
        pb.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=client)
        pb.resetBaseVelocity(body, velocity, spin, physicsClientId=client)
        pb.resetJointStatesMultiDof(
            body,
            self._indices,
            list(zip(angles.tolist())),
            targetVelocities=list(zip(rates.tolist())),
            physicsClientId=client,
        )

    def hold(
        self, angles: np.ndarray, rates: np.ndarray, velocity: tuple, spin: tuple, contacts: Callable[[], tuple]
    ) -> None:
        """The state an ODE step has just solved, kept as pybullet gives it back once written
        (it stores these numbers as they are, the orientation rebuilt from a matrix; its motors,
        never stepped, applied no torque), so that the sensors and the next step need not ask it;
        and the step's contacts, made when first asked for. Until the next step or a re-pose,
        ``held`` says pybullet holds this, or will when written (``keep_unwritten``)."""
        self._stepped()
        self._contact_maker = contacts
        self._joints = (angles, rates)
        self._motion = (velocity, spin)
        self.held = True
        if self._unwritten is not None:
            position, orientation = self._unwritten[0], self._unwritten[1]
            back = read_back(tuple(orientation))
            self._pose = (tuple(position), stored_matrix(back), back)

    # ----- placing -----
    def beam(self, x: float, y: float, heading_deg: float) -> None:
        """The server's beam: torso centre to (x, y, 0.4), upright facing ``heading_deg``
        (0 = world +x), joint angles kept, all velocities zeroed. Motor commands stay (sticky).
        The accelerometer has read before it, in this cycle (``_sense_acceleration``)."""
        if self._acc_view is None:
            self._acc_view = (self._velocity, self._base_pose()[1])
        self._reset(x, y, BEAM_HEIGHT, _yaw_quaternion(heading_deg))

    def place(self, x: float, y: float, z: float, yaw_deg: float | None = None) -> None:
        """The trainer's move: torso centre to (x, y, z), velocities zeroed, joints kept; the
        orientation is kept, or with ``yaw_deg`` set upright facing it (0 = world +x)."""
        if yaw_deg is None:
            orientation = self._base_pose()[2]
        else:
            orientation = _yaw_quaternion(yaw_deg)
        self._reset(x, y, z, orientation)

    def _reset(self, x: float, y: float, z: float, orientation) -> None:
        """Re-pose the body at rest (the accelerometer sees the stop at its next reading)."""
        client = self._client
        angles = self.joint_state()[0]
        self.sync()
        pb.resetBasePositionAndOrientation(self._body, (x, y, z), orientation, physicsClientId=client)
        pb.resetBaseVelocity(self._body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=client)
        pb.resetJointStatesMultiDof(
            self._body,
            self._indices,
            [[a] for a in angles],
            targetVelocities=[[0.0]] * len(self._indices),
            physicsClientId=client,
        )
        self._invalidate()
        self._velocity = (0.0, 0.0, 0.0)
        if self._on_move is not None:
            self._on_move(self)

    # ----- sensors -----
    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(angles, rates) of the hinges in radians, cached until the next step."""
        if self._joints is None:
            self.sync()
            states = pb.getJointStates(self._body, self._indices, physicsClientId=self._client)
            self._joints = (np.array([s[0] for s in states]), np.array([s[1] for s in states]))
        return self._joints

    def stored_pose(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The torso's (position, quaternion) as pybullet holds them."""
        position, _, orientation = self._base_pose()
        return position, orientation

    def stored_motion(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The torso's (velocity, spin) as pybullet holds them."""
        return self._base_motion()

    def link_frames(self) -> list[tuple]:
        """pybullet's frame of every link (centre, orientation, ..., hinge anchor at index 4), from
        its exact joints: where the step places the bodies before their first step."""
        self.sync()
        return pb.getLinkStates(self._body, self._indices, computeForwardKinematics=1, physicsClientId=self._client)

    def link_frame(self, link: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """(centre, quaternion) of one link (-1: the torso) as pybullet holds it: where a contact
        Bullet found on it lies in the link's frame."""
        self.sync()
        if link < 0:
            return pb.getBasePositionAndOrientation(self._body, physicsClientId=self._client)
        state = pb.getLinkState(self._body, link, computeForwardKinematics=1, physicsClientId=self._client)
        return state[0], state[1]

    def _link_states(self) -> list[tuple]:
        """pybullet's state of every link (pose and velocity), cached until the next step: the
        cameras and the monitor read the same state."""
        if self._links is None:
            self.sync()
            self._links = pb.getLinkStates(
                self._body,
                self._indices,
                computeLinkVelocity=1,
                computeForwardKinematics=1,
                physicsClientId=self._client,
            )
        return self._links

    def _link_table(self) -> np.ndarray:
        """``_link_states`` as one array, a row per link: centre (3), orientation (4), frame origin
        = hinge anchor (3), velocity (3), spin (3); built once per step for the monitor's poses."""
        if self._table is None:
            self._table = np.array([st[0] + st[1] + st[4] + st[6] + st[7] for st in self._link_states()])
        return self._table

    def _contacts(self) -> tuple:
        """Every contact point of this robot after the last step (pybullet's tuples)."""
        if self._contact_points is None:
            if self._contact_maker is not None:
                self._contact_points = self._contact_maker()
            elif self._new:
                self._contact_points = ()
            else:
                self.sync()
                self._contact_points = pb.getContactPoints(bodyA=self._body, physicsClientId=self._client)
        return self._contact_points

    def contact_points(self) -> tuple:
        """Every contact point of this robot after the last step, in pybullet's tuple layout
        (fields named in ``server_stub.physics.contact``), with the forces the step solved."""
        return self._contacts()

    def _base_pose(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """(position, rotation as 9 floats row-major, quaternion), cached until the next step."""
        if self._pose is None:
            self.sync()
            position, orientation = pb.getBasePositionAndOrientation(self._body, physicsClientId=self._client)
            self._pose = (position, pb.getMatrixFromQuaternion(orientation), orientation)
        return self._pose

    def _base_motion(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """(velocity, angular velocity) of the torso in the world, cached until the next step:
        the accelerometer and the gyro read the same state."""
        if self._motion is None:
            self.sync()
            self._motion = pb.getBaseVelocity(self._body, physicsClientId=self._client)
        return self._motion

    def joint_angles(self) -> dict[str, float]:
        """Hinge angles in degrees by perceptor name (hj1 ... llj6, then a type's toes rlj7, llj7),
        in ``joints_of`` order."""
        return dict(zip(self._perceptors, self.joint_degrees()))

    @property
    def perceptors(self) -> tuple[str, ...]:
        """Every joint's perceptor name, in ``joints_of`` order: the keys of ``joint_angles``."""
        return self._perceptors

    def joint_degrees(self) -> list[float]:
        """``joint_angles``' values alone: what a reader that knows the order needs."""
        return np.degrees(self.joint_state()[0]).tolist()

    def x_extent(self) -> tuple[float, float]:
        """The lowest and highest field x the referee counts the robot as reaching: its torso box
        (0.10 x 0.10 x 0.18 m). Measured on the real server with this project's agent: a robot
        beamed with its torso centre at x = -0.02 is moved back before kick-off, one at -0.05 is
        left alone, though its feet reach 0.1 m ahead of the torso; so the referee's rectangle
        spans about the torso, not the limbs."""
        (x, _, _), rotation, _ = self._base_pose()
        half = float(np.abs(np.array(rotation).reshape(3, 3)[0]) @ _TORSO_HALF_SIZE)
        return x - half, x + half

    def torso_position(self) -> tuple[float, float, float]:
        x, y, z = self._base_pose()[0]
        return (x, y, z)

    def torso_rotation(self) -> np.ndarray:
        """3x3 rotation whose columns are the torso's x (right), y (forward), z (up) in world."""
        return np.array(self._base_pose()[1]).reshape(3, 3)

    def gyro(self) -> tuple[float, float, float]:
        """Torso angular velocity in the torso frame, deg/s (GYR)."""
        omega = self._base_motion()[1]
        x, y, z = _to_local(self._base_pose()[1], omega)
        return (math.degrees(x), math.degrees(y), math.degrees(z))

    def accelerometer(self) -> tuple[float, float, float]:
        """Torso proper acceleration in the torso frame, m/s^2 (ACC), as read before the last step
        (``_sense_acceleration``): (0, 0, 9.81) upright at rest, 0 in free fall."""
        return self._acc

    def foot_pressure(self) -> dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]]:
        """FRP per foot (and toe, on a type with toes: rf1, lf1) that touches: (centre of
        pressure, total contact force), both in the part's frame (origin at its centre, so a
        foot's sole is z = -0.01), as ``contact.link_pressure`` sums them; a part that does not
        touch is absent."""
        touching = contact.link_pressure(self._contacts(), self._foot_keys)
        if not touching:
            return {}
        states = self._link_states()
        result = {}
        for link, (point, force) in touching.items():
            (ox, oy, oz), rotation = states[link][0], pb.getMatrixFromQuaternion(states[link][1])
            centre = (point[0] - ox, point[1] - oy, point[2] - oz)
            result[self._foot_keys[link]] = (_to_local(rotation, centre), _to_local(rotation, force))
        return result

    def head_pose(self) -> tuple[tuple[float, float, float], np.ndarray]:
        """Head centre (the camera, and ``mypos``) and its 3x3 rotation (columns = head axes)."""
        state = self._link_states()[self._head_link]
        rotation = np.array(pb.getMatrixFromQuaternion(state[1])).reshape(3, 3)
        x, y, z = (float(c) for c in state[0])
        return (x, y, z), rotation

    @property
    def part_names(self) -> tuple[str, ...]:
        """Every body part, torso first: the order of ``part_poses``."""
        return self._part_names

    def part_poses(self) -> np.ndarray:
        """Every body part's world pose (n x 4 x 4: part centre and axes), in ``part_names``
        order, for the monitor; computed once per step."""
        if self._parts is None:
            position, rotation, _ = self._base_pose()
            poses = body_poses(np.array(position), np.array(rotation).reshape(3, 3), self._link_table())
            self._parts = poses if self._scene_order is None else poses[self._scene_order]
        return self._parts

    def part_positions(self, names: Sequence[str]) -> dict[str, tuple[float, float, float]]:
        """World centres of the named parts (not the torso): what other robots' cameras need
        every third cycle, without building ``part_poses``' matrices."""
        states = self._link_states()
        return {name: states[self._link_index[name]][0] for name in names}

    @property
    def body_id(self) -> int:
        return self._body


def _to_local(r: tuple[float, ...], v) -> tuple[float, float, float]:
    """R^T v for a row-major 3x3 rotation ``r``: a world vector in the body's frame."""
    x, y, z = v
    return (r[0] * x + r[3] * y + r[6] * z, r[1] * x + r[4] * y + r[7] * z, r[2] * x + r[5] * y + r[8] * z)
