"""The stand-in's game without sockets: robots, referee, agents' commands, perceptions and the
monitor's scene, one cycle at a time.

``server_stub.net.server.StubServer`` wraps this core in sockets and pacing (which agent sent
what, when a cycle may run, who reads which monitor update). The optimizer's in-process episodes
(``optimizer.episode.inprocess``) drive it directly, with no sockets and no text in between.

One ``step`` is one server cycle: the physics step (0.02 s), the game clock, the referee
(``server_stub.referee``). A caller gives each agent its perception computed after the previous step before
applying what the agent sent, which reproduces the real server's two-cycle action latency (a
reply to perception k first shows in perception k+2).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from protocol.errors import ProtocolError
from protocol.nao import JOINTS, NAO_HETERO_RSG, NAO_RSG, ROBOT_TYPES
from server_stub.agent_state import AgentState
from server_stub.config import PhysicsConfig, RefereeConfig, ServerConfig
from server_stub.game import Game, GameError, beam_pose
from server_stub.net.agent_commands import flat_commands, read_commands
from server_stub.physics.robot import BEAM_HEIGHT, Robot
from server_stub.physics.world import SPAWN_POSITION, World
from server_stub.referee import Referee
from server_stub.sensors.sensing import Sensing

#: Placement after ``repos``: the robot's last beam pose, or its side's default spot.
_DEFAULT_REPOS = {"left": (-5.0, 0.0, 0.0), "right": (5.0, 0.0, 180.0)}
#: Hinge effector name as it arrives on the wire -> its index in ``JOINTS`` (``Robot.command_joint``).
_HINGE_INDEX = {joint.effector.encode(): index for index, joint in enumerate(JOINTS)}
#: Errors a bad command raises; each is reported for that command and the rest of the message goes on.
COMMAND_ERRORS = (GameError, ValueError, KeyError, IndexError, TypeError)

#: ``warn(problem, key)``: how the core reports an agent's ignored command (``Client.warn``).
Warn = Callable[[str, str], None]


class Simulation:
    """The world, the game and every agent's record; no sockets, no clocks of wall time."""

    def __init__(
        self,
        config: ServerConfig = ServerConfig(),
        physics: PhysicsConfig = PhysicsConfig(),
        rules: RefereeConfig = RefereeConfig(),
    ) -> None:
        self.config = config
        # perceptions go out one step late (see the module docstring), so commands act at once
        self.world = World(physics, seed=config.seed, command_delay_steps=0)
        self.game = Game()
        self.referee = Referee(rules, self.game, self.world)
        self.sensing = Sensing(config, self.world)
        #: cycles since the field was last empty: vision and monitor cadences count from it
        self.cycle = 0
        #: every agent's record, in the order they joined (the monitor's scene order)
        self.agents: list[AgentState] = []
        #: robots came or went, or one's team or number changed: the next monitor update is a full scene
        self.scene_changed = False
        self._last_beam: dict[tuple[str, int], tuple[float, float, float]] = {}
        #: the referee's fouls the monitors have been told of
        self._fouls_sent = 0
        # its own stream of the seed, so that beams do not shift the vision noise's draws
        self._beam_rng = np.random.default_rng([config.seed, 1])

    # ----- agents -----
    def join(self) -> AgentState:
        """A new agent, with no robot until it sends ``scene``."""
        state = AgentState()
        self.agents.append(state)
        return state

    def leave(self, state: AgentState) -> bool:
        """The agent is gone; True if it had a robot (now removed: the scene changed)."""
        if state in self.agents:
            self.agents.remove(state)
        if state.robot is None:
            return False
        robot, state.robot = state.robot, None  # nothing may read a removed robot (hearing, vision)
        self.world.remove_robot(robot)
        if not any(s.robot is not None for s in self.agents):
            # vision and monitor cadences restart with the next robot on an empty field, so an
            # episode sees the same cycles whatever ran before it (the optimizer relies on it)
            self.cycle = 0
            self.referee.field_emptied()
        if state.side is not None and state.unum is not None:
            self.game.leave(state.side, state.unum)
        self.scene_changed = True
        return True

    def apply_frame(self, state: AgentState, frame: bytes, warn: Warn) -> bool:
        """Apply one message of an agent; whether any command of it was applied (the rest are
        reported through ``warn`` and ignored)."""
        robot = state.robot
        pairs = flat_commands(frame) if robot is not None else None
        applied = False
        if pairs is not None:  # the common case, every cycle: hinge commands read with no detour
            for name, value in pairs:
                index = _HINGE_INDEX.get(name)
                if index is None:
                    applied |= self._apply_safely(state, name.decode(), [value.decode()] if value else [], warn)
                    continue
                try:
                    assert robot is not None  # pairs are read only for a robot
                    robot.command_joint(index, float(value))
                    applied = True
                except ValueError:  # again by the general path, for its warning
                    applied |= self._apply_safely(state, name.decode(), [value.decode()], warn)
            return applied
        try:
            expressions = read_commands(frame)
        except ProtocolError as exc:
            warn(f"message ignored, it does not parse: {exc}", "parse")
            return False
        for expr in expressions:
            command = expr[0] if expr and isinstance(expr[0], str) else None
            applied |= self._apply_safely(state, command, expr[1:], warn)
        return applied

    def _apply_safely(self, state: AgentState, name: str | None, args: list, warn: Warn) -> bool:
        try:
            self.apply_command(state, name, args)
        except COMMAND_ERRORS as exc:
            problem = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
            warn(f"({name} ...) ignored: {problem}", f"{name}:{type(exc).__name__}")
            return False
        return True

    def apply_command(self, state: AgentState, name: str | None, args: list) -> None:
        """One parsed command (``[name, arg, ...]`` as ``read_commands`` gives it); raises one of
        ``COMMAND_ERRORS`` for a bad one."""
        if name is None:
            raise ValueError("not a command")
        robot = state.robot
        if name == "syn" or name == "pass":
            return
        if robot is not None and name not in ("scene", "init", "beam", "say"):
            robot.command(name, float(args[0]))  # KeyError for an unknown effector
            return
        if name == "scene":
            self._scene(state, args)
        elif name == "init":
            self._init(state, args)
        elif name == "beam":
            self._beam(state, args)
        elif name == "say":
            # the real say effector relays the first word only: (say a b) is heard as "a"
            self.sensing.say(state, str(args[0]) if args else "")
        else:
            raise ValueError(f"unknown effector (robot {'exists' if robot else 'not created yet'})")

    def _scene(self, state: AgentState, args: list) -> None:
        if state.robot is not None:
            raise ValueError("robot already created")
        path = args[0] if args else None
        robot_type = 0
        if path == NAO_HETERO_RSG:
            robot_type = int(args[1]) if len(args) > 1 else 0
            if robot_type not in ROBOT_TYPES:
                raise ValueError(f"robot type {robot_type} not in {ROBOT_TYPES}")
        elif path != NAO_RSG:
            raise ValueError(f"unknown scene {path!r}; known: {NAO_RSG}, {NAO_HETERO_RSG} <type>")
        robot = self.world.add_robot(robot_type)
        # the real server drops every new robot at (0, -1, 1.5); two robots created there before
        # either is beamed would overlap and explode, so later ones hang beside the first
        taken = [s.robot.torso_position() for s in self.agents if s.robot is not None]
        x, y, z = SPAWN_POSITION
        while any(abs(tx - x) < 0.5 and abs(ty - y) < 0.5 for tx, ty, _ in taken):
            x -= 0.6
        if x != SPAWN_POSITION[0]:
            robot.place(x, y, z)
        state.robot = robot
        state.robot_type = robot_type
        self.sensing.add_robot(state)
        self.scene_changed = True

    def _init(self, state: AgentState, args: list) -> None:
        if state.robot is None:
            raise ValueError("init before scene")
        if state.side is not None:
            raise ValueError("already initialised")
        fields = {item[0]: item[1:] for item in args if isinstance(item, list) and item}
        unum = int(fields.get("unum", ["0"])[0])
        team = str(fields.get("teamname", [""])[0])
        if not team:
            raise ValueError("(teamname NAME) missing")
        state.side, state.unum = self.game.join(team, unum)
        state.team = team
        # SimSpark's InitEffector moves it as a beam does, but before the accelerometer reads
        x, y, heading = self.game.init_pose(state.side)
        state.robot.place(x, y, BEAM_HEIGHT, yaw_deg=heading)
        state.announce_identity = True
        self.scene_changed = True

    def _beam(self, state: AgentState, args: list) -> None:
        if state.robot is None:
            raise ValueError("beam before scene")
        if not self.game.beam_allowed():
            return  # silently ignored outside BeforeKickOff / Goal_*, as on the real server
        x, y, rot = (float(a) for a in args[:3])
        if self.config.beam_noise:
            # added to what the agent asked for, in its own half's coordinates, before clipping
            dx, dy, drot = self._beam_rng.uniform(-1.0, 1.0, 3)
            x, y = x + dx * self.config.beam_noise_xy, y + dy * self.config.beam_noise_xy
            rot += drot * self.config.beam_noise_angle
        pose = beam_pose(state.side or "left", x, y, rot)
        state.robot.beam(*pose)
        if state.side is not None and state.unum is not None:
            self._last_beam[(state.side, state.unum)] = pose

    # ----- the cycle -----
    @property
    def active(self) -> bool:
        """Some agent has a robot or is about to ask for one: a cycle has something to do."""
        return any(s.robot is not None or s.inbox for s in self.agents)

    def step(self) -> None:
        """One cycle after the agents' commands: physics, clock, referee (as the real server's
        step runs its game-control aspects after the physics; the referee notes what touches the
        ball as the step begins, where the real server's collision pass does)."""
        self.referee.before_step(self.agents)
        self.world.step()
        self.game.advance()
        self.referee.after_step(self.agents)
        self.cycle += 1
        self.sensing.end_of_cycle()

    @property
    def vision_due(self) -> bool:
        """The perceptions computed after this cycle's step carry ``See``."""
        return self.cycle % self.config.vision_interval == 0

    @property
    def monitor_due(self) -> bool:
        """Monitors get an update after this cycle's step."""
        return self.cycle % self.config.monitor_interval == 0

    def perception(self, state: AgentState, with_vision: bool) -> str:
        """The perception text of one agent's robot, as the real server prints it."""
        return self.sensing.perception(state, self.game, with_vision, self.agents)

    def monitor_messages(self, full_wanted: bool, delta_wanted: bool) -> tuple[str | None, str | None]:
        """(full scene, delta) for the monitors: the full one if some monitor needs it
        (``full_wanted``) or everyone does (the scene changed: then the delta is None), the delta
        if some monitor takes one. Each is made only when asked for: making one moves what the
        next delta is measured against."""
        views = self.sensing.monitor_views(self.agents)
        fouls = self.referee.incapable.fouls
        header = self.sensing.monitor_header(self.game, [f.monitor_item() for f in fouls[self._fouls_sent :]])
        self._fouls_sent = len(fouls)
        ball = self.world.ball_position()
        scene = self.sensing.scene
        everyone_full = self.scene_changed or scene.needs_full(views)
        delta = scene.delta(header, views, ball) if delta_wanted and not everyone_full else None
        full = scene.full(header, views, ball) if everyone_full or full_wanted else None
        self.scene_changed = False
        return full, delta

    # ----- what a trainer may do (server_stub.net.trainer) -----
    def agent_by(self, side: str, unum: int) -> AgentState:
        """The agent playing ``unum`` for ``side`` with a robot; ``GameError`` if there is none."""
        for state in self.agents:
            if state.side == side and state.unum == unum and state.robot is not None:
                return state
        raise GameError(f"no robot {unum} on the {side} team")

    def set_play_mode(self, name: str) -> None:
        self.game.set_play_mode(name)

    def set_game_time(self, t: float) -> None:
        self.game.set_time(t)

    def set_score(self, left: int, right: int) -> None:
        self.game.score_left, self.game.score_right = left, right

    def place_agent(self, side: str, unum: int, pos: tuple[float, float, float], yaw_deg: float | None) -> None:
        self._robot_of(side, unum).place(*pos, yaw_deg=yaw_deg)

    def reposition_agent(self, side: str, unum: int) -> None:
        x, y, heading = self._last_beam.get((side, unum), _DEFAULT_REPOS[side])
        self._robot_of(side, unum).beam(x, y, heading)

    def _robot_of(self, side: str, unum: int) -> Robot:
        robot = self.agent_by(side, unum).robot
        assert robot is not None  # agent_by finds agents with a robot only
        return robot

    def set_ball(self, pos: tuple[float, float, float], vel: tuple[float, float, float]) -> None:
        self.world.set_ball(pos, vel)

    def drop_ball(self) -> None:
        self.referee.drop_ball(self.agents)

    def close(self) -> None:
        self.world.close()
