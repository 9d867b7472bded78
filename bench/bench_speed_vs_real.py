"""Speed of the stand-in against a real rcssserver3d, side by side in one sitting.

Three ways to run one optimizer episode (``EpisodeRunner``, 15-s walks from (-5, 0, 0)):

- ``inprocess``: the embedded stand-in in the worker's process, no sockets (the optimizer's default);
- ``socket``: the stand-in as a ``python -m server_stub`` process, the agent over TCP;
- ``real``: a real rcssserver3d (``RCSSSERVER3D``, then PATH; sync profile), the agent over TCP.

**One worker.** ``--rounds`` rounds; in each, every way walks the shipped gait and the fast gait
(``line-10`` of ``bench/fidelity_gaits/held_aside.json``, 13.3 m in 15 s on the real server)
``--episodes`` times, one server alive at a time, the ways taking turns so that all see the same
load. Per way and gait: wall seconds per episode, x real time (seconds walked per wall second), and
CPU seconds per episode (this process: agent and judge; plus the server process's, from /proc).
The ratios are per episode of the same gait (the stand-in's fast walk falls after 0.46 s while the
real server's walks 15 s, so for that gait it also gives the ratio of x real time).

**Two workers.** ``--pool-episodes`` shipped-gait episodes on one worker, then the same number on
each of two workers at once (processes, one runner each), for ``inprocess`` and ``real``: episodes
per wall second and the 2-vs-1 scaling.

**Robots.** The stand-in's cycle with 1, 2, 11 and 22 walking robots in one world (teams of at most
11, placed 3 m apart, each driven by its own ``WalkBehaviour`` as in an in-process episode): CPU per cycle,
its physics step alone, and per robot; then the same robots each in a world of its own, stepped in
turn in one process, to say whether sharing a world pays.

The machine is shared: the load average is printed before and after, and CPU times are the figures
the load moves least.

    python -m bench.bench_speed_vs_real [--rounds 3] [--episodes 3] [--pool-episodes 10] [--cycles 300]
        [--skip-real] [--skip-pool] [--skip-robots]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from agent.behaviour import WalkBehaviour
from agent.config import AgentConfig
from gait import TFS, Gait, load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner
from optimizer.episode.inprocess import InProcessStub, _perception
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs
from optimizer.episode.servers import ServerProcess, StubProcess
from protocol import commands
from protocol.cli_values import positive_int
from protocol.nao import CYCLE
from server_stub.config import ServerConfig
from server_stub.simulation import Simulation

GAITS_DIR = Path(__file__).resolve().parent / "fidelity_gaits"
WAYS = ("inprocess", "socket", "real")


def fast_gait() -> Gait:
    gaits = json.loads((GAITS_DIR / "held_aside.json").read_text())["gaits"]
    params = next(g["params"] for g in gaits if g["name"] == "line-10")
    return TFS.gait([params[name] for name in TFS.gene_names])


def process_cpu(pid: int | None) -> float:
    """CPU seconds (user + system) a process has used so far, from /proc (0 where unreadable)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@dataclass
class Tally:
    walls: list[float] = field(default_factory=list)
    walked: list[float] = field(default_factory=list)
    falls: int = 0
    own_cpu: float = 0.0
    server_cpu: float = 0.0

    def wall(self) -> float:
        return statistics.fmean(self.walls)

    def cpu(self) -> float:
        return (self.own_cpu + self.server_cpu) / len(self.walls)

    def speed(self) -> float:
        return sum(self.walked) / sum(self.walls)


def _runner(way: str, real_command: str | None) -> tuple[EpisodeRunner, ServerProcess | None]:
    if way == "inprocess":
        return EpisodeRunner(EpisodeConfig(embedded_stub="inprocess")), None
    process: ServerProcess = StubProcess() if way == "socket" else RealServerProcess(real_command or "")
    return EpisodeRunner(EpisodeConfig(), process), process


