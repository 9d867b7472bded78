"""What each client is told every cycle: agent perceptions (with vision and hearing) and the
monitor stream, assembled from the world's state and the game's."""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from protocol.commands import say_problem
from server_stub.agent_state import AgentState
from server_stub.config import HearingConfig, ServerConfig
from server_stub.game import Game
from server_stub.physics.world import World
from server_stub.sensors.monitor_scene import GameHeader, MonitorScene, RobotView
from server_stub.sensors.perception_text import GameStateText, format_hear, format_perception
from server_stub.sensors.vision import PLAYER_PARTS, SeenRobot, VisionSensor

if TYPE_CHECKING:
    from server_stub.physics.robot import Robot

#: One message a listener may hear from another robot: (the speaker's team, direction, message).
Heard = tuple[str, float, str]


class _Capacity:
    """How much of one kind of message (teammates' or opponents') a robot can still hear, kept
    as rcssserver3d's AgentState keeps it: a message arriving with less than ``cost`` left is
    lost, one heard costs ``cost`` (a later one of the same perception replaces it), and every
    perception gives back ``recovery`` while below ``capacity``. So with the defaults a robot
    that heard a teammate hears no teammate in the next cycle, whoever speaks."""

    def __init__(self, config: HearingConfig) -> None:
        self._config = config
        self._left = config.capacity

    def hear(self, offered: Sequence[Heard]) -> Heard | None:
        """What of ``offered`` (this perception's messages of this kind, in the order they were
        said) reaches the listener; and the perception's recovery."""
        heard = None
        for message in offered:
            if self._left >= self._config.cost:
                self._left -= self._config.cost
                heard = message
        if self._left < self._config.capacity:
            self._left += self._config.recovery
        return heard


class _Ears:
    """A robot's two hearing capacities, teammates' and opponents'."""

    def __init__(self, config: HearingConfig) -> None:
        self.teammates = _Capacity(config)
        self.opponents = _Capacity(config)


def hear_direction(listener: Sequence[float], speaker: Sequence[float], side: str) -> float:
    """The direction (deg) from the listener's torso centre to the speaker's in the listener's
    field frame (turned half round for the right team), not relative to where it faces: how
    rcssserver3d's SoccerRuleAspect::Broadcast measures it, in float32 as it does, so that the
    printed two decimals match."""
    dx, dy = np.float32(speaker[0]) - np.float32(listener[0]), np.float32(speaker[1]) - np.float32(listener[1])
    if side == "right":
        dx, dy = -dx, -dy
    radians = np.float32(math.atan2(dy, dx))
    return float(np.float32(float(radians) * (180.0 / math.pi)))


def within_hearing(listener: Sequence[float], speaker: Sequence[float], reach: float) -> bool:
    """Whether the torso centres are less than ``reach`` apart, in 3-D (float32, as the server's
    bounding sphere test: the squared distance below the squared radius)."""
    offset = np.asarray(speaker, dtype=np.float32) - np.asarray(listener, dtype=np.float32)
    return bool(np.float32(offset @ offset) < np.float32(reach) * np.float32(reach))


