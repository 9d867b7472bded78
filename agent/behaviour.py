"""What the agent says each cycle: the handshake, the beam, settling, then the walk.

Kept free of sockets so that a recorded perception stream can be replayed through it and its
replies compared with what a real client sent (tests do this with the real-server calibration walk).

Cycle by cycle (one reply per perception, as the server expects):

1. first perception -> ``(init ...)``: the server only accepts init once the robot exists;
2. second -> ``(beam x y rot)`` if the play mode allows it (BeforeKickOff, Goal_Left/Right);
3. ``settle_cycles`` cycles holding the fixed posture and the gait's starting pose, beam repeated
   once at ``rebeam_cycle`` because moving into the pose shifts the feet;
4. walking, from the first cycle after settling in which the play mode is PlayOn (or at once with
   ``start_now``), for ``duration`` seconds of gait time.
"""

from __future__ import annotations

import enum
import logging
from dataclasses import dataclass, field
from operator import itemgetter

import numpy as np

from agent.config import AgentConfig
from agent.controller import velocities_into
from agent.fall import FallDetector
from agent.goto import GoTo, ServerPoseWhereSent
from agent.localization import PoseSource, TruePose, VisionPose, readable_vision
from gait import ArrayWalker, Command, Steerable, Walker
from protocol import commands
from protocol.nao import BEAM_PLAY_MODES, CYCLE, JOINT_BY_EFFECTOR, joints_of
from protocol.perception import Perception

log = logging.getLogger("agent")

_LIMITS = {j.effector: (j.min_deg, j.max_deg) for j in JOINT_BY_EFFECTOR.values()}


class Phase(enum.Enum):
    CONNECTING = "connecting"
    BEAMING = "beaming"
    SETTLING = "settling"
    WALKING = "walking"
    DONE = "done"


#: Cycles of dither drawn at once: a generator fills a block with the numbers it gives one
#: cycle's draw after another, at a tenth of the calls.
_NOISE_BLOCK = 64

#: No hinge velocities: an action that only says something else, or nothing.
_NO_SPEEDS = np.zeros(0)
_NO_SPEEDS.flags.writeable = False


@dataclass(frozen=True, eq=False)
class Action:
    """One cycle's answer before it is printed: hinge velocities (rad/s, ``speeds[i]`` for
    ``effectors[i]``, in ``joints_of`` order; none when none are sent) and the text of any other
    command after them (``init``, ``beam``). A program that hands the velocities to a server
    without text (the optimizer's direct episodes) reads the array; ``reply`` prints them."""

    effectors: tuple[str, ...] = ()
    speeds: np.ndarray = field(default_factory=lambda: _NO_SPEEDS)
    text: str = ""

    @property
    def velocities(self) -> dict[str, float]:
        """The hinge velocities by effector name."""
        return dict(zip(self.effectors, self.speeds.tolist()))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Action):
            return NotImplemented
        return (self.effectors, self.speeds.tolist(), self.text) == (other.effectors, other.speeds.tolist(), other.text)


def pose_source_for(config: AgentConfig) -> PoseSource:
    """Where a walk to poses takes its pose from: the server's where sent (unless
    ``config.true_pose`` is off), else the robot's own estimate, both from the beam pose on."""
    own = VisionPose(config.beam)
    return ServerPoseWhereSent(TruePose(config.beam), own) if config.true_pose else own


