"""The stub's socket shell: two listening ports, clients, sync and real-time pacing, around the
socket-free core (``server_stub.simulation.Simulation``: robots, referee, commands, perceptions,
the monitor's scene).

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

import json
import logging
import os
import selectors
import socket
import time
from array import array
from collections.abc import Callable

from protocol.errors import ProtocolError, excerpt
from protocol.nao import CYCLE
from protocol.sexp import parse_sexp
from server_stub import kernels
from server_stub.config import PhysicsConfig, ServerConfig
from server_stub.game import Game, GameError
from server_stub.net.agent_commands import has_syn
from server_stub.net.clients import AgentState, Client
from server_stub.net.trainer import TrainerError, apply_trainer_command
from server_stub.physics.world import World
from server_stub.sensors.sensing import Sensing
from server_stub.simulation import Simulation

log = logging.getLogger("server_stub")


class StubServer:
    """``serve_forever`` until ``(killsim)`` or ``stop``; ports are bound in the constructor."""

    def __init__(self, config: ServerConfig = ServerConfig(), physics: PhysicsConfig = PhysicsConfig()) -> None:
        self.config = config
        kernels.warm_up()  # compile now, not in an agent's first cycle
        self.sim = Simulation(config, physics)
        self.running = False
        self._selector = selectors.DefaultSelector()
        self._agents: dict[Client, AgentState] = {}
        self._monitors: dict[Client, bool] = {}  # monitor -> needs a full scene
        self._agent_listener = self._listen(config.agent_port, "agent")
        self._monitor_listener = self._listen(config.monitor_port, "monitor")
        self.agent_port = self._agent_listener.getsockname()[1]
        self.monitor_port = self._monitor_listener.getsockname()[1]
        # ``stop`` writes a byte here so that a loop waiting in select() wakes at once: a signal
        # handler may call it, and ending the loop this way (not by raising KeyboardInterrupt
        # into whatever runs, a compiled physics kernel included) lets the cycle finish cleanly
        self._wakeup, self._waker = socket.socketpair()
        self._wakeup.setblocking(False)
        self._waker.setblocking(False)
        self._selector.register(self._wakeup, selectors.EVENT_READ, "wakeup")
        #: each cycle's wall seconds (the physics step, the whole cycle) and the play mode it ended
        #: in (``ServerConfig.cycle_times``)
        self._times: tuple[array, array, array] | None = (
            (array("d"), array("d"), array("b")) if config.cycle_times else None
        )

    @property
    def world(self) -> World:
        return self.sim.world

    @property
    def game(self) -> Game:
        return self.sim.game

    @property
    def sensing(self) -> Sensing:
        return self.sim.sensing

    @property
    def cycle(self) -> int:
        return self.sim.cycle

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
            self._agents[client] = self.sim.join()
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
                state.inbox_bytes += len(frame)
                if (
                    len(state.inbox) > self.config.agent_inbox_frames
                    or state.inbox_bytes > self.config.agent_inbox_bytes
                ):
                    self._drop(client, self._flooded(state))
                    return
                if has_syn(frame):
                    state.awaiting_syn = False
            else:
                self._on_trainer_frame(client, frame)

    def _flooded(self, state: AgentState) -> str:
        cfg = self.config
        return (
            f"sent {len(state.inbox)} messages ({state.inbox_bytes} B) in one cycle, over the cap of "
            f"{cfg.agent_inbox_frames} or {cfg.agent_inbox_bytes} B: it does not wait for its perceptions"
        )

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
        if state is not None and self.sim.leave(state) and self.running:
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
                    if key.data == "wakeup":
                        self._drain_wakeup()
                        continue
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
        started = time.perf_counter()
        now = time.monotonic()
        for client, state in self._agents.items():
            if state.next_perception is not None:
                client.send(state.next_perception)
                state.next_perception = None
                state.awaiting_syn = True
                state.sent_at = now
        for client, state in list(self._agents.items()):
            inbox, state.inbox, state.inbox_bytes = state.inbox, [], 0
            self._guarded(client, self._on_agent_frames, client, state, inbox)
        physics = time.perf_counter()
        self.sim.step()
        physics = time.perf_counter() - physics
        with_vision = self.sim.vision_due
        for client, state in list(self._agents.items()):
            if state.robot is not None:
                self._guarded(client, self._perceive, state, with_vision)
        if self.sim.monitor_due:
            self._broadcast_monitor()
        if self._times is not None:
            self._times[0].append(physics)
            self._times[1].append(time.perf_counter() - started)
            self._times[2].append(self.sim.game.play_mode_index)

    def _broadcast_monitor(self) -> None:
        """One update to every monitor: a delta, or a full scene to those that need one (just
        connected, asked with ``reqfullstate``, missed an update) and to all when robots changed."""
        if not self._monitors:
            return
        full, delta = self.sim.monitor_messages(any(self._monitors.values()), not all(self._monitors.values()))
        for monitor, needs_full in list(self._monitors.items()):
            message = full if needs_full or delta is None else delta
            assert message is not None  # made above for whoever needs it
            # a monitor over its buffer cap misses this update and gets a full scene later
            self._monitors[monitor] = not monitor.send(message)
            self._want_write(monitor)

    def _perceive(self, state: AgentState, with_vision: bool) -> None:
        state.next_perception = self.sim.perception(state, with_vision)

    def _on_agent_frames(self, client: Client, state: AgentState, frames: list[bytes]) -> None:
        for frame in frames:
            if client.closed:
                return
            self._on_agent_frame(client, state, frame)

    def _on_agent_frame(self, client: Client, state: AgentState, frame: bytes) -> None:
        """Apply one message; one that is refused whole counts against the client (``_refuse``)."""
        if not self.sim.apply_frame(state, frame, client.warn) and frame.strip():
            self._refuse(client)

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

    def set_play_mode(self, name: str) -> None:
        self.sim.set_play_mode(name)

    def set_game_time(self, t: float) -> None:
        self.sim.set_game_time(t)

    def set_score(self, left: int, right: int) -> None:
        self.sim.set_score(left, right)

    def place_agent(self, side: str, unum: int, pos: tuple[float, float, float], yaw_deg: float | None) -> None:
        self.sim.place_agent(side, unum, pos, yaw_deg)

    def reposition_agent(self, side: str, unum: int) -> None:
        self.sim.reposition_agent(side, unum)

    def kill_agent(self, side: str, unum: int) -> None:
        state = self.sim.agent_by(side, unum)
        client = next(client for client, s in self._agents.items() if s is state)
        self._drop(client, None)

    def set_ball(self, pos: tuple[float, float, float], vel: tuple[float, float, float]) -> None:
        self.sim.set_ball(pos, vel)

    def drop_ball(self) -> None:
        self.sim.drop_ball()

    def request_full_state(self, monitor: object) -> None:
        if monitor in self._monitors:
            self._monitors[monitor] = True

    def kill_sim(self) -> None:
        log.info("killsim received: shutting down")
        self.running = False

    def stop(self) -> None:
        """End ``serve_forever`` after the work in hand; safe to call from a signal handler."""
        self.running = False
        try:
            self._waker.send(b"x")
        except OSError:  # full (a wake-up is pending anyway) or closed
            pass

    def _drain_wakeup(self) -> None:
        try:
            while self._wakeup.recv(64):
                pass
        except OSError:
            pass

    def _write_cycle_times(self) -> None:
        assert self._times is not None
        physics, cycle = ([round(t * 1000.0, 4) for t in times] for times in self._times[:2])
        try:
            with open(self.config.cycle_times, "w") as out:
                json.dump({"physics": physics, "cycle": cycle, "play_mode": list(self._times[2])}, out)
        except OSError as exc:
            log.error("cannot write the cycle times to %s: %s", self.config.cycle_times, exc)

    def close(self) -> None:
        if self._times is not None:
            self._write_cycle_times()
        for client in list(self._agents) + list(self._monitors):
            client.flush()
            self._drop(client, None)
        for listener in (self._agent_listener, self._monitor_listener, self._wakeup):
            try:
                self._selector.unregister(listener)
            except (KeyError, ValueError):
                pass
            listener.close()
        self._waker.close()
        self._selector.close()
        self.sim.close()