class Sensing:
    def __init__(self, config: ServerConfig, world: World) -> None:
        self.config = config
        self.world = world
        self.scene = MonitorScene()
        self._rng = np.random.default_rng(config.seed)
        self._said: list[tuple[AgentState, str]] = []
        self._audible: list[tuple[AgentState, str]] = []
        #: each robot's hearing capacities, gone with the robot
        self._ears: weakref.WeakKeyDictionary[Robot, _Ears] = weakref.WeakKeyDictionary()
        self._seen: list[SeenRobot] | None = None

    # ----- agents -----
    def add_robot(self, state: AgentState) -> None:
        """Each robot's camera gets its own noise stream (and fixed offset) drawn from the seed."""
        child = np.random.default_rng(self._rng.integers(2**63))
        state.vision = VisionSensor(child, noise=self.config.vision_noise, sense_mypos=self.config.sense_mypos)
        assert state.robot is not None  # sensors are made for a robot
        self._ears[state.robot] = _Ears(self.config.hearing)

    def say(self, state: AgentState, message: str) -> None:
        """Queue ``message`` to be heard next cycle. Refused here, where the rules belong: a
        message the real server drops (over 20 characters, or characters it does not allow:
        ``say_problem``), so nobody hears it, not even the speaker; and a ``say`` before ``scene``
        or ``init``, since a message is heard from the speaker's torso and labelled with its team
        (the real server would hand an unnamed robot's message to everyone twice, as teammate
        and as opponent: not reproduced)."""
        if state.robot is None or state.side is None:
            raise ValueError("say before scene and init: a message needs a robot and a team to come from")
        problem = say_problem(message)
        if problem is not None:
            raise ValueError(f"say: {problem}")
        self._said.append((state, message))

    def end_of_cycle(self) -> None:
        """What was said this cycle is heard in the perceptions computed after this step."""
        self._audible, self._said = self._said, []
        self._seen = None

    def _seen_robots(self, states: Sequence[AgentState]) -> list[SeenRobot]:
        if self._seen is None:
            seen = []
            for s in states:
                if s.robot is None or s.team is None:
                    continue  # a robot is shown as (P (team NAME) (id N) ...) only once init named it
                seen.append(SeenRobot(s.team or "", s.unum or 0, s.robot.part_positions(PLAYER_PARTS)))
            self._seen = seen
        return self._seen

    def _hear(self, listener: AgentState, now: float) -> list[str]:
        """The ``hear`` entries of one perception (``now`` the game time): the listener's own
        last message, then the teammate's and the opponent's its capacities let through, as
        rcssserver3d's HearPerceptor orders them."""
        robot = listener.robot
        assert robot is not None  # perceptions are made for robots only
        ears = self._ears[robot]
        own = [message for speaker, message in self._audible if speaker is listener]
        mate = ears.teammates.hear(self._offered(listener, teammates=True))
        opponent = ears.opponents.hear(self._offered(listener, teammates=False))
        heard = [format_hear(listener.team or "", now, None, own[-1])] if own else []
        for other in (mate, opponent):
            if other is not None:
                team, direction, message = other
                heard.append(format_hear(team, now, direction, message))
        return heard

    def _offered(self, listener: AgentState, teammates: bool) -> list[Heard]:
        """This cycle's messages of the listener's teammates (or opponents) within hearing range,
        in the order they were said, each with the team and the direction it comes from. The
        positions are the perception's: the real server measures them as it relays the ``say``,
        in the same state its next perceptions report."""
        robot, side = listener.robot, listener.side
        if robot is None or side is None:
            return []  # a robot not yet in a team is on no team's list: it hears nobody
        said = [
            (speaker.team or "", speaker.robot.torso_position(), message)
            for speaker, message in self._audible
            if speaker is not listener and speaker.robot is not None and (speaker.side == side) == teammates
        ]  # not itself, not a robot gone since, only the kind asked for
        if not said:
            return []
        here = robot.torso_position()
        reach = self.config.hearing.range
        return [
            (team, hear_direction(here, there, side), message)
            for team, there, message in said
            if within_hearing(here, there, reach)
        ]

    def perception(self, state: AgentState, game: Game, with_vision: bool, states: Sequence[AgentState]) -> str:
        robot, camera = state.robot, state.vision
        assert robot is not None and camera is not None  # perceptions are made for robots only
        identity = state.announce_identity and state.side is not None
        gs = GameStateText(
            game.score_left,
            game.score_right,
            game.time,
            game.play_mode,
            state.unum if identity else None,
            state.side if identity else None,
        )
        state.announce_identity = state.announce_identity and not identity
        see = None
        if with_vision:
            position, rotation = robot.head_pose()
            see = camera.see(
                position, rotation, state.side or "left", self.world.ball_position(), self._seen_robots(states)
            )
        return format_perception(
            self.world.time,
            gs,
            robot.gyro(),
            robot.accelerometer(),
            robot.joint_angles(),
            robot.foot_pressure(),
            see,
            self._hear(state, game.time),
            robot.perception_layout,
        )

    # ----- monitors -----
    def monitor_views(self, states: Sequence[AgentState]) -> list[RobotView]:
        return [
            RobotView(s.side, s.unum, s.robot_type, s.robot.part_names, s.robot.part_poses())
            for s in states
            if s.robot is not None
        ]

    def monitor_header(self, game: Game, fouls: Sequence[str] = ()) -> GameHeader:
        return GameHeader(
            game.time,
            game.play_mode,
            game.half,
            game.score_left,
            game.score_right,
            game.team_left,
            game.team_right,
            tuple(fouls),
        )
