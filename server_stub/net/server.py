"""The stub's event loop: two listening ports, the cycle, sync and real-time pacing.

One thread, non-blocking sockets. Each cycle:

1. send every agent the perception computed after the previous step;
2. apply what agents sent since the last cycle (effectors, beam, scene, init, say);
3. step the physics once (0.02 s) and advance the game clock;
4. compute each agent's next perception and, every 2nd cycle, the monitor update.

Sending a perception *before* stepping is how the stub reproduces the real server's two-cycle
action latency (a reply to perception k first shows in perception k+2), and it lets the physics of
the next cycle run while the agent is still thinking about this one: on two cores the agent and
the server overlap instead of taking turns.

Sync mode starts a cycle once every agent that was sent a perception has answered with ``(syn)``
(or ``sync_grace`` seconds passed, as the real server's waits do); real-time mode every 20 ms.
"""

from __future__ import annotations

import logging
import os
import selectors
import socket
import time
from collections.abc import Callable

import numpy as np

from protocol.errors import ProtocolError, excerpt
from protocol.nao import CYCLE, JOINTS, NAO_HETERO_RSG, NAO_RSG, ROBOT_TYPES
from protocol.sexp import parse_sexp
from server_stub import field
from server_stub.config import PhysicsConfig, ServerConfig
from server_stub.game import Game, GameError, beam_pose
from server_stub.net.agent_commands import flat_commands, has_syn, read_commands
from server_stub.net.clients import AgentState, Client
from server_stub.net.trainer import TrainerError, apply_trainer_command
from server_stub.physics.robot import Robot
from server_stub.physics.world import SPAWN_POSITION, World
from server_stub.sensors.sensing import Sensing

log = logging.getLogger("server_stub")

#: Where a new robot appears (docs/robot_and_server.md section 6): in the air, it falls until beamed.
#: Placement after ``repos``: the robot's last beam pose, or its side's default spot.
_DEFAULT_REPOS = {"left": (-5.0, 0.0, 0.0), "right": (5.0, 0.0, 180.0)}
#: Hinge effector name as it arrives on the wire -> its index in ``JOINTS`` (``Robot.command_joint``).
_HINGE_INDEX = {joint.effector.encode(): index for index, joint in enumerate(JOINTS)}


