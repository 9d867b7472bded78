"""Running one episode (paper eq. 9): a fresh agent walks one gait; the monitor stream scores it
(``optimizer.episode.scoring``).

Everything is read the way a trainer on a real rcssserver3d would: the torso pose from the
monitor stream, control through trainer commands.

Per episode on the server (stub or real, sync mode):
``(playMode BeforeKickOff)(time 0)``; a new agent connects, beams to the start, settles;
``(playMode PlayOn)`` is sent at the cycle its walk starts, so the game clock measures walking time,
with the ball parked 5 m to the side of the start (not before: until PlayOn the referee keeps the
ball at the centre spot); the episode ends at a fall or at ``walk_time``; the agent disconnects and
its robot is removed. Resetting the clock each episode keeps a real server's half (300 s) from
ever ending, so thousands of episodes run on one server.

``python -m optimizer.episode`` evaluates one gait from the command line.
"""

from __future__ import annotations

import logging
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from agent import AgentConfig, AgentError, NaoAgent
from agent.behaviour import WalkBehaviour
from gait import Gait, family_named, save_gait
from optimizer.episode.config import EpisodeConfig, EpisodeResult, Start, parked_ball
from optimizer.episode.inprocess import InProcessStub
from optimizer.episode.monitor_link import EpisodeFailure, MonitorLink
from optimizer.episode.objectives import Judging, judge_for
from optimizer.episode.scoring import TracePoint, find_robot
from optimizer.episode.servers import (
    ManagedServer,
    ServerAddress,
    ServerStartError,
    StubProcess,
)
from protocol import trainer
from protocol.nao import ACTION_LATENCY_CYCLES

#: Cycles between two monitor messages of the server (0.04 s; docs/robot_and_server.md section 4).
MONITOR_CYCLES = 2

log = logging.getLogger("optimizer.episode")


def quiet_agent_logs() -> None:
    """For a process that runs agents in-process, episode after episode: a fall is an episode's
    ordinary outcome, scored from the monitor, and the agent's warning about it would write
    through any progress display. Called by the processes' entry points, not by a library
    constructor."""
    logging.getLogger("agent").setLevel(logging.ERROR)


def play_on(config: EpisodeConfig) -> tuple[str, ...]:
    """The trainer's start of a walk: PlayOn, and the ball parked 5 m to the side of the start,
    out of the walk's way (the same cycle: from PlayOn on the referee leaves the ball where it is)."""
    sx, sy = config.start
    return trainer.play_mode("PlayOn"), trainer.ball(parked_ball(sx, sy), (0.0, 0.0, 0.0))


