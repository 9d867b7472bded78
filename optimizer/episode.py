"""One episode (paper eq. 9): a fresh agent walks one gait; the monitor stream scores it.

Fitness = 10 x the torso's displacement along the walking direction from where it stood when its
walk began, taken when the robot falls (torso up-vector z < 0.6 or torso height < 0.25 m, the
community's run-benchmark rule) or when ``walk_time`` seconds of game time have passed.
Everything is read the way a trainer on a real rcssserver3d would: the torso pose from the
monitor stream, control through trainer commands.

Per episode on the server (stub or real, sync mode):
``(playMode BeforeKickOff)(time 0)``, the ball parked out of the way; a new agent connects, beams
to the start, settles; ``(playMode PlayOn)`` is sent at the cycle its walk starts, so the game clock
measures walking time; the episode ends at a fall or at ``walk_time``; the agent disconnects and
its robot is removed. Resetting the clock each episode keeps a real server's half (300 s) from
ever ending, so thousands of episodes run on one server.

``python -m optimizer.episode`` evaluates one gait from the command line.
"""
from __future__ import annotations

import logging
import math
import os
import select
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from agent import AgentConfig, AgentError, NaoAgent
from gait import TFSParams, save_gait
from optimizer.servers import ManagedServer, ServerAddress, StubProcess
from protocol import trainer
from protocol.framing import FrameDecoder, encode_frame
from protocol.monitor import MonitorReader, MonitorState, RobotPose

log = logging.getLogger("optimizer.episode")

__all__ = ["DEFAULT_START", "EpisodeConfig", "EpisodeResult", "EpisodeRunner", "ServerAddress", "Start",
           "TracePoint", "start_problem_on_real_server"]

#: A start point on the field: x, y (m) and heading (deg, 0 = +x).
Start = tuple[float, float, float]

#: Where walks start unless told otherwise: 5 m into the own half, facing the opponent goal. Not
#: the paper's x = y = 0: that is the origin of the measurement (the distance is counted from where
#: the torso stands at PlayOn), not a field position. A real server's referee moves a left-team
#: robot whose body reaches into the right half (x > 0) 2.5 m back before kick-off, so a walk
#: beamed to (0, 0) would start at about x = -2.5 while the trainer believes it at 0. From x = -5
#: the fastest walks known (0.9 m/s for 15 s) end near x = 8.5, inside the 15 m half.
DEFAULT_START: Start = (-5.0, 0.0, 0.0)

#: The left team's robot must stay this far behind the centre line to be left alone before
#: kick-off on a real server (its colliders reach ~0.15 m from the torso; the referee moves any
#: robot whose bounding box enters the right half).
_REFEREE_MARGIN = 0.5


def start_problem_on_real_server(start: Start) -> str | None:
    """Why a real server would not leave a robot beamed to ``start`` where it was put (None when
    it would): its referee clears the opponent half before kick-off."""
    if start[0] > -_REFEREE_MARGIN:
        return (f"x = {start[0]:g} m: a real server's referee moves a left-team robot within "
                f"{_REFEREE_MARGIN:g} m of the centre line (or past it) 2.5 m back before kick-off, so the walk "
                f"would not start there; start at x <= {-_REFEREE_MARGIN:g} (default {DEFAULT_START[0]:g})")
    return None


@dataclass(frozen=True)
class EpisodeConfig:
    #: Seconds of walking (game time after PlayOn) before the walk is scored (paper: 15 s).
    walk_time: float = 15.0
    #: Start point (x, y) and heading (deg, 0 = +x) on the field: where the robot is beamed, and
    #: the direction along which its distance is measured (from where its torso is at PlayOn).
    start: tuple[float, float] = DEFAULT_START[:2]
    heading: float = DEFAULT_START[2]
    #: "inprocess": a fresh ``agent.NaoAgent`` per episode in this process, over the same socket
    #: protocol (fast, default); "process": a fresh ``python -m agent`` process per episode.
    agent_mode: str = "inprocess"
    #: Wall seconds an episode may take before the server or agent is declared hung.
    episode_timeout: float = 60.0
    team: str = "GALA"
    unum: int = 1
    #: Fall rule (community run benchmark): torso up-vector z below / torso height below.
    fall_up_z: float = 0.6
    fall_height: float = 0.25

    def starting_at(self, start: Start) -> "EpisodeConfig":
        """This config with another start point and heading."""
        x, y, heading = start
        return replace(self, start=(float(x), float(y)), heading=float(heading))

    def __post_init__(self) -> None:
        if not self.walk_time > 0:
            raise ValueError(f"walk_time must be > 0 s, got {self.walk_time}")
        if self.agent_mode not in ("inprocess", "process"):
            raise ValueError(f"agent_mode must be 'inprocess' or 'process', got {self.agent_mode!r}")
        if not self.episode_timeout > 0:
            raise ValueError(f"episode_timeout must be > 0 s, got {self.episode_timeout}")


