"""The simulated world: a pybullet DIRECT client holding the field, the ball and the robots.

One ``step`` is one 0.02 s server cycle for everything in it (docs/robot_and_server.md sections 4).
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
from server_stub.physics import motors, nao_model, ode_contacts, ode_step, rotations, slip
from server_stub.physics.robot import Robot

#: docs/robot_and_server.md section 6: a new robot appears with its torso here, in the air.
SPAWN_POSITION = (0.0, -1.0, 1.5)
#: Thickness of the goal's posts, bar and net boxes (not given by the real server's files; thin).
_GOAL_THICKNESS = 0.02
#: Border walls: 1 m boxes about 10 m beyond the goal lines and 15 m beyond the side lines.
_WALL_GAP_X = 10.0
_WALL_GAP_Y = 15.0
_WALL_SIZE = 1.0
#: Half side of the ground box (m): the field, the gap to the walls and the walls themselves.
_GROUND_HALF = field.LENGTH / 2 + _WALL_GAP_Y + _WALL_SIZE + 4.0
#: Where removed robots wait, asleep, for the next robot of their type (``World.remove_robot``):
#: far beyond the walls and the ground, one spot each.
_PARKING = (500.0, 500.0, 50.0)
_PARKING_GAP = 5.0
#: Activation flags: a parked body sleeps and nothing wakes it; a revived one is as ``loadURDF``
#: leaves a body (awake, never sleeping, wakeable).
_PARK = pb.ACTIVATION_STATE_ENABLE_SLEEPING | pb.ACTIVATION_STATE_SLEEP | pb.ACTIVATION_STATE_DISABLE_WAKEUP
_REVIVE = pb.ACTIVATION_STATE_WAKE_UP | pb.ACTIVATION_STATE_DISABLE_SLEEPING | pb.ACTIVATION_STATE_ENABLE_WAKEUP
_SOLVERS = {"dantzig": pb.CONSTRAINT_SOLVER_LCP_DANTZIG, "pgs": pb.CONSTRAINT_SOLVER_LCP_SI}


def _static_boxes() -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """(half extents, centre) of every static box: both goals (posts, bar, sides, back) and walls."""
    t = _GOAL_THICKNESS / 2
    half_w = field.GOAL_WIDTH / 2
    h = field.GOAL_HEIGHT / 2
    boxes = []
    for side in (-1.0, 1.0):
        line = side * field.LENGTH / 2
        for y in (-half_w - t, half_w + t):
            boxes.append(((t, t, h), (line + side * t, y, h)))  # post on the goal line
            boxes.append(((field.GOAL_DEPTH / 2, t, h), (line + side * field.GOAL_DEPTH / 2, y, h)))  # side net
        boxes.append(((t, half_w, t), (line + side * t, 0.0, field.GOAL_HEIGHT + t)))  # crossbar
        boxes.append(((t, half_w, h), (line + side * (field.GOAL_DEPTH + t), 0.0, h)))  # back net
    wall_x = field.LENGTH / 2 + _WALL_GAP_X
    wall_y = field.WIDTH / 2 + _WALL_GAP_Y
    half = _WALL_SIZE / 2
    for side in (-1.0, 1.0):
        boxes.append(((half, wall_y, half), (side * (wall_x + half), 0.0, half)))
        boxes.append(((wall_x, half, half), (0.0, side * (wall_y + half), half)))
    return boxes


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
        self._configure_engine()
        self._build_field()
        slip.warm_up()
        if config.backend == "ode":
            ode_step.warm_up()
        rotations.warm_up()
        motors.warm_up()

    def _configure_engine(self) -> None:
        cfg = self.config
        c = self._client
        pb.setGravity(0.0, 0.0, cfg.gravity, physicsClientId=c)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=cfg.cycle / cfg.sub_steps,
            numSubSteps=1,
            numSolverIterations=cfg.solver_iterations,
            globalCFM=cfg.global_cfm,
            contactBreakingThreshold=cfg.contact_breaking_threshold,
            contactSlop=cfg.contact_slop,
            deterministicOverlappingPairs=1,
            constraintSolverType=_SOLVERS[cfg.solver],
            physicsClientId=c,
        )

    def _build_field(self) -> None:
        c = self._client
        # The ground is a thick box, not a plane: Bullet's box-box collider gives all 4 corners
        # of a flat foot at once, as ODE's box-plane collider does, while its convex-plane one
        # adds one point per step, so with one step per cycle a standing robot rocked on 2.
        ground = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[_GROUND_HALF, _GROUND_HALF, 1.0], physicsClientId=c)
        self._ground = pb.createMultiBody(0.0, ground, basePosition=(0.0, 0.0, -1.0), physicsClientId=c)
        maximal = self.config.backend == "ode" and self.config.ode_maximal and self.config.ode_contacts
        # the maximal step collides robots and ball with the boxes SimSpark's field has
        boxes = ode_contacts.static_boxes() if maximal else _static_boxes()
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
        pb.changeDynamics(
            self._ball,
            -1,
            linearDamping=self.config.linear_damping,
            angularDamping=self.config.angular_damping,
            physicsClientId=c,
        )
        self._ode_stepper = (
            ode_contacts.Stepper(self.config, c, self._ground, self._ball, self._static) if maximal else None
        )

    # ----- robots -----
    def add_robot(self, robot_type: int = 0) -> Robot:
        """A new NAO of ``robot_type`` (0-3) with its torso at (0, -1, 1.5), facing +y, falling.

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
        bullet_steps = self._ode_stepper is None
        robot = Robot(self._client, body, robot_type, self.config, self.command_delay_steps, bullet_steps)
        self._robots.append(robot)
        return robot

    def _load(self, robot_type: int) -> int:
        cfg = self.config
        c = self._client
        body = pb.loadURDF(
            self._urdf_file(robot_type),
            basePosition=SPAWN_POSITION,
            flags=pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_MAINTAIN_LINK_ORDER,
            physicsClientId=c,
        )
        for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
            pb.changeDynamics(
                body,
                link,
                lateralFriction=cfg.lateral_friction,
                rollingFriction=cfg.rolling_friction,
                spinningFriction=cfg.spinning_friction,
                restitution=cfg.restitution,
                contactStiffness=cfg.contact_stiffness,
                contactDamping=cfg.contact_damping,
                linearDamping=cfg.linear_damping,
                angularDamping=cfg.angular_damping,
                jointDamping=0.0,
                physicsClientId=c,
            )
        return body

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
            path.write_text(nao_model.urdf(robot_type, self.config.inertia_floor))
            self._urdf[robot_type] = str(path)
        return self._urdf[robot_type]

    def remove_robot(self, robot: Robot) -> None:
        """Take ``robot`` off the field: its body is parked asleep far away, out of every step's
        work and every other body's reach, until ``add_robot`` reuses it."""
        self._robots.remove(robot)
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

    # ----- time -----
    def step(self) -> None:
        """One server cycle: motors from the commands of two cycles ago, then the physics
        sub-steps, each after the contact slip forces of its start (``Robot.before_substep``)."""
        for robot in self._robots:
            robot.begin_step()
        if self.config.backend == "ode":
            self._step_ode()
            return
        for _ in range(self.config.sub_steps):
            for robot in self._robots:
                robot.before_substep()
            pb.stepSimulation(physicsClientId=self._client)
            for robot in self._robots:
                robot.after_substep()
        self.time += self.config.cycle
        for robot in self._robots:
            robot.end_step()

    def _step_ode(self) -> None:
        """The "ode" backend's cycle (``server_stub.physics.ode_step``): each robot solved by the stub,
        then Bullet steps the rest (the ball), and the robots get their solved state back. The
        maximal step with ``ode_contacts`` solves the ball and every contact itself
        (``server_stub.physics.ode_contacts``): Bullet only finds the contacts."""
        if self._ode_stepper is not None:
            self._ode_stepper.step(self._robots)
            self.time += self.config.cycle
            for robot in self._robots:
                robot.end_step()
            return
        solved = [ode_step.solve(robot, self._ground, self.config) for robot in self._robots]
        pb.stepSimulation(physicsClientId=self._client)
        for robot, state in zip(self._robots, solved):
            ode_step.apply(robot, state)
        self.time += self.config.cycle
        for robot in self._robots:
            robot.end_step()

    # ----- ball -----
    def set_ball(self, pos, vel=(0.0, 0.0, 0.0)) -> None:
        c = self._client
        pb.resetBasePositionAndOrientation(self._ball, pos, (0.0, 0.0, 0.0, 1.0), physicsClientId=c)
        pb.resetBaseVelocity(self._ball, vel, (0.0, 0.0, 0.0), physicsClientId=c)
        if self._ode_stepper is not None:
            self._ode_stepper.ball_moved()

    def ball_position(self) -> tuple[float, float, float]:
        return tuple(pb.getBasePositionAndOrientation(self._ball, physicsClientId=self._client)[0])

    def close(self) -> None:
        if self._client >= 0:
            pb.disconnect(physicsClientId=self._client)
            self._client = -1
            self._tmp.cleanup()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