def one_worker(
    rounds: int, episodes: int, ways: Sequence[str], gaits: dict[str, Gait], real_command: str | None
) -> dict[tuple[str, str], Tally]:
    tallies: dict[tuple[str, str], Tally] = {}
    for round_index in range(rounds):
        for way in ways:
            runner, process = _runner(way, real_command)
            with runner:
                runner.evaluate(gaits["shipped"])  # warm-up: the server's start, the first connection
                for name, params in gaits.items():
                    tally = tallies.setdefault((way, name), Tally())
                    for _ in range(episodes):
                        own, server = time.process_time(), process_cpu(process.pid if process else None)
                        started = time.perf_counter()
                        result = runner.evaluate(params)
                        tally.walls.append(time.perf_counter() - started)
                        tally.own_cpu += time.process_time() - own
                        if process is not None:
                            tally.server_cpu += process_cpu(process.pid) - server
                        if result.status != "ok":
                            raise RuntimeError(f"{way}: an episode could not be run: {result.reason}")
                        tally.walked.append(result.time)
                        tally.falls += result.fell
        print(f"  round {round_index + 1}/{rounds} done, load {os.getloadavg()[0]:.2f}", file=sys.stderr)
    return tallies


def _pool_worker(way: str, real_command: str | None, episodes: int, out, go) -> None:
    quiet_agent_logs()
    runner, _ = _runner(way, real_command)
    with runner:
        runner.evaluate(load_gait())
        out.put(("ready", os.getpid()))
        go.wait()
        started, cpu = time.perf_counter(), time.process_time()
        for _ in range(episodes):
            if runner.evaluate(load_gait()).status != "ok":
                raise RuntimeError("an episode could not be run")
        out.put((time.perf_counter() - started, time.process_time() - cpu))


def workers(way: str, count: int, episodes: int, real_command: str | None) -> tuple[float, float]:
    """Episodes per wall second of ``count`` workers walking ``episodes`` each: all warmed up
    (server started, one walk), then started together; the slowest worker's time counts. And the
    workers' own CPU seconds per episode (for ``inprocess`` the whole episode's CPU): if it does not
    grow with two workers, two free cores give two workers twice the rate."""
    context = multiprocessing.get_context("spawn")
    queue, go = context.Queue(), context.Event()
    procs = [context.Process(target=_pool_worker, args=(way, real_command, episodes, queue, go)) for _ in range(count)]
    for proc in procs:
        proc.start()
    for _ in range(count):
        queue.get(timeout=600)  # ready
    go.set()
    done = [queue.get(timeout=600) for _ in range(count)]
    for proc in procs:
        proc.join()
    return count * episodes / max(span for span, _ in done), sum(cpu for _, cpu in done) / (count * episodes)


# ----- robots in one world -----


@dataclass
class Walker:
    sim: Simulation
    behaviour: WalkBehaviour
    state: object
    inbox: list = field(default_factory=list)
    pending: object = None