class WalkBehaviour:
    def __init__(self, config: AgentConfig, gait: Walker, pose: PoseSource | None = None) -> None:
        """``pose``: where a walk to ``config.goals`` takes its pose from (default
        ``pose_source_for``)."""
        self.config = config
        self.gait = gait
        #: the walker as one that takes commands and feels the robot (each cycle, before it is
        #: asked for targets), if it is one: checked once, not per cycle
        self._steerable = gait if isinstance(gait, Steerable) else None
        #: the walk to poses, and where it takes its pose from (none without goals)
        self.goto: GoTo | None = None
        self.pose: PoseSource | None = None
        if (config.goals or config.walk_command is not None) and self._steerable is None:
            raise ValueError("walking to poses or by a command needs a steerable gait (the omni family)")
        if config.goals:
            self.goto = GoTo(config.goals, config.goto)
            self.pose = pose if pose is not None else pose_source_for(config)
        self._fixed = None if config.walk_command is None else Command(*config.walk_command)
        #: what the walk to poses believed at each vision cycle of the walk: (game time, x, y,
        #: heading), for measuring its pose estimate against the truth (``bench.bench_course``)
        self.pose_log: list[tuple[float, float, float, float]] = []
        self.phase = Phase.CONNECTING
        self.settle_cycle = 0
        self.walk_cycles = 0
        self.fall = FallDetector()
        self.fell_at: float | None = None
        self.play_mode: str | None = None
        joints = joints_of(config.robot_type)
        #: the robot type's joints (the toes of type 4 too), the order of every array of joints here
        self._effectors = tuple(j.effector for j in joints)
        self._perceptors = tuple(j.perceptor for j in joints)
        #: a perception's joint angles in that order, in one call (KeyError if one is missing)
        self._angles_of = itemgetter(*self._perceptors)
        self._slot = {effector: i for i, effector in enumerate(self._effectors)}
        #: a walker that gives its targets as an array, and where its numbers go in ours
        self._array_gait = gait if isinstance(gait, ArrayWalker) else None
        self._target_slots = (
            None if self._array_gait is None else np.array([self._slot[e] for e in self._array_gait.target_effectors])
        )
        # every joint held at 0 unless the posture says otherwise
        self._posture = np.zeros(len(joints))
        for effector, degrees in config.posture.items():
            if effector not in self._slot:
                raise ValueError(f"posture names {effector!r}, not a joint of robot type {config.robot_type}")
            self._posture[self._slot[effector]] = degrees
        #: the controller's gain as its kernel takes it (a row per robot: this one)
        self._gains = np.array([config.gain])
        self._dither = np.random.default_rng(config.noise_seed) if config.command_noise > 0 else None
        # the dither's draws, a block of cycles at a time (the very numbers of one draw a cycle)
        self._noise = np.zeros((0, len(joints)))
        self._noise_row = 0

    @property
    def reads_vision(self) -> bool:
        """Whether this agent looks at what it sees (to know where it is): a program that makes
        its perceptions itself makes vision only for one that does."""
        return self.goto is not None

    @property
    def walk_time(self) -> float:
        """Seconds of gait time walked so far."""
        return self.walk_cycles * CYCLE

    def targets(self, gait_time: float) -> dict[str, float]:
        """Joint targets in degrees for every joint of the robot's type at ``gait_time``."""
        return dict(zip(self._effectors, self._target_array(gait_time).tolist()))

    def _target_array(self, gait_time: float) -> np.ndarray:
        out = self._posture.copy()
        if self._array_gait is not None:
            out[self._target_slots] = self._array_gait.joint_target_array(gait_time, _LIMITS)
            return out
        slot = self._slot
        for effector, degrees in self.gait.joint_targets(gait_time, _LIMITS).items():
            out[slot[effector]] = degrees
        return out

    def _velocities(self, perception: Perception, gait_time: float) -> np.ndarray:
        """The controller's commands; a joint missing from the perception gets 0 ("hold")."""
        steerable = self._steerable
        if steerable is not None:
            steerable.sense(perception.gyro, perception.acc, perception.joints)
            if self.pose is not None:
                self._steer(perception, steerable)
            elif self._fixed is not None:
                steerable.command = self._fixed if self.phase is Phase.WALKING else Command()
        lookahead = gait_time + self.config.lookahead_cycles * CYCLE
        joints = perception.joints
        try:
            angles = np.fromiter(self._angles_of(joints), float, len(self._perceptors))
            unseen = []
        except KeyError:
            unseen = [i for i, perceptor in enumerate(self._perceptors) if perceptor not in joints]
            angles = np.array([joints.get(perceptor, 0.0) for perceptor in self._perceptors], dtype=float)
        out = np.empty((1, len(angles)))
        velocities_into(self._target_array(lookahead)[None], angles[None], self._gains, out)
        velocities = out[0]
        if unseen:
            velocities[unseen] = 0.0
        return velocities

    def _steer(self, perception: Perception, gait: Steerable) -> None:
        """Where the robot is, then what it walks: towards the next pose while walking, standing
        before (the gait's command is the walk to poses' from the walk's start on)."""
        assert self.pose is not None and self.goto is not None
        self.pose.update(perception, gait.moved())
        if self.phase is Phase.WALKING:
            pose = self.pose.pose
            gait.command = self.goto.command(pose, gait.max_command, gait.max_backward)
            if perception.game.time is not None and readable_vision(perception) is not None:
                self.pose_log.append((perception.game.time, *pose))
        else:
            gait.command = Command()

    def _dithered(self, velocities: np.ndarray) -> np.ndarray:
        """``velocities``, each moved by its own draw of the walk's dither (``AgentConfig.command_noise``)."""
        if self._dither is None:
            return velocities
        if self._noise_row == self._noise.shape[0]:
            noise = self.config.command_noise
            self._noise = self._dither.uniform(-noise, noise, (_NOISE_BLOCK, len(velocities)))
            self._noise_row = 0
        self._noise_row += 1
        return velocities + self._noise[self._noise_row - 1]

    def _beam(self) -> str:
        if self.play_mode in BEAM_PLAY_MODES:
            if self.pose is not None:
                self.pose.reset(self.config.beam)  # a beam puts the robot back where it started
            return commands.beam(*self.config.beam)
        log.info("beam skipped: play mode %s does not allow it", self.play_mode)
        return ""

    def reply(self, perception: Perception) -> str:
        """The message to send after ``perception`` (without ``(syn)``, which the caller adds)."""
        action = self.action(perception)
        if not action.effectors:
            return action.text
        return commands.hinge_velocities(action.velocities) + action.text

    def action(self, perception: Perception) -> Action:
        """What to answer ``perception`` with (``reply`` prints it); advances the behaviour."""
        if perception.game.play_mode is not None:
            self.play_mode = perception.game.play_mode
        if self.phase is Phase.CONNECTING:
            self.phase = Phase.BEAMING
            return Action(text=commands.init(self.config.unum, self.config.team))
        if self.phase is Phase.BEAMING:
            self.phase = Phase.SETTLING
            return Action(text=self._beam())
        if self.phase is Phase.SETTLING:
            if self.settle_cycle >= self.config.settle_cycles and (self.config.start_now or self.play_mode == "PlayOn"):
                self.phase = Phase.WALKING
                log.info("gait started at server time %.2f", perception.time)
            else:
                velocities = self._velocities(perception, 0.0)
                beam = self._beam() if self.settle_cycle == self.config.rebeam_cycle else ""
                self.settle_cycle += 1
                return Action(self._effectors, velocities, beam)
        if self.phase is Phase.WALKING:
            # the first walking reply is gait time 0; after it, one cycle has been walked
            velocities = self._dithered(self._velocities(perception, self.walk_time))
            self.walk_cycles += 1
            if self.fall.update(perception.acc, perception.gyro):
                self.fell_at = self.walk_time
                log.warning(
                    "fall detected after %.2f s of walking (torso tilted past the 0.6 up-z limit)", self.walk_time
                )
            if self.config.duration is not None and self.walk_time >= self.config.duration - 1e-9:
                self.phase = Phase.DONE
            return Action(self._effectors, velocities)
        return Action()
