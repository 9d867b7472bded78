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
from operator import add

import numpy as np

from agent.config import AgentConfig
from agent.controller import joint_velocities
from agent.fall import FallDetector
from gait import Walker
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


@dataclass(frozen=True)
class Action:
    """One cycle's answer before it is printed: hinge velocities (rad/s by effector name, in
    ``joints_of`` order; empty when none are sent) and the text of any other command after them
    (``init``, ``beam``). A program that hands the velocities to a server without text (the
    optimizer's direct episodes) reads this; ``reply`` prints it."""

    velocities: dict[str, float] = field(default_factory=dict)
    text: str = ""


class WalkBehaviour:
    def __init__(self, config: AgentConfig, gait: Walker) -> None:
        self.config = config
        self.gait = gait
        self.phase = Phase.CONNECTING
        self.settle_cycle = 0
        self.walk_cycles = 0
        self.fall = FallDetector()
        self.fell_at: float | None = None
        self.play_mode: str | None = None
        # every joint of the robot's type, the toes of type 4 too: held at 0 unless told otherwise
        base = {j.effector: 0.0 for j in joints_of(config.robot_type)}
        base.update(config.posture)
        self._posture = base
        self._dither = np.random.default_rng(config.noise_seed) if config.command_noise > 0 else None

    @property
    def walk_time(self) -> float:
        """Seconds of gait time walked so far."""
        return self.walk_cycles * CYCLE

    def targets(self, gait_time: float) -> dict[str, float]:
        """Joint targets in degrees for every joint of the robot's type at ``gait_time``."""
        out = dict(self._posture)
        out.update(self.gait.joint_targets(gait_time, _LIMITS))
        return out

    def _velocities(self, perception: Perception, gait_time: float) -> dict[str, float]:
        lookahead = gait_time + self.config.lookahead_cycles * CYCLE
        return joint_velocities(self.targets(lookahead), perception.joints, self.config.gain)

    def _dithered(self, velocities: dict[str, float]) -> dict[str, float]:
        """``velocities``, each moved by its own draw of the walk's dither (``AgentConfig.command_noise``)."""
        if self._dither is None:
            return velocities
        draws = self._dither.uniform(-self.config.command_noise, self.config.command_noise, len(velocities))
        return dict(zip(velocities, map(add, velocities.values(), draws.tolist())))

    def _beam(self) -> str:
        if self.play_mode in BEAM_PLAY_MODES:
            return commands.beam(*self.config.beam)
        log.info("beam skipped: play mode %s does not allow it", self.play_mode)
        return ""

    def reply(self, perception: Perception) -> str:
        """The message to send after ``perception`` (without ``(syn)``, which the caller adds)."""
        action = self.action(perception)
        if not action.velocities:
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
                return Action(velocities, beam)
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
            return Action(velocities)
        return Action()