@dataclass(frozen=True)
class EpisodeResult:
    distance: float
    fell: bool
    time: float
    fitness: float
    mean_speed: float
    status: str = "ok"
    reason: str = ""
    wall: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def failed(cls, reason: str, wall: float) -> "EpisodeResult":
        """An episode the infrastructure could not run; fitness 0 so that the search goes on."""
        return cls(0.0, False, 0.0, 0.0, 0.0, "failed", reason, wall)


@dataclass(frozen=True)
class TracePoint:
    """What the judge saw of the torso in one PlayOn monitor state (``EpisodeRunner(trace=True)``):
    the walk's shape (drift, turning, the moment of a fall), which the score alone hides.
    ``heading`` is the azimuth of the torso's forward axis (deg, atan2 of its y over its x)."""

    game_time: float
    x: float
    y: float
    z: float
    up_z: float
    heading: float


class EpisodeFailure(RuntimeError):
    """The server or the agent died, hung or misbehaved: not the gait's fault."""


#: Bytes asked of the monitor socket per read (a full scene larger than this arrives in several).
#: Not more: ``recv(n)`` allocates n bytes every call, and 1 MB cost ~13 us per read.
_RECV_SIZE = 1 << 16


class MonitorLink:
    """A trainer's connection to the monitor port: sends commands, follows the stream."""

    def __init__(self, address: ServerAddress, timeout: float) -> None:
        self._sock = socket.create_connection((address.host, address.monitor_port), timeout=timeout)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._decoder = FrameDecoder()
        self.reader = MonitorReader()

    def send(self, *commands: str) -> None:
        for command in commands:
            self._sock.sendall(encode_frame(command))

    def poll(self, wait: float = 0.0) -> list[MonitorState]:
        """Every monitor state that arrived, oldest first (waits up to ``wait`` s for the first)."""
        states: list[MonitorState] = []
        while True:
            ready, _, _ = select.select([self._sock], [], [], wait)
            if not ready:
                return states
            data = self._sock.recv(_RECV_SIZE)
            if not data:
                raise EpisodeFailure("the server closed the monitor connection")
            states.extend(self.reader.feed(frame) for frame in self._decoder.feed(data))
            wait = 0.0

    def close(self) -> None:
        self._sock.close()


def _find_robot(state: MonitorState, side: str, unum: int) -> RobotPose | None:
    for robot in state.robots:
        if robot.team == side and robot.unum == unum:
            return robot
    return None


class _Judge:
    """Watches monitor states in order and decides, from their content alone, when and how an
    episode ends; so the outcome does not depend on when the states happen to be read.

    The distance is the torso's displacement from where it stood when the walk began (the first
    PlayOn state), along the configured heading. Not from the configured start: a server moves a
    beam off its target (the left team's beam is clipped to x <= 0, so a stability check's start
    at x = +0.03 lands at 0, and a real server adds up to 5 cm of beam noise), and the torso
    settles away from the beamed point (by a median 2 mm, up to 6 cm for random gaits); measured
    from the target, each of these would be counted as walking."""

    def __init__(self, config: EpisodeConfig, trace: bool = False) -> None:
        self.config = config
        self.result: EpisodeResult | None = None
        self._heading = math.radians(config.heading)
        self._origin: tuple[float, float] | None = None
        #: every PlayOn state judged, when asked for (None otherwise: the search does not pay for it)
        self.trace: list[TracePoint] | None = [] if trace else None

    def feed(self, state: MonitorState) -> None:
        if self.result is not None or state.play_mode != "PlayOn":
            return
        robot = _find_robot(state, "left", self.config.unum)
        if robot is None:
            return
        x, y, z = robot.position
        if self._origin is None:
            self._origin = (x, y)
        if self.trace is not None:
            fx, fy = robot.forward[0], robot.forward[1]
            self.trace.append(TracePoint(state.game_time, x, y, z, robot.up[2], math.degrees(math.atan2(fy, fx))))
        fell = robot.up[2] < self.config.fall_up_z or z < self.config.fall_height
        if fell or state.game_time >= self.config.walk_time - 1e-6:
            sx, sy = self._origin
            distance = (x - sx) * math.cos(self._heading) + (y - sy) * math.sin(self._heading)
            t = min(state.game_time, self.config.walk_time)
            speed = distance / t if t > 0 else 0.0
            self.result = EpisodeResult(distance, fell, t, 10.0 * distance, speed)