class StubServer:
    """``serve_forever`` until ``(killsim)`` or ``stop``; ports are bound in the constructor."""

    def __init__(self, config: ServerConfig = ServerConfig(), physics: PhysicsConfig = PhysicsConfig()) -> None:
        self.config = config
        # perceptions go out one step late (see the module docstring), so commands act at once
        self.world = World(physics, seed=config.seed, command_delay_steps=0)
        self.game = Game()
        self.sensing = Sensing(config, self.world)
        self.cycle = 0
        self.running = False
        self._selector = selectors.DefaultSelector()
        self._agents: dict[Client, AgentState] = {}
        self._monitors: dict[Client, bool] = {}  # monitor -> needs a full scene
        self._scene_changed = False
        self._last_beam: dict[tuple[str, int], tuple[float, float, float]] = {}
        # its own stream of the seed, so that beams do not shift the vision noise's draws
        self._beam_rng = np.random.default_rng([config.seed, 1])
        self._agent_listener = self._listen(config.agent_port, "agent")
        self._monitor_listener = self._listen(config.monitor_port, "monitor")
        self.agent_port = self._agent_listener.getsockname()[1]
        self.monitor_port = self._monitor_listener.getsockname()[1]

    # ----- sockets -----
    def _listen(self, port: int, kind: str) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((self.config.host, port))
        sock.listen(64)
        sock.setblocking(False)
        self._selector.register(sock, selectors.EVENT_READ, kind)
        return sock

    def _accept(self, listener: socket.socket, kind: str) -> None:
        """Take one waiting connection. A connection can be gone by the time it is accepted (a
        client that connects and resets at once): whatever the socket calls raise then, only that
        connection is dropped."""
        try:
            sock, peer = listener.accept()
        except OSError:
            return
        cap = self.config.agent_out_cap if kind == "agent" else self.config.monitor_out_cap
        try:
            sock.setblocking(False)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            client = Client(sock, kind, self.config.max_frame, cap, peer, self.config)
            self._selector.register(sock, selectors.EVENT_READ, client)
        except OSError as exc:
            log.info("%s connection gone before it was set up (%s)", kind, exc.strerror or exc)
            sock.close()
            return
        if kind == "agent":
            self._agents[client] = AgentState()
        else:
            self._monitors[client] = True
            self._broadcast_monitor()
        log.info("%s connected", client.name)

    def _read(self, client: Client) -> None:
        try:
            data = client.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            # a reset between messages is a way of leaving; in the middle of one it is a problem
            problem = f"connection error ({exc.strerror or exc})"
            self._drop(client, problem if client.decoder.buffered else None)
            return
        if not data:
            self._drop(client, None if not client.decoder.buffered else "vanished in the middle of a frame")
            return
        client.last_heard = time.monotonic()
        try:
            frames = client.decoder.feed(data)
        except ProtocolError as exc:
            self._drop(client, str(exc))
            return
        state = self._agents.get(client)
        for frame in frames:
            if client.closed:
                return  # dropped by one of its own messages (refused too often, or killed)
            if state is not None:
                state.inbox.append(frame)
                if has_syn(frame):
                    state.awaiting_syn = False
            else:
                self._on_trainer_frame(client, frame)

    def _guarded(self, client: Client, handle: Callable[..., object], *args: object) -> None:
        """Run one client's handler behind an error boundary: whatever its input makes the
        handler raise (a bug the input reached, not only the ``ValueError`` of malformed input)
        disconnects that client with one warning line, and the server and everyone else go on."""
        try:
            handle(*args)
        except Exception as exc:  # noqa: BLE001 - the boundary is the point
            log.debug("%s: handler failed", client.name, exc_info=True)
            self._drop(client, f"its input raised {type(exc).__name__}: {exc}")

    def _refuse(self, client: Client) -> None:
        """One message of ``client`` refused whole; a client that keeps sending such is dropped."""
        if client.refused():
            self._drop(
                client,
                f"keeps sending input that is refused (over {self.config.bad_input_burst} "
                f"messages, more than {self.config.bad_input_rate:g} a second)",
            )

    def _drop(self, client: Client, problem: str | None) -> None:
        if client.closed and client not in self._agents and client not in self._monitors:
            return  # dropped already (e.g. by a trainer's kill while its own frame was handled)
        if problem:
            log.warning("%s: %s; disconnected", client.name, excerpt(problem, self.config.warning_quote))
        else:
            log.info("%s disconnected", client.name)
        try:
            self._selector.unregister(client.sock)
        except (KeyError, ValueError):
            pass
        client.close()
        state = self._agents.pop(client, None)
        self._monitors.pop(client, None)
        if state is not None and state.robot is not None:
            robot, state.robot = state.robot, None  # nothing may read a removed robot (hearing, vision)
            self.world.remove_robot(robot)
            if not any(s.robot is not None for s in self._agents.values()):
                # vision and monitor cadences restart with the next robot on an empty field, so an
                # episode sees the same cycles whatever ran before it (the optimizer relies on it)
                self.cycle = 0
            if state.side is not None and state.unum is not None:
                self.game.leave(state.side, state.unum)
            self._scene_changed = True
            if self.running:
                # tell monitors at once: in sync mode with no agent left no cycle would do it
                self._broadcast_monitor()

    def _want_write(self, client: Client) -> None:
        events = selectors.EVENT_READ | (selectors.EVENT_WRITE if client.out else 0)
        try:
            self._selector.modify(client.sock, events, client)
        except (KeyError, ValueError):
            pass

    # ----- the loop -----
    def serve_forever(self) -> None:
        self.running = True
        next_tick = time.monotonic()
        try:
            while self.running:
                timeout = self._select_timeout(next_tick)
                for key, events in self._selector.select(timeout):
                    if key.data in ("agent", "monitor"):
                        assert isinstance(key.fileobj, socket.socket)  # the listeners registered so
                        self._accept(key.fileobj, key.data)
                        continue
                    client: Client = key.data
                    if client.closed:
                        continue
                    if events & selectors.EVENT_WRITE:
                        client.flush()
                        self._want_write(client)
                    if events & selectors.EVENT_READ:
                        self._guarded(client, self._read, client)
                self._reap()
                if self.config.parent_pid and os.getppid() != self.config.parent_pid:
                    log.warning("parent process %d is gone: shutting down", self.config.parent_pid)
                    break
                now = time.monotonic()
                if self.config.realtime:
                    if now >= next_tick and self._ready(now):
                        self._run_cycle()
                        next_tick = max(next_tick + CYCLE, now - CYCLE)
                elif self._ready(now):
                    self._run_cycle()
        finally:
            self.close()

    def _select_timeout(self, next_tick: float) -> float | None:
        if self.config.realtime:
            return max(0.0, next_tick - time.monotonic())
        if self._ready(time.monotonic()):
            return 0.0
        return 0.05 if self._agents or self.config.parent_pid else None

    def _reap(self) -> None:
        """Disconnect clients whose socket failed and agents silent past the timeout."""
        now = time.monotonic()
        for client in list(self._agents) + list(self._monitors):
            if client.closed:
                self._drop(client, "write failed")
            elif (
                self.config.sync
                and client in self._agents
                and self._agents[client].awaiting_syn
                and now - client.last_heard > self.config.agent_timeout
            ):
                self._drop(client, f"silent for more than {self.config.agent_timeout:g} s")
            elif len(client.out) > client.out_cap and client in self._agents:
                self._drop(client, "stopped reading its perceptions")
            elif client.out:
                self._want_write(client)

    def _ready(self, now: float) -> bool:
        """Whether a cycle may run now."""
        active = False
        for state in self._agents.values():
            if state.robot is None and not state.inbox:
                continue
            active = True
            if self.config.sync and state.awaiting_syn and now - state.sent_at < self.config.sync_grace:
                return False
        return active or (self.config.realtime and bool(self._monitors))

    def _run_cycle(self) -> None:
        now = time.monotonic()
        for client, state in self._agents.items():
            if state.next_perception is not None:
                client.send(state.next_perception)
                state.next_perception = None
                state.awaiting_syn = True
                state.sent_at = now
        for client, state in list(self._agents.items()):
            inbox, state.inbox = state.inbox, []
            self._guarded(client, self._on_agent_frames, client, state, inbox)
        self._clear_halves_before_kick_off()
        self.world.step()
        self.game.advance()
        self.cycle += 1
        self.sensing.end_of_cycle()
        with_vision = self.cycle % self.config.vision_interval == 0
        states = list(self._agents.values())
        for client, state in list(self._agents.items()):
            if state.robot is not None:
                self._guarded(client, self._perceive, state, with_vision, states)
        if self.cycle % self.config.monitor_interval == 0:
            self._broadcast_monitor()

    def _clear_halves_before_kick_off(self) -> None:
        """The real referee's rule before kick-off, every cycle: a robot of a team whose body
        reaches into the other team's half is moved to FREE_KICK_MOVE_DIST behind the centre line,
        its y, height and orientation kept (a left-team robot beamed to (0, 0) stands at x -2.5).
        Trainer tools that start walks near the centre line meet it here as on the real server."""
        if self.game.play_mode != "BeforeKickOff":
            return
        for state in self._agents.values():
            robot = state.robot
            if robot is None or state.side not in ("left", "right"):
                continue
            low, high = robot.x_extent()
            if (high > 0.0) if state.side == "left" else (low < 0.0):
                _, y, z = robot.torso_position()
                side = -1.0 if state.side == "left" else 1.0
                robot.place(side * field.FREE_KICK_MOVE_DIST, y, z)

    def _broadcast_monitor(self) -> None:
        """One update to every monitor: a delta, or a full scene to those that need one (just
        connected, asked with ``reqfullstate``, missed an update) and to all when robots changed."""
        if not self._monitors:
            return
        views = self.sensing.monitor_views(list(self._agents.values()))
        header = self.sensing.monitor_header(self.game)
        ball = self.world.ball_position()
        scene = self.sensing.scene
        everyone_full = self._scene_changed or scene.needs_full(views)
        delta = None
        if not everyone_full and not all(self._monitors.values()):
            delta = scene.delta(header, views, ball)
        full = None
        for monitor, needs_full in list(self._monitors.items()):
            if everyone_full or needs_full:
                full = full or scene.full(header, views, ball)
                message = full
            else:
                assert delta is not None  # made above whenever some monitor takes a delta
                message = delta
            # a monitor over its buffer cap misses this update and gets a full scene later
            self._monitors[monitor] = not monitor.send(message)
            self._want_write(monitor)
        self._scene_changed = False

    def _perceive(self, state: AgentState, with_vision: bool, states: list[AgentState]) -> None:
        state.next_perception = self.sensing.perception(state, self.game, with_vision, states)

    def _on_agent_frames(self, client: Client, state: AgentState, frames: list[bytes]) -> None:
        for frame in frames:
            if client.closed:
                return
            self._on_agent_frame(client, state, frame)

    def _on_agent_frame(self, client: Client, state: AgentState, frame: bytes) -> None:
        """Apply one message; one that is refused whole counts against the client (``_refuse``)."""
        if not self._agent_frame_applied(client, state, frame) and frame.strip():
            self._refuse(client)

    def _agent_frame_applied(self, client: Client, state: AgentState, frame: bytes) -> bool:
        """Whether any command of ``frame`` was applied (the rest warned about and ignored)."""
        robot = state.robot
        pairs = flat_commands(frame) if robot is not None else None
        applied = False
        if pairs is not None:  # the common case, every cycle: hinge commands read with no detour
            for name, value in pairs:
                index = _HINGE_INDEX.get(name)
                if index is None:
                    applied |= self._apply_safely(client, state, name.decode(), [value.decode()] if value else [])
                    continue
                try:
                    assert robot is not None  # pairs are read only for a robot
                    robot.command_joint(index, float(value))
                    applied = True
                except ValueError:  # again by the general path, for its warning
                    applied |= self._apply_safely(client, state, name.decode(), [value.decode()])
            return applied
        try:
            expressions = read_commands(frame)
        except ProtocolError as exc:
            client.warn(f"message ignored, it does not parse: {exc}", "parse")
            return False
        for expr in expressions:
            command = expr[0] if expr and isinstance(expr[0], str) else None
            applied |= self._apply_safely(client, state, command, expr[1:])
        return applied

    def _apply_safely(self, client: Client, state: AgentState, name: str | None, args: list) -> bool:
        """One command; a bad one is ignored with one warning naming the client and the problem.
        True if it was applied."""
        try:
            self._apply_agent_command(client, state, name, args)
        except (GameError, ValueError, KeyError, IndexError, TypeError) as exc:
            problem = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
            client.warn(f"({name} ...) ignored: {problem}", f"{name}:{type(exc).__name__}")
            return False
        return True

    def _apply_agent_command(self, client: Client, state: AgentState, name: str | None, args: list) -> None:
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
            self.sensing.say(state, " ".join(str(a) for a in args))
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
        taken = [s.robot.torso_position() for s in self._agents.values() if s.robot is not None]
        x, y, z = SPAWN_POSITION
        while any(abs(tx - x) < 0.5 and abs(ty - y) < 0.5 for tx, ty, _ in taken):
            x -= 0.6
        if x != SPAWN_POSITION[0]:
            robot.place(x, y, z)
        state.robot = robot
        state.robot_type = robot_type
        self.sensing.add_robot(state)
        self._scene_changed = True

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
        state.announce_identity = True
        self._scene_changed = True

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

    # ----- monitors and trainer -----
    def _on_trainer_frame(self, monitor: Client, frame: bytes) -> None:
        """Apply one trainer message; one refused whole counts against the monitor."""
        try:
            expressions = parse_sexp(frame)
        except ProtocolError as exc:
            monitor.warn(f"trainer message ignored, it does not parse: {exc}", "parse")
            self._refuse(monitor)
            return
        applied = not expressions
        for expr in expressions:
            try:
                apply_trainer_command(expr if isinstance(expr, list) else [expr], self, monitor)
                applied = True
            except (TrainerError, GameError, ValueError) as exc:
                monitor.warn(f"trainer command ignored: {exc}", str(exc))
        if not applied:
            self._refuse(monitor)

    def _agent_by(self, side: str, unum: int) -> tuple[Client, AgentState]:
        for client, state in self._agents.items():
            if state.side == side and state.unum == unum and state.robot is not None:
                return client, state
        raise TrainerError(f"no robot {unum} on the {side} team")

    def set_play_mode(self, name: str) -> None:
        self.game.set_play_mode(name)

    def set_game_time(self, t: float) -> None:
        self.game.time = max(0.0, t)

    def set_score(self, left: int, right: int) -> None:
        self.game.score_left, self.game.score_right = left, right

    def place_agent(self, side: str, unum: int, pos: tuple[float, float, float], yaw_deg: float | None) -> None:
        self._robot_of(side, unum).place(*pos, yaw_deg=yaw_deg)

    def reposition_agent(self, side: str, unum: int) -> None:
        x, y, heading = self._last_beam.get((side, unum), _DEFAULT_REPOS[side])
        self._robot_of(side, unum).beam(x, y, heading)

    def _robot_of(self, side: str, unum: int) -> Robot:
        _, state = self._agent_by(side, unum)
        if state.robot is None:
            raise TrainerError(f"player {unum} of the {side} team has no robot")
        return state.robot

    def kill_agent(self, side: str, unum: int) -> None:
        client, _ = self._agent_by(side, unum)
        self._drop(client, None)

    def set_ball(self, pos: tuple[float, float, float], vel: tuple[float, float, float]) -> None:
        self.world.set_ball(pos, vel)

    def drop_ball(self) -> None:
        x, y, _ = self.world.ball_position()
        self.world.set_ball((x, y, field.BALL_RADIUS), (0.0, 0.0, 0.0))
        self.game.set_play_mode("PlayOn")

    def request_full_state(self, monitor: object) -> None:
        if monitor in self._monitors:
            self._monitors[monitor] = True

    def kill_sim(self) -> None:
        log.info("killsim received: shutting down")
        self.running = False

    def stop(self) -> None:
        self.running = False

    def close(self) -> None:
        for client in list(self._agents) + list(self._monitors):
            client.flush()
            self._drop(client, None)
        for listener in (self._agent_listener, self._monitor_listener):
            try:
                self._selector.unregister(listener)
            except (KeyError, ValueError):
                pass
            listener.close()
        self._selector.close()
        self.world.close()