class EpisodeRunner:
    """Runs episodes one after another on one server: its own embedded stub (the default), a
    server process it is given to own (a real rcssserver3d, ``optimizer.episode.real_server``), or a
    server run elsewhere (an address).

    The embedded stub runs in this process by default, its core and the agent's behaviour driven
    directly with no sockets and no text (``optimizer.episode.inprocess``, ``config.embedded_stub``
    "inprocess", for an in-process agent), with the same results as the stub over sockets
    (``embedded_stub="socket"``, or ``agent_mode="process"``: a ``python -m server_stub`` process).

    A server or agent that dies or hangs is detected, an owned server restarted, the episode retried once;
    if that fails too the episode is returned as failed with its reason. ``evaluate`` never raises
    for such failures, so a worker keeps going. Each episode may start elsewhere (``start``) on
    the same server: a stability check walks one gait from several nearby starts.

    With ``trace=True`` each episode also keeps the torso as the judge saw it in every PlayOn
    state (``last_trace``), for comparing how walks go on two servers; results and logs are the
    same either way.
    """

    def __init__(
        self,
        config: EpisodeConfig = EpisodeConfig(),
        server: ServerAddress | ManagedServer | None = None,
        seed: int = 0,
        trace: bool = False,
    ) -> None:
        self.config = config
        self.trace = trace
        #: the torso track of the last episode evaluated (empty if it failed), when ``trace`` is on
        self.last_trace: list[TracePoint] | None = None
        #: the agent of the last episode walked in this process (not in an agent process): what it
        #: believed along the walk (``WalkBehaviour.pose_log``)
        self.last_agent: WalkBehaviour | None = None
        self._fixed_server = server if isinstance(server, ServerAddress) else None
        self._owned: ManagedServer | None = None
        self._seed = seed
        #: the embedded stub in this process (made at the first episode), when episodes go in process
        self._in_process_stub: InProcessStub | None = None
        self._in_process = server is None and config.agent_mode == "inprocess" and config.embedded_stub == "inprocess"
        if server is None and not self._in_process:
            self._owned = StubProcess(seed=seed)
        elif not isinstance(server, ServerAddress):
            self._owned = server
        self._monitor: MonitorLink | None = None
        self._tmp = tempfile.TemporaryDirectory(prefix="gala_episode_")

    # ----- public -----
    def evaluate(
        self,
        genes: Sequence[float] | Gait,
        seed: int | None = None,
        start: Start | None = None,
        trace: bool = False,
    ) -> EpisodeResult:
        """Walk ``genes`` (of the config's family, or a ``Gait``) once, from ``start`` (x, y,
        heading) if given, else from the config's. ``seed`` seeds the agent's command dither where
        the config asks for one (``EpisodeConfig.command_noise``); otherwise no outcome depends on
        it: the physics is deterministic and the walking agent uses no vision, the only noisy
        sensor. ``trace`` (or the runner's own ``trace``) adds the walk's drift, turn and track to
        the result (``EpisodeResult.track``); what the walk does is the same either way."""
        gait = genes if isinstance(genes, Gait) else family_named(self.config.family).gait(genes)
        config = self.config if start is None else self.config.starting_at(start)
        if seed is not None and config.command_noise > 0:
            config = replace(config, noise_seed=seed)
        traced = trace or self.trace
        started = time.monotonic()
        self.last_trace = [] if self.trace else None
        reason = ""
        for attempt in (1, 2):
            try:
                result = self._episode(gait, config, traced)
                return replace(result, wall=time.monotonic() - started)
            except (EpisodeFailure, AgentError, OSError, ServerStartError) as exc:  # infrastructure, not bugs
                reason = f"{type(exc).__name__}: {exc}"
                log.warning("episode attempt %d failed: %s", attempt, reason)
                self._reset_server()
        return EpisodeResult.failed(reason, time.monotonic() - started)

    def close(self) -> None:
        self._close_monitor()
        self._close_in_process()
        if self._owned is not None:
            self._owned.stop()
        self._tmp.cleanup()

    def _close_in_process(self) -> None:
        if self._in_process_stub is not None:
            self._in_process_stub.close()
            self._in_process_stub = None

    def __enter__(self) -> EpisodeRunner:
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
        self._close_in_process()
        if self._owned is not None:
            self._owned.restart()

    def _close_monitor(self) -> None:
        if self._monitor is not None:
            self._monitor.close()
            self._monitor = None

    def _prepare(self, link: MonitorLink, config: EpisodeConfig) -> None:
        """Reset what a long-running server carries over from the previous episode."""
        link.send(trainer.play_mode("BeforeKickOff"), trainer.set_time(0.0))
        link.poll()

    def _agent_config(self, address: ServerAddress, config: EpisodeConfig) -> AgentConfig:
        sx, sy = config.start
        # our own stub answers scene at once; a (syn) nudge racing its first perception would let
        # it step once more before init and make episodes depend on timing
        nudge = None if isinstance(self._owned, StubProcess) else AgentConfig.syn_nudge_interval
        return AgentConfig(
            host=address.host,
            port=address.agent_port,
            team=config.team,
            unum=config.unum,
            beam=(sx, sy, config.heading),
            sync=True,
            duration=None,
            start_now=True,
            rebeam_cycle=config.rebeam_cycle,
            timeout=config.episode_timeout,
            syn_nudge_interval=nudge,
            command_noise=config.command_noise,
            noise_seed=config.noise_seed,
            robot_type=config.robot_type,
            goals=config.goals,
            true_pose=config.true_pose,
            walk_command=config.command,
        )

    def _episode(self, gait: Gait, config: EpisodeConfig, traced: bool) -> EpisodeResult:
        if self._in_process:
            judge = judge_for(config, traced)
            if self._in_process_stub is None:
                self._in_process_stub = InProcessStub(self._seed)
            self.last_agent = self._in_process_stub.run(gait, config, judge)
            assert judge.result is not None
            self.last_trace = judge.trace if self.trace else None
            return judge.result
        address = self._address()
        link = self._link()
        self._prepare(link, config)
        judge = judge_for(config, traced)
        deadline = time.monotonic() + config.episode_timeout
        if config.agent_mode == "inprocess":
            self._run_inprocess(gait, address, link, judge, deadline)
        else:
            self._run_process(gait, address, link, judge, deadline)
        assert judge.result is not None
        self.last_trace = judge.trace if self.trace else None
        return judge.result

    def _run_inprocess(
        self, gait: Gait, address: ServerAddress, link: MonitorLink, judge: Judging, deadline: float
    ) -> None:
        config = self._agent_config(address, judge.config)
        agent = NaoAgent(config, gait=gait)
        self.last_agent = agent.behaviour
        agent.connect()
        play_on_sent = False
        try:
            while judge.result is None:
                agent.receive()
                if not play_on_sent and agent.settled:
                    # sent between a perception and its reply, so it reaches the server at the
                    # same cycle in every run: the walk and the game clock start together
                    link.send(*play_on(judge.config))
                    play_on_sent = True
                agent.reply()
                for state in link.poll():
                    judge.feed(state)
                if time.monotonic() > deadline:
                    raise EpisodeFailure(f"no result within {judge.config.episode_timeout:g} s")
        finally:
            agent.close()
        self._await_robot_gone(link, deadline)

    def _run_process(
        self, gait: Gait, address: ServerAddress, link: MonitorLink, judge: Judging, deadline: float
    ) -> None:
        gait_file = save_gait(gait, Path(self._tmp.name) / "gait.json")
        config = judge.config
        sx, sy = config.start
        command = [
            sys.executable,
            "-m",
            "agent",
            "--host",
            address.host,
            "--port",
            str(address.agent_port),
            "--team",
            config.team,
            "--unum",
            str(config.unum),
            "--gait",
            str(gait_file),
            "--beam",
            str(sx),
            str(sy),
            str(config.heading),
            "--sync",
            "--start-now",
            "--rebeam-cycle",
            "none" if config.rebeam_cycle is None else str(config.rebeam_cycle),
            "--timeout",
            str(config.episode_timeout),
            "--command-noise",
            repr(config.command_noise),
            "--noise-seed",
            str(config.noise_seed),
            *[arg for goal in config.goals for arg in ("--goto", *map(str, goal))],
            *([] if config.true_pose else ["--no-true-pose"]),
            *([] if config.command is None else ["--command", *map(repr, config.command)]),
        ]
        process = subprocess.Popen(
            command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=dict(os.environ)
        )
        try:
            # an agent process walks by its own count after settling; PlayOn starts the game clock
            # once the robot has its team (init done) and has stood for the settling time, counted
            # in monitor states: one every MONITOR_CYCLES cycles, plus the action latency
            settle_states = 0
            wanted = math.ceil((AgentConfig.settle_cycles + ACTION_LATENCY_CYCLES) / MONITOR_CYCLES)
            play_on_sent = False
            while judge.result is None:
                for state in link.poll(wait=0.05):
                    robot = find_robot(state, "left", config.unum)
                    if robot is not None and not play_on_sent:
                        settle_states += 1
                        if settle_states >= wanted:
                            link.send(*play_on(config))
                            play_on_sent = True
                    judge.feed(state)
                if process.poll() is not None:
                    raise EpisodeFailure(
                        f"agent process exited early ({process.returncode}): "
                        f"{(process.stderr.read() if process.stderr else '').strip()}"
                    )
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
            if find_robot(link.reader.state, "left", self.config.unum) is None:
                return
            link.poll(wait=0.05)
        raise EpisodeFailure("the previous robot was not removed from the server")