class EpisodeRunner:
    """Runs episodes one after another on one server: its own embedded stub (the default), a
    server process it is given to own (a real rcssserver3d, ``optimizer.real_server``), or a
    server run elsewhere (an address).

    A server or agent that dies or hangs is detected, an owned server restarted, the episode retried once;
    if that fails too the episode is returned as failed with its reason. ``evaluate`` never raises
    for such failures, so a worker keeps going. Each episode may start elsewhere (``start``) on
    the same server: a stability check walks one gait from several nearby starts.

    With ``trace=True`` each episode also keeps the torso as the judge saw it in every PlayOn
    state (``last_trace``), for comparing how walks go on two servers; results and logs are the
    same either way.
    """

    def __init__(self, config: EpisodeConfig = EpisodeConfig(),
                 server: ServerAddress | ManagedServer | None = None, seed: int = 0, trace: bool = False) -> None:
        self.config = config
        self.trace = trace
        #: the torso track of the last episode evaluated (empty if it failed), when ``trace`` is on
        self.last_trace: list[TracePoint] | None = None
        self._fixed_server = server if isinstance(server, ServerAddress) else None
        self._owned: ManagedServer | None = None
        if self._fixed_server is None:
            self._owned = StubProcess(seed=seed) if server is None else server
        self._monitor: MonitorLink | None = None
        self._tmp = tempfile.TemporaryDirectory(prefix="gala_episode_")
        # a fall is an episode's ordinary outcome, scored from the monitor: in-process agents need
        # not log it (and would write through any progress display)
        logging.getLogger("agent").setLevel(logging.ERROR)

    # ----- public -----
    def evaluate(self, genes: Sequence[float] | TFSParams, seed: int | None = None,
                 start: Start | None = None) -> EpisodeResult:
        """Walk ``genes`` once, from ``start`` (x, y, heading) if given, else from the config's.
        ``seed`` is accepted for the evaluator's bookkeeping; no outcome depends on it: the
        physics is deterministic and the walking agent uses no vision, the only noisy sensor."""
        params = genes if isinstance(genes, TFSParams) else TFSParams.from_array(list(genes))
        config = self.config if start is None else self.config.starting_at(start)
        started = time.monotonic()
        self.last_trace = [] if self.trace else None
        reason = ""
        for attempt in (1, 2):
            try:
                result = self._episode(params, config)
                return EpisodeResult(**{**result.to_dict(), "wall": time.monotonic() - started})
            except (EpisodeFailure, AgentError, OSError, RuntimeError) as exc:
                reason = f"{type(exc).__name__}: {exc}"
                log.warning("episode attempt %d failed: %s", attempt, reason)
                self._reset_server()
        return EpisodeResult.failed(reason, time.monotonic() - started)

    def close(self) -> None:
        self._close_monitor()
        if self._owned is not None:
            self._owned.stop()
        self._tmp.cleanup()

    def __enter__(self) -> "EpisodeRunner":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----- one episode -----
    def _address(self) -> ServerAddress:
        if self._owned is not None:
            return self._owned.ensure_running()
        assert self._fixed_server is not None
        return self._fixed_server

    def _link(self) -> MonitorLink:
        if self._monitor is None:
            self._monitor = MonitorLink(self._address(), self.config.episode_timeout)
        return self._monitor

    def _reset_server(self) -> None:
        self._close_monitor()
        if self._owned is not None:
            self._owned.restart()

    def _close_monitor(self) -> None:
        if self._monitor is not None:
            self._monitor.close()
            self._monitor = None

    def _prepare(self, link: MonitorLink, config: EpisodeConfig) -> None:
        """Reset what a long-running server carries over from the previous episode."""
        sx, sy = config.start
        link.send(trainer.play_mode("BeforeKickOff"), trainer.set_time(0.0),
                  trainer.ball((sx, sy + 5.0, 0.042), (0.0, 0.0, 0.0)))
        link.poll()

    def _agent_config(self, address: ServerAddress, config: EpisodeConfig) -> AgentConfig:
        sx, sy = config.start
        # our own stub answers scene at once; a (syn) nudge racing its first perception would let
        # it step once more before init and make episodes depend on timing
        nudge = None if isinstance(self._owned, StubProcess) else AgentConfig.syn_nudge_interval
        return AgentConfig(host=address.host, port=address.agent_port, team=config.team,
                           unum=config.unum, beam=(sx, sy, config.heading), sync=True,
                           duration=None, start_now=True, timeout=config.episode_timeout,
                           syn_nudge_interval=nudge)

    def _episode(self, params: TFSParams, config: EpisodeConfig) -> EpisodeResult:
        address = self._address()
        link = self._link()
        self._prepare(link, config)
        judge = _Judge(config, self.trace)
        deadline = time.monotonic() + config.episode_timeout
        if config.agent_mode == "inprocess":
            self._run_inprocess(params, address, link, judge, deadline)
        else:
            self._run_process(params, address, link, judge, deadline)
        assert judge.result is not None
        self.last_trace = judge.trace
        return judge.result

    def _run_inprocess(self, params: TFSParams, address: ServerAddress, link: MonitorLink,
                       judge: _Judge, deadline: float) -> None:
        config = self._agent_config(address, judge.config)
        agent = NaoAgent(config, gait=params)
        agent.connect()
        play_on_sent = False
        try:
            while judge.result is None:
                agent.receive()
                if not play_on_sent and agent.behaviour.settle_cycle >= config.settle_cycles:
                    # sent between a perception and its reply, so it reaches the server at the
                    # same cycle in every run: the walk and the game clock start together
                    link.send(trainer.play_mode("PlayOn"))
                    play_on_sent = True
                agent.reply()
                for state in link.poll():
                    judge.feed(state)
                if time.monotonic() > deadline:
                    raise EpisodeFailure(f"no result within {judge.config.episode_timeout:g} s")
        finally:
            agent.close()
        self._await_robot_gone(link, deadline)

    def _run_process(self, params: TFSParams, address: ServerAddress, link: MonitorLink,
                     judge: _Judge, deadline: float) -> None:
        gait_file = save_gait(params, Path(self._tmp.name) / "gait.json")
        config = judge.config
        sx, sy = config.start
        command = [sys.executable, "-m", "agent", "--host", address.host, "--port", str(address.agent_port),
                   "--team", config.team, "--unum", str(config.unum), "--gait", str(gait_file),
                   "--beam", str(sx), str(sy), str(config.heading), "--sync", "--start-now",
                   "--timeout", str(config.episode_timeout)]
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                   env=dict(os.environ))
        try:
            # the agent walks by its own count after settling; PlayOn starts the game clock once
            # the robot has its team (init done) and has stood for the settling time
            settle_messages = 0
            play_on_sent = False
            while judge.result is None:
                for state in link.poll(wait=0.05):
                    robot = _find_robot(state, "left", config.unum)
                    if robot is not None and not play_on_sent:
                        settle_messages += 1
                        if settle_messages * 2 >= AgentConfig.settle_cycles + 2:
                            link.send(trainer.play_mode("PlayOn"))
                            play_on_sent = True
                    judge.feed(state)
                if process.poll() is not None:
                    raise EpisodeFailure(f"agent process exited early ({process.returncode}): "
                                         f"{(process.stderr.read() if process.stderr else '').strip()}")
                if time.monotonic() > deadline:
                    raise EpisodeFailure(f"no result within {judge.config.episode_timeout:g} s")
            link.send(trainer.kill(config.unum, "Left"))
            process.wait(timeout=max(1.0, deadline - time.monotonic()))
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
            if process.stderr is not None:
                process.stderr.close()
        self._await_robot_gone(link, deadline)

    def _await_robot_gone(self, link: MonitorLink, deadline: float) -> None:
        """The next episode's robot must not meet this one's: wait until the server removed it."""
        while time.monotonic() < deadline:
            if _find_robot(link.reader.state, "left", self.config.unum) is None:
                return
            link.poll(wait=0.05)
        raise EpisodeFailure("the previous robot was not removed from the server")


if __name__ == "__main__":
    from optimizer.episode_command import main

    raise SystemExit(main())
