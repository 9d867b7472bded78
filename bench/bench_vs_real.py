"""Speed, stand-in against a real rcssserver3d, side by side in one sitting.

The stand-in exists to be a faster, easier judge than the real server; this says whether it is.
The same ``EpisodeRunner`` walks the shipped gait and the fast real walk (``FAST_REAL``) from
(-5, 0, 0), ``--episodes`` times each, first on the embedded stand-in, then on a real server
started here (``RCSSSERVER3D``, then PATH; sync profile): one server alive at a time. Then the
agent alone (``agent.NaoAgent``, no monitor, no trainer) walks the shipped gait on each, the same
number of times. Each server is warmed up by one untimed walk (its start, the stand-in's kernel
load, the first connection are not counted).

Figures per case: wall seconds per episode, episodes per wall second, and x real time = seconds
walked (game time from the walk's start to its end or fall) per wall second. On a shared machine
the wall figures move with everyone else's load, so each case also gives its CPU seconds (the
server's, from /proc, plus this process's: agent and judge) and x real time per CPU second, the
speed on one core of its own, which the load hardly moves. A gait that falls
early walks few seconds: the stand-in falls with the fast gait in 0.5 s, so its episodes are
short and its x real time is set by the fixed cost of an episode (connect, beam, settle, remove).
The load average is printed: the machine is shared, and rates move with it.

    python bench/bench_vs_real.py [--episodes 5] [--walk-time 15]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agent import AgentConfig, NaoAgent  # noqa: E402
from gait import TFS, Gait, load_gait  # noqa: E402
from optimizer.episode import DEFAULT_START, EpisodeConfig, EpisodeRunner  # noqa: E402
from optimizer.episode.fidelity import FAST_REAL, real_server_or_none  # noqa: E402
from optimizer.episode.real_server import RealServerProcess  # noqa: E402
from optimizer.episode.runner import quiet_agent_logs  # noqa: E402
from optimizer.episode.servers import ServerProcess, StubProcess  # noqa: E402
from protocol.cli_values import positive_float, positive_int  # noqa: E402


@dataclass(frozen=True)
class Timing:
    """Timed walks of one case: each walk's wall seconds and seconds walked."""

    server: str
    case: str
    walls: tuple[float, ...]
    walked: tuple[float, ...]
    falls: int
    #: CPU seconds of all the walks: the server's, and this process's (agent and judge)
    server_cpu: float
    own_cpu: float

    def line(self) -> str:
        wall = statistics.fmean(self.walls)
        speed = sum(self.walked) / sum(self.walls)
        return (
            f"{self.server:<9} {self.case:<38} {len(self.walls):>3} walks ({self.falls} fell): "
            f"{wall:6.3f} s each, {1 / wall:5.2f} episodes/s, {speed:5.1f}x real time "
            f"(walked {statistics.fmean(self.walked):5.2f} s each); CPU {self.server_cpu / len(self.walls):.3f} s "
            f"server + {self.own_cpu / len(self.walls):.3f} s agent each, "
            f"{sum(self.walked) / (self.server_cpu + self.own_cpu):5.1f}x real time per CPU second"
        )


def _process_cpu(pid: int | None) -> float:
    """CPU seconds (user + system) a process has used so far, from /proc (0 where unreadable)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _episodes(
    server: str, process: ServerProcess, runner: EpisodeRunner, gaits: dict[str, Gait], count: int
) -> list[Timing]:
    runner.evaluate(gaits["shipped gait"])  # warm-up: server start, first connection
    out = []
    for name, params in gaits.items():
        walls, walked, falls = [], [], 0
        server_cpu, own_cpu = _process_cpu(process.pid), time.process_time()
        for _ in range(count):
            started = time.perf_counter()
            result = runner.evaluate(params)
            walls.append(time.perf_counter() - started)
            if result.status != "ok":
                raise RuntimeError(f"{server}: an episode could not be run: {result.reason}")
            walked.append(result.time)
            falls += result.fell
        out.append(
            Timing(
                server,
                f"EpisodeRunner, {name}",
                tuple(walls),
                tuple(walked),
                falls,
                _process_cpu(process.pid) - server_cpu,
                time.process_time() - own_cpu,
            )
        )
    return out


def _agent_alone(
    server: str, process: ServerProcess, params: Gait, count: int, walk_time: float, nudge: float | None
) -> Timing:
    """The agent walking on its own: no monitor connection, no trainer; start at once, walk
    ``walk_time`` s, disconnect."""
    address = process.ensure_running()
    config = AgentConfig(
        host=address.host,
        port=address.agent_port,
        beam=DEFAULT_START,
        sync=True,
        duration=walk_time,
        start_now=True,
        syn_nudge_interval=nudge,
    )
    walls, walked, falls = [], [], 0
    server_cpu = own_cpu = 0.0
    for i in range(count + 1):
        cpu_before = (_process_cpu(process.pid), time.process_time())
        started = time.perf_counter()
        report = NaoAgent(config, gait=params).run()
        wall = time.perf_counter() - started
        time.sleep(0.2)  # the server removes the robot of an agent that left
        if i == 0:
            continue  # warm-up
        server_cpu += _process_cpu(process.pid) - cpu_before[0]
        own_cpu += time.process_time() - cpu_before[1]
        walls.append(wall)
        walked.append(report.walk_time)
        falls += report.fell
    return Timing(server, "agent alone, shipped gait", tuple(walls), tuple(walked), falls, server_cpu, own_cpu)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=positive_int, default=5, help="timed walks per gait and server (default 5)")
    p.add_argument("--walk-time", type=positive_float, default=15.0)
    args = p.parse_args(argv)
    quiet_agent_logs()
    command = real_server_or_none()
    if command is None:
        return 1
    gaits = {"shipped gait": load_gait(), "fast gait (13.3 m real)": TFS.gait(FAST_REAL)}
    config = EpisodeConfig(walk_time=args.walk_time)
    servers: list[tuple[str, Callable[[], ServerProcess], float | None]] = [
        ("stand-in", StubProcess, None),  # the stub answers scene at once: no (syn) nudge
        ("real", lambda: RealServerProcess(command), AgentConfig.syn_nudge_interval),
    ]
    print(f"load average before: {os.getloadavg()[0]:.2f}; real server: {command}", file=sys.stderr)
    timings: list[Timing] = []
    for name, make, _ in servers:
        process = make()
        with EpisodeRunner(config, process) as runner:
            timings += _episodes(name, process, runner, gaits, args.episodes)
    for name, make, nudge in servers:
        process = make()
        try:
            timings.append(_agent_alone(name, process, gaits["shipped gait"], args.episodes, args.walk_time, nudge))
        finally:
            process.stop()
    for timing in timings:
        print(timing.line())
    print(f"load average after: {os.getloadavg()[0]:.2f} (2 cores: above ~2 the figures are shared with others)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
