"""The simulated world: the field, the ball and the robots, stepped one server cycle at a time.

One ``step`` is one 0.02 s server cycle for everything in it (docs/robot_and_server.md section 4):
the stand-in's own ODE step (``stepper.Stepper``, which owns the physics state). A pybullet DIRECT
client holds the bodies' shapes: it finds the contacts between robots, the ball and the field's
boxes, gives the links' poses to the cameras and the monitor, and mirrors each robot's state, which
the step writes into it only when pybullet is asked about the robot.
The server built on top of this reads sensors from each ``Robot`` and forwards effector commands
to ``Robot.command``; nothing here knows about sockets or message text.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pybullet as pb

from server_stub import field
from server_stub.config import PhysicsConfig
from server_stub.physics import bodies as kinematics
from server_stub.physics import collision, nao_model, robot_step, stepper
from server_stub.physics.robot import Robot

#: docs/robot_and_server.md section 6: a new robot appears with its torso here, in the air.
SPAWN_POSITION = (0.0, -1.0, 1.5)
#: Half side of the ground box (m): well beyond the border walls.
_GROUND_HALF = field.LENGTH / 2 + 20.0
#: Where removed robots wait, asleep, for the next robot of their type (``World.remove_robot``):
#: far beyond the walls and the ground, one spot each.
_PARKING = (500.0, 500.0, 50.0)
_PARKING_GAP = 5.0
#: Activation flags: a parked body sleeps and nothing wakes it; a revived one is as ``loadURDF``
#: leaves a body (awake, never sleeping, wakeable).
_PARK = pb.ACTIVATION_STATE_ENABLE_SLEEPING | pb.ACTIVATION_STATE_SLEEP | pb.ACTIVATION_STATE_DISABLE_WAKEUP
_REVIVE = pb.ACTIVATION_STATE_WAKE_UP | pb.ACTIVATION_STATE_DISABLE_SLEEPING | pb.ACTIVATION_STATE_ENABLE_WAKEUP


class World:
    """A field with goals and a ball, and any number of NAOs, stepped one server cycle at a time.

    ``seed`` feeds ``rng``, the only source of randomness a caller should use for this world
    (the physics itself has none, so equal seeds and equal calls give equal runs).
    """

    def __init__(self, config: PhysicsConfig = PhysicsConfig(), seed: int = 0, command_delay_steps: int = 1) -> None:
        """``command_delay_steps``: see ``Robot``; 1 reproduces the real latency for in-process use."""
        self.config = config
        self.command_delay_steps = command_delay_steps
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.time = 0.0
        self._client = pb.connect(pb.DIRECT)
        self._tmp = tempfile.TemporaryDirectory(prefix="nao_stub_")
        self._urdf: dict[int, str] = {}
        self._robots: list[Robot] = []
        #: removed robots' bodies by robot type, kept for the next robot of that type
        self._parked: dict[int, list[int]] = {}
        self._configure_collision()
        self._build_field()

    def _configure_collision(self) -> None:
        """pybullet never steps this world; it finds the contacts between robots, the ball and the
        field's boxes (``stepper``). Its pairs in a fixed order, so equal runs find equal points."""
        pb.setPhysicsEngineParameter(
            contactBreakingThreshold=self.config.contact_breaking_threshold,
            deterministicOverlappingPairs=1,
            physicsClientId=self._client,
        )

    def _build_field(self) -> None:
        c = self._client
        # The ground collides with nothing in Bullet (the step makes ground contacts itself,
        # ``collision.ground_contacts``); it is the body a ground contact names.
        ground = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[_GROUND_HALF, _GROUND_HALF, 1.0], physicsClientId=c)
        self._ground = pb.createMultiBody(0.0, ground, basePosition=(0.0, 0.0, -1.0), physicsClientId=c)
        # robots and ball collide with the boxes SimSpark's field has
        boxes = collision.static_boxes()
        shapes = pb.createCollisionShapeArray(
            [pb.GEOM_BOX] * len(boxes),
            halfExtents=[b[0] for b in boxes],
            collisionFramePositions=[b[1] for b in boxes],
            physicsClientId=c,
        )
        self._static = pb.createMultiBody(0.0, shapes, physicsClientId=c)
        ball_shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=field.BALL_RADIUS, physicsClientId=c)
        self._ball = pb.createMultiBody(
            field.BALL_MASS, ball_shape, basePosition=(0.0, 0.0, field.BALL_RADIUS), physicsClientId=c
        )
        self._stepper = stepper.Stepper(self.config, c, self._ground, self._ball, self._static)

    # ----- robots -----
    def add_robot(self, robot_type: int = 0) -> Robot:
        """A new NAO of ``robot_type`` (0-4) with its torso at (0, -1, 1.5), facing +y, falling.

        The body of a robot removed earlier is reused when one of this type is parked: pybullet
        never frees all a ``loadURDF`` takes (about 19 KiB a robot, even across
        ``resetSimulation``), and a stub serving one robot per episode would grow without end.
        A reused body is put in exactly a loaded body's state (``_revive``)."""
        parked = self._parked.get(robot_type)
        if parked:
            body = parked.pop()
            self._revive(body)
        else:
            body = self._load(robot_type)
        robot = Robot(self._client, body, robot_type, self.config, self.command_delay_steps, self._stepper.moved)
        self._stepper.add(robot)
        self._robots.append(robot)
        return robot

    def _load(self, robot_type: int) -> int:
        return pb.loadURDF(
            self._urdf_file(robot_type),
            basePosition=SPAWN_POSITION,
            flags=pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_MAINTAIN_LINK_ORDER,
            physicsClientId=self._client,
        )

    def _revive(self, body: int) -> None:
        """A parked body as ``loadURDF`` leaves one: torso at the spawn point, upright, every joint
        at 0, everything at rest, awake. Motor targets need no reset (a new ``Robot`` sets every
        motor in its first step), nor contacts (it reads none before its first step)."""
        c = self._client
        pb.changeDynamics(body, -1, activationState=_REVIVE, physicsClientId=c)
        pb.resetBasePositionAndOrientation(body, SPAWN_POSITION, (0.0, 0.0, 0.0, 1.0), physicsClientId=c)
        pb.resetBaseVelocity(body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=c)
        joints = list(range(pb.getNumJoints(body, physicsClientId=c)))
        pb.resetJointStatesMultiDof(
            body, joints, [[0.0]] * len(joints), targetVelocities=[[0.0]] * len(joints), physicsClientId=c
        )

    def _urdf_file(self, robot_type: int) -> str:
        if robot_type not in self._urdf:
            path = Path(self._tmp.name) / f"nao{robot_type}.urdf"
            path.write_text(nao_model.urdf(robot_type))
            self._urdf[robot_type] = str(path)
        return self._urdf[robot_type]

    def remove_robot(self, robot: Robot) -> None:
        """Take ``robot`` off the field: its body is parked asleep far away, out of every step's
        work and every other body's reach, until ``add_robot`` reuses it."""
        self._robots.remove(robot)
        self._stepper.forget(robot)
        robot.sync()  # a state kept from pybullet must not land on the parked body later
        c = self._client
        x, y, z = _PARKING
        spot = (x + _PARKING_GAP * robot.body_id, y, z)
        pb.resetBasePositionAndOrientation(robot.body_id, spot, (0.0, 0.0, 0.0, 1.0), physicsClientId=c)
        pb.resetBaseVelocity(robot.body_id, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=c)
        pb.changeDynamics(robot.body_id, -1, activationState=_PARK, physicsClientId=c)
        self._parked.setdefault(robot.robot_type, []).append(robot.body_id)

    @property
    def robots(self) -> tuple[Robot, ...]:
        return tuple(self._robots)

    def physics_of(self, robot: Robot) -> robot_step.RobotPhysics:
        """What the step keeps of ``robot``: its model and its bodies in maximal coordinates (the
        diagnostics of tests and probes; the step owns them)."""
        return self._stepper.physics_of(robot)

    def anchor_gaps(self, robot: Robot) -> np.ndarray:
        """How far apart each hinge's two anchor copies are (m), in ``JOINTS`` order: the joint
        drift of ODE's maximal coordinates (the real server's knees part by 3-6 mm walking); zeros
        before the robot's first step."""
        physics = self.physics_of(robot)
        static, state = physics.model, physics.state
        if static is None or state is None:
            return np.zeros(len(robot.joint_degrees()))
        model = static.model
        return kinematics.anchor_gaps(
            model.parents, model.joint_of, state.pos, state.quat, model.anchor_child, model.anchor_parent
        )

    # ----- time -----
    def step(self) -> None:
        """One server cycle: motors from the commands of two cycles ago (``Robot.begin_step``),
        then one ODE step of every robot and the ball (``stepper.Stepper``)."""
        for robot in self._robots:
            robot.begin_step()
        self._stepper.step(self._robots)
        self.time += self.config.cycle
        for robot in self._robots:
            robot.end_step()

    # ----- ball -----
    def set_ball(self, pos, vel=(0.0, 0.0, 0.0)) -> None:
        c = self._client
        pb.resetBasePositionAndOrientation(self._ball, pos, (0.0, 0.0, 0.0, 1.0), physicsClientId=c)
        pb.resetBaseVelocity(self._ball, vel, (0.0, 0.0, 0.0), physicsClientId=c)
        self._stepper.ball_moved()

    def ball_position(self) -> tuple[float, float, float]:
        x, y, z = self._stepper.ball_now()[0]
        return (x, y, z)

    def robots_touching_ball(self, ball: tuple[float, float, float]) -> list[Robot]:
        """The robots with a part touching the ball (at ``ball``, where it is now) as everything
        stands now (Bullet's closest points at no distance), for the referee's record of who
        played the ball: SimSpark's ball recorder, filled by the collision pass at the start of a
        step. Changes nothing; asks pybullet only about robots whose torso is within 1 m of the
        ball (a lone walker never)."""
        bx, by, bz = ball
        touching = []
        for robot in self._robots:
            x, y, z = robot.torso_position()
            if (x - bx) ** 2 + (y - by) ** 2 + (z - bz) ** 2 > 1.0:
                continue
            robot.sync()
            points = pb.getClosestPoints(self._ball, robot.body_id, 0.0, physicsClientId=self._client)
            if any(point[8] <= 0.0 for point in points):
                touching.append(robot)
        return touching

    def close(self) -> None:
        if self._client >= 0:
            pb.disconnect(physicsClientId=self._client)
            self._client = -1
            self._tmp.cleanup()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
