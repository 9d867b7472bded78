"""What each client is told every cycle: agent perceptions (with vision and hearing) and the
monitor stream, assembled from the world's state and the game's."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from protocol.commands import say_problem
from server_stub.agent_state import AgentState
from server_stub.config import ServerConfig
from server_stub.game import Game
from server_stub.physics.world import World
from server_stub.sensors.monitor_scene import GameHeader, MonitorScene, RobotView
from server_stub.sensors.perception_text import GameStateText, format_hear, format_perception
from server_stub.sensors.vision import PLAYER_PARTS, SeenRobot, VisionSensor


class Sensing:
    def __init__(self, config: ServerConfig, world: World) -> None:
        self.config = config
        self.world = world
        self.scene = MonitorScene()
        self._rng = np.random.default_rng(config.seed)
        self._said: list[tuple[AgentState, str]] = []
        self._audible: list[tuple[AgentState, str]] = []
        self._seen: list[SeenRobot] | None = None

    # ----- agents -----
    def add_robot(self, state: AgentState) -> None:
        """Each robot's camera gets its own noise stream (and fixed offset) drawn from the seed."""
        child = np.random.default_rng(self._rng.integers(2**63))
        state.vision = VisionSensor(child, noise=self.config.vision_noise, sense_mypos=self.config.sense_mypos)

    def say(self, state: AgentState, message: str) -> None:
        """Queue ``message`` to be heard next cycle. Only a robot can speak: hearing gives the
        direction from the listener's head to the speaker's, so an agent without one (``say``
        before ``scene``) is refused here, where the rule belongs, not left to fail in every
        other agent's perception."""
        if state.robot is None:
            raise ValueError("say before scene: there is no robot to speak")
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
        heard = []
        for speaker, message in self._audible:
            if speaker.robot is None:
                continue  # left the field after speaking: nothing to hear it from
            if speaker is listener or listener.robot is None:
                direction = None
            else:
                (lx, ly, _), rot = listener.robot.head_pose()
                sx, sy, _ = speaker.robot.head_pose()[0]
                facing = math.atan2(rot[1, 1], rot[0, 1])  # the head looks along its +y axis
                direction = math.degrees(math.atan2(sy - ly, sx - lx) - facing)
                direction = (direction + 180.0) % 360.0 - 180.0
            heard.append(format_hear(speaker.team or "", now, direction, message))
        return heard

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
            self._hear(state, self.world.time),
            robot.perception_layout,
        )

    # ----- monitors -----
    def monitor_views(self, states: Sequence[AgentState]) -> list[RobotView]:
        return [
            RobotView(s.side, s.unum, s.robot_type, s.robot.part_names, s.robot.part_poses())
            for s in states
            if s.robot is not None
        ]

    def monitor_header(self, game: Game) -> GameHeader:
        return GameHeader(
            game.time, game.play_mode, game.half, game.score_left, game.score_right, game.team_left, game.team_right
        )