def _walkers(sim: Simulation, count: int, first: int = 0) -> list[Walker]:
    """``count`` robots on ``sim``, placed 3 m apart on their own halves, settled and walking."""
    out = []
    for k in range(first, first + count):
        team, unum = ("A", k + 1) if k < 11 else ("B", k - 10)
        spot = k % 11
        x, y = -3.0 - 3.0 * (spot % 4), -7.5 + 5.0 * (spot // 4)
        config = AgentConfig(team=team, unum=unum, beam=(x, y, 0.0), sync=True, start_now=True)
        state = sim.join()
        out.append(Walker(sim, WalkBehaviour(config, load_gait().walker()), state, [commands.scene().encode()]))
    return out


def _cycle(sims: Sequence[Simulation], walkers: Sequence[Walker], physics: list[float]) -> None:
    """One cycle of every world as an in-process episode runs it: commands, step, perceptions, replies."""
    for walker in walkers:
        for message in walker.inbox:
            if isinstance(message, bytes):
                walker.sim.apply_frame(walker.state, message, lambda problem, key: None)
            else:
                walker.state.robot.command_joints(message)
        walker.inbox = []
    started = time.process_time()
    for sim in sims:
        sim.step()
    physics[0] += time.process_time() - started
    for walker in walkers:
        delivered, walker.pending = walker.pending, None
        if walker.state.robot is not None:
            walker.pending = _perception(walker.sim, walker.state)
        if delivered is not None:
            walker.inbox = [
                np.array(list(m.values())) if isinstance(m, dict) else m
                for m in InProcessStub._reply(walker.behaviour, delivered)
            ]


def robots(count: int, cycles: int, shared: bool) -> tuple[float, float]:
    """(CPU s per cycle, of which the physics step) with ``count`` walking robots, in one world
    (``shared``) or one world each; timed over ``cycles`` cycles after 60 of beaming and settling."""
    config = ServerConfig(sync=True, realtime=False, beam_noise=False)
    sims = [Simulation(config)] if shared else [Simulation(config) for _ in range(count)]
    walkers = []
    for index, sim in enumerate(sims):
        walkers += _walkers(sim, count if shared else 1, 0 if shared else index)
    physics = [0.0]
    for _ in range(60):
        _cycle(sims, walkers, physics)
    for sim in sims:
        sim.set_play_mode("PlayOn")
    physics[0] = 0.0
    started = time.process_time()
    for _ in range(cycles):
        _cycle(sims, walkers, physics)
    total = time.process_time() - started
    fallen = sum(w.state.robot.torso_position()[2] < 0.25 for w in walkers)
    for sim in sims:
        sim.close()
    if fallen:
        print(f"  ({fallen} of {count} robots fell during the timing)", file=sys.stderr)
    return total / cycles, physics[0] / cycles


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m bench.bench_speed_vs_real",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--rounds", type=positive_int, default=3)
    p.add_argument("--episodes", type=positive_int, default=3, help="episodes per gait, way and round (default 3)")
    p.add_argument("--pool-episodes", type=positive_int, default=10, help="episodes per worker (default 10)")
    p.add_argument("--cycles", type=positive_int, default=300, help="timed cycles per robot count (default 300)")
    p.add_argument("--skip-real", action="store_true", help="no real server (stand-in figures only)")
    p.add_argument("--skip-pool", action="store_true")
    p.add_argument("--skip-robots", action="store_true")
    args = p.parse_args(argv)
    quiet_agent_logs()
    real_command = None
    if not args.skip_real:
        from bench.fidelity import real_server_or_none

        real_command = real_server_or_none()
        if real_command is None:
            return 1
    ways = [w for w in WAYS if w != "real" or real_command]
    print(
        f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}; {os.cpu_count()} cores; "
        f"real server: {real_command}"
    )
    gaits = {"shipped": load_gait(), "fast (line-10)": fast_gait()}
    tallies = one_worker(args.rounds, args.episodes, ways, gaits, real_command)
    print("\none worker, 15-s walks from (-5, 0, 0), ways taking turns:")
    for (way, name), t in tallies.items():
        print(
            f"  {way:<7} {name:<15} {len(t.walls):>3} walks ({t.falls} fell, "
            f"walked {statistics.fmean(t.walked):5.2f} s):"
            f" {t.wall():6.3f} s wall each ({1 / t.wall():5.2f}/s, {t.speed():5.1f}x real time);"
            f" CPU {t.own_cpu / len(t.walls):.3f} s worker + {t.server_cpu / len(t.walls):.3f} s server"
        )
    if real_command:
        for name in gaits:
            real = tallies["real", name]
            for way in ("inprocess", "socket"):
                mine = tallies[way, name]
                print(
                    f"  {way} vs real, {name}: {real.wall() / mine.wall():5.2f}x per episode (wall), "
                    f"{real.cpu() / mine.cpu():5.2f}x per episode (CPU), "
                    f"{mine.speed() / real.speed():5.2f}x in x real time"
                )
    if not args.skip_pool:
        print("\nworkers (shipped gait, one process per worker):")
        for way in [w for w in ("inprocess", "real") if w in ways]:
            one, one_cpu = workers(way, 1, args.pool_episodes, real_command)
            two, two_cpu = workers(way, 2, args.pool_episodes, real_command)
            print(
                f"  {way:<7} 1 worker {one:5.2f} episodes/s, 2 workers {two:5.2f} episodes/s: {two / one:4.2f}x;"
                f" worker CPU per episode {one_cpu:.3f} s alone, {two_cpu:.3f} s two at once"
                f" (load {os.getloadavg()[0]:.2f})"
            )
    if not args.skip_robots:
        print(f"\nrobots walking on the stand-in, {args.cycles} cycles (CPU per cycle):")
        for count in (1, 2, 11, 22):
            total, physics = robots(count, args.cycles, shared=True)
            line = (
                f"  {count:>2} robot(s), one world : {total * 1e3:6.3f} ms/cycle (physics step {physics * 1e3:6.3f}),"
                f" {total / count * 1e3:5.3f} ms per robot, {CYCLE / total:5.1f}x real time"
            )
            if count > 1:
                alone, alone_physics = robots(count, args.cycles, shared=False)
                line += (
                    f"; one world each: {alone * 1e3:6.3f} ms/cycle (physics {alone_physics * 1e3:6.3f}),"
                    f" {alone / count * 1e3:5.3f} ms per robot"
                )
            print(line)
    print(f"\nload average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
