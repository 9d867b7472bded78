"""One simulated NAO inside a ``World``: the server's motor rules and the robot's sensors.

The motor rules follow NAO_MODEL_FACTS.md section 3 ("How a velocity command is applied"):
clip to the speed cap, sticky, dropped while the joint is not strictly inside (min, max), applied
with the two-cycle action latency; a joint that starts a step outside its range is pushed back by
the stop (ERP 0.8, bounce 1) instead of being held at the limit, as ODE's limit rows do.
Sensors (section 5) are read lazily and cached until the next step, so a caller pays only for
what it asks.
"""
from __future__ import annotations

import math

import numpy as np
import pybullet as pb

from protocol.nao import JOINTS
from server_stub import nao_model
from server_stub.config import PhysicsConfig

_N = len(JOINTS)
_EFFECTOR_INDEX: dict[str, int] = {j.effector: i for i, j in enumerate(JOINTS)}
_MIN = np.radians([j.min_deg for j in JOINTS])
_MAX = np.radians([j.max_deg for j in JOINTS])
#: Torso height of a beamed robot (facts section 6).
BEAM_HEIGHT = 0.4
#: Force large enough to make the stop's velocity win against anything in one step.
_STOP_FORCE = 1e4


def _yaw_quaternion(heading_deg: float) -> tuple[float, float, float, float]:
    """Upright orientation facing world heading ``heading_deg`` (0 = +x). The model is built
    facing +y (heading 90), so the body turns by heading - 90 about z."""
    half = math.radians(heading_deg - 90.0) / 2.0
    return (0.0, 0.0, math.sin(half), math.cos(half))


class Robot:
    """A NAO body in a pybullet world. Created by ``World.add_robot``; ``World.step`` drives it."""

    def __init__(self, client: int, body: int, robot_type: int, config: PhysicsConfig) -> None:
        self.robot_type = robot_type
        self._client = client
        self._body = body
        self._config = config
        self._indices = list(range(_N))
        self._caps = np.array(nao_model.speed_caps(robot_type))
        names = [pb.getJointInfo(body, i, physicsClientId=client)[12].decode() for i in self._indices]
        self._part_names = ["torso"] + names
        self._head_link = names.index("head")
        self._foot_links = {key: names.index(part) for key, part in nao_model.FOOT_PARTS.items()}
        self._requested = np.full(_N, np.nan)  # commands since the last step
        self._pending = np.full(_N, np.nan)  # commands to apply at the start of the next step
        self._motor = np.zeros(_N)  # sticky motor target velocities, rad/s
        self._sent: tuple[np.ndarray, np.ndarray] | None = None
        self._prev_velocity = np.zeros(3)
        self._velocity = np.zeros(3)
        self._invalidate()

    # ----- commands -----
    def command(self, effector: str, velocity: float) -> None:
        """Queue a hinge velocity (rad/s) as the server's effector would receive it.

        Unknown effector -> KeyError; non-finite -> ValueError. The value is clipped to the
        joint's speed cap now and applied (or dropped) in the step after the next one.
        """
        index = _EFFECTOR_INDEX[effector]
        if not math.isfinite(velocity):
            raise ValueError(f"velocity for {effector} must be finite, got {velocity!r}")
        cap = self._caps[index]
        self._requested[index] = min(cap, max(-cap, velocity))

    def _before_step(self) -> None:
        """Apply last interval's commands (the latency rule) and set this step's motors."""
        angles, rates = self._joint_state()
        inside = (angles > _MIN) & (angles < _MAX)
        take = ~np.isnan(self._pending) & inside
        self._motor[take] = self._pending[take]
        self._pending = self._requested
        self._requested = np.full(_N, np.nan)

        target = self._motor.copy()
        force = np.full(_N, self._config.motor_torque)
        if not inside.all():
            self._stop(angles, rates, target, force)
        sent = self._sent
        if sent is None or not (np.array_equal(sent[0], target) and np.array_equal(sent[1], force)):
            pb.setJointMotorControlArray(self._body, self._indices, pb.VELOCITY_CONTROL,
                                         targetVelocities=target, forces=force,
                                         physicsClientId=self._client)
            self._sent = (target, force)

    def _stop(self, angles: np.ndarray, rates: np.ndarray, target: np.ndarray,
              force: np.ndarray) -> None:
        """ODE's joint stop for joints that start the step past a limit: drive back at the larger
        of the ERP correction and the bounced incoming speed (facts section 3: hj1 at 100 rad/s
        into +120 alternates 119.5 / 126.5 deg)."""
        cfg = self._config
        over = angles - _MAX
        under = _MIN - angles
        for i in np.nonzero((over >= 0) | (under >= 0))[0]:
            if over[i] >= 0:
                back = max(cfg.stop_erp * over[i] / cfg.cycle, cfg.stop_bounce * max(rates[i], 0.0))
                target[i] = -back
            else:
                back = max(cfg.stop_erp * under[i] / cfg.cycle, cfg.stop_bounce * max(-rates[i], 0.0))
                target[i] = back
            force[i] = _STOP_FORCE

    def _after_step(self) -> None:
        self._invalidate()
        self._prev_velocity = self._velocity
        self._velocity = np.array(pb.getBaseVelocity(self._body, physicsClientId=self._client)[0])

    def _invalidate(self) -> None:
        self._joints: tuple[np.ndarray, np.ndarray] | None = None
        self._pose: tuple[np.ndarray, np.ndarray] | None = None

    # ----- placing -----
    def beam(self, x: float, y: float, heading_deg: float) -> None:
        """The server's beam: torso centre to (x, y, 0.4), upright facing ``heading_deg``
        (0 = world +x), joint angles kept, all velocities zeroed. Motor commands stay (sticky)."""
        self._reset(x, y, BEAM_HEIGHT, _yaw_quaternion(heading_deg))

    def place(self, x: float, y: float, z: float, yaw_deg: float | None = None) -> None:
        """The trainer's move: torso centre to (x, y, z), velocities zeroed, joints kept; the
        orientation is kept, or with ``yaw_deg`` set upright facing it (0 = world +x)."""
        if yaw_deg is None:
            orientation = pb.getBasePositionAndOrientation(self._body, physicsClientId=self._client)[1]
        else:
            orientation = _yaw_quaternion(yaw_deg)
        self._reset(x, y, z, orientation)

    def _reset(self, x: float, y: float, z: float, orientation) -> None:
        """Re-pose the body at rest. The accelerometer's previous velocity is kept on purpose:
        the real server shows a one-cycle spike after a beam (facts section 5)."""
        client = self._client
        angles, _ = self._joint_state()
        pb.resetBasePositionAndOrientation(self._body, (x, y, z), orientation, physicsClientId=client)
        pb.resetBaseVelocity(self._body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=client)
        pb.resetJointStatesMultiDof(self._body, self._indices, [[a] for a in angles],
                                    targetVelocities=[[0.0]] * _N, physicsClientId=client)
        self._invalidate()

    # ----- sensors -----
    def _joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        if self._joints is None:
            states = pb.getJointStates(self._body, self._indices, physicsClientId=self._client)
            self._joints = (np.array([s[0] for s in states]), np.array([s[1] for s in states]))
        return self._joints

    def _base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        if self._pose is None:
            position, orientation = pb.getBasePositionAndOrientation(
                self._body, physicsClientId=self._client)
            rotation = np.array(pb.getMatrixFromQuaternion(orientation)).reshape(3, 3)
            self._pose = (np.array(position), rotation)
        return self._pose

    def joint_angles(self) -> dict[str, float]:
        """Hinge angles in degrees by perceptor name (hj1 ... llj6), in JOINTS order."""
        angles = np.degrees(self._joint_state()[0])
        return {j.perceptor: float(a) for j, a in zip(JOINTS, angles)}

    def torso_position(self) -> tuple[float, float, float]:
        return tuple(float(c) for c in self._base_pose()[0])

    def torso_rotation(self) -> np.ndarray:
        """3x3 rotation whose columns are the torso's x (right), y (forward), z (up) in world."""
        return self._base_pose()[1].copy()

    def gyro(self) -> tuple[float, float, float]:
        """Torso angular velocity in the torso frame, deg/s (GYR)."""
        omega = pb.getBaseVelocity(self._body, physicsClientId=self._client)[1]
        local = self._base_pose()[1].T @ np.array(omega)
        return tuple(float(c) for c in np.degrees(local))

    def accelerometer(self) -> tuple[float, float, float]:
        """Torso proper acceleration in the torso frame, m/s^2 (ACC): the velocity change over the
        last step minus gravity, so (0, 0, 9.81) upright at rest and 0 in free fall."""
        world = (self._velocity - self._prev_velocity) / self._config.cycle
        world[2] -= self._config.gravity
        return tuple(float(c) for c in self._base_pose()[1].T @ world)

    def foot_pressure(self) -> dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]]:
        """FRP per foot in contact: (centre of pressure, total contact force), both in the foot's
        frame (origin at the foot centre, so the sole is z = -0.01). Feet without contact are
        absent, as the server omits them."""
        contacts = pb.getContactPoints(bodyA=self._body, physicsClientId=self._client)
        if not contacts:
            return {}
        result = {}
        for key, link in self._foot_links.items():
            points = [c for c in contacts if c[3] == link]
            if not points:
                continue
            force = np.zeros(3)
            weighted = np.zeros(3)
            total_normal = 0.0
            for c in points:
                normal_force = c[9]
                force += (normal_force * np.array(c[7]) + c[10] * np.array(c[11])
                          + c[12] * np.array(c[13]))
                weighted += normal_force * np.array(c[5])
                total_normal += normal_force
            if total_normal <= 0.0:
                continue
            state = pb.getLinkState(self._body, link, computeForwardKinematics=True,
                                    physicsClientId=self._client)
            rotation = np.array(pb.getMatrixFromQuaternion(state[1])).reshape(3, 3)
            centre = rotation.T @ (weighted / total_normal - np.array(state[0]))
            local_force = rotation.T @ force
            result[key] = (tuple(float(c) for c in centre), tuple(float(c) for c in local_force))
        return result

    def head_pose(self) -> tuple[tuple[float, float, float], np.ndarray]:
        """Head centre (the camera, and ``mypos``) and its 3x3 rotation (columns = head axes)."""
        return self._link_pose(self._head_link)

    def _link_pose(self, link: int) -> tuple[tuple[float, float, float], np.ndarray]:
        state = pb.getLinkState(self._body, link, computeForwardKinematics=True,
                                physicsClientId=self._client)
        rotation = np.array(pb.getMatrixFromQuaternion(state[1])).reshape(3, 3)
        return tuple(float(c) for c in state[0]), rotation

    def part_poses(self) -> list[tuple[str, np.ndarray]]:
        """Every body part's world pose (4x4, part centre and axes), torso first, for the monitor."""
        position, rotation = self._base_pose()
        poses = [("torso", _homogeneous(position, rotation))]
        states = pb.getLinkStates(self._body, self._indices, computeForwardKinematics=True,
                                  physicsClientId=self._client)
        for name, state in zip(self._part_names[1:], states):
            r = np.array(pb.getMatrixFromQuaternion(state[1])).reshape(3, 3)
            poses.append((name, _homogeneous(np.array(state[0]), r)))
        return poses

    @property
    def body_id(self) -> int:
        return self._body


def _homogeneous(position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = position
    return m

