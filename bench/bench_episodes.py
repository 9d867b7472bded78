"""Episode throughput of the optimizer's worker pool on the embedded stub, with 1 and 2 workers.

Random gaits from the search box (what a GA's first generation evaluates) mostly fall within a
second, so raw episodes per hour says little; the figure that compares across gaits and machines
is *15-s-episode equivalents per hour*: simulated walking seconds per wall hour, divided by 15.
Parallel efficiency = equivalents/h with N workers / (N x equivalents/h with 1 worker).
Workers are started and warmed up (one episode each) before the clock starts.

With ``--gait FILE`` every episode walks that gait instead (one that does not fall gives the cost
of full 15-s episodes, what a converged population evaluates).

With one worker it also prints the CPU time per walked cycle of the stub server (s) and of the
worker, i.e. the agent and the episode's judge (w), read from /proc: two workers on two cores
run at most at 2/(s + w), so s/(s + w) bounds the parallel efficiency: one worker alone already
uses the second core for its agent while its server steps. So it also measures one worker held
to one core (``sched_setaffinity``; stub and agent take turns on it), the baseline of "one worker
per core", and prints the 2-worker rate against twice that as well.

Run: ``python -m bench.bench_episodes [--episodes 60] [--gait FILE] [--agent-mode inprocess|process] [--dask]``
(``--dask`` also runs the 2-worker case on a Dask LocalCluster and prints its overhead).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from gait import GENE_BOUNDS, load_gait, repair_genes
from optimizer.episode import EpisodeConfig
from optimizer.evaluation.pool import (
    EpisodeRunnerFactory,
    EpisodeTask,
    ProcessPoolEvaluator,
)
from protocol.nao import CYCLE


def gaits(count: int, seed: int) -> list[tuple[float, ...]]:
    rng = np.random.default_rng(seed)
    raw = rng.uniform(GENE_BOUNDS[:, 0], GENE_BOUNDS[:, 1], size=(count, len(GENE_BOUNDS)))
    return [tuple(float(g) for g in repair_genes(row)) for row in raw]


def _evaluator(workers: int, config: EpisodeConfig, dask: bool):
    if dask:
        from optimizer.evaluation.dask_cluster import DaskEvaluator

        return DaskEvaluator(config, seed=0, local_workers=workers)
    factory = EpisodeRunnerFactory(config, seed=0)
    return ProcessPoolEvaluator(factory, workers, task_timeout=2 * config.episode_timeout + 30)


def cpu_seconds() -> dict[str, float]:
    """CPU seconds (user + system) so far of this process's descendants, by kind: the stub
    servers and the workers (agent and judge). Linux only (/proc); empty elsewhere."""
    tree: dict[int, tuple[int, float, str]] = {}
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            stat = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        tree[int(entry.name)] = (int(stat[1]), (int(stat[11]) + int(stat[12])) / os.sysconf("SC_CLK_TCK"), command)
    totals: dict[str, float] = {}
    stack = [os.getpid()]
    while stack:
        parent = stack.pop()
        for pid, (ppid, cpu, command) in tree.items():
            if ppid == parent:
                kind = "stub" if "server_stub" in command else "worker"
                totals[kind] = totals.get(kind, 0.0) + cpu
                stack.append(pid)
    return totals


def measure(
    workers: int, genes: list[tuple[float, ...]], config: EpisodeConfig, dask: bool = False
) -> dict[str, float]:
    pool = _evaluator(workers, config, dask)
    try:
        warm = [EpisodeTask(f"warm/i{k}", g, k) for k, g in enumerate(gaits(workers, seed=99))]
        list(pool.evaluate(warm))
        tasks = [EpisodeTask(f"bench/i{k:03d}", g, k) for k, g in enumerate(genes)]
        cpu_before = cpu_seconds()
        start = time.perf_counter()
        outcomes = list(pool.evaluate(tasks))
        wall = time.perf_counter() - start
        cpu_after = cpu_seconds()
    finally:
        pool.close()
    walked = sum(float(o.result["time"]) for o in outcomes)
    failed = sum(o.result["status"] != "ok" for o in outcomes)
    cycles = walked / CYCLE
    cpu = {
        f"{kind}_ms_per_cycle": (spent - cpu_before.get(kind, 0.0)) / cycles * 1e3 for kind, spent in cpu_after.items()
    }
    return {
        "wall": wall,
        "episodes_per_hour": len(tasks) / wall * 3600,
        "equivalents_per_hour": walked / config.walk_time / wall * 3600,
        "mean_walked": walked / len(tasks),
        "failed": failed,
        **cpu,
    }


def measure_on_one_core(genes: list[tuple[float, ...]], config: EpisodeConfig) -> dict[str, float] | None:
    """``measure`` with one worker whose processes (they inherit this process's CPU set) all run
    on one core: the per-core baseline. Unmeasured (None) where the CPU set cannot be set."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})
    try:
        return measure(1, genes, config)
    finally:
        os.sched_setaffinity(0, cores)


def main() -> None:
    p = argparse.ArgumentParser(prog="python -m bench.bench_episodes", description=__doc__)
    p.add_argument("--episodes", type=int, default=60)
    p.add_argument("--gait", type=Path, default=None, help="walk this gait file every episode")
    p.add_argument("--agent-mode", choices=("inprocess", "process"), default="inprocess")
    p.add_argument("--dask", action="store_true", help="also run the same episodes on a 2-worker Dask LocalCluster")
    args = p.parse_args()
    config = EpisodeConfig(agent_mode=args.agent_mode)
    if args.gait is None:
        genes, what = gaits(args.episodes, seed=1), "random gaits"
    else:
        genes, what = [tuple(load_gait(args.gait).as_array())] * args.episodes, f"x {args.gait.name}"
    results = {n: measure(n, genes, config) for n in (1, 2)}
    pinned = measure_on_one_core(genes, config)
    for n, r in results.items():
        print(
            f"{n} worker(s), {args.episodes} {what} ({args.agent_mode}): {r['wall']:.1f} s wall, "
            f"{r['episodes_per_hour']:.0f} episodes/h, {r['equivalents_per_hour']:.0f} 15-s-episode "
            f"equivalents/h (mean {r['mean_walked']:.2f} s walked per episode, {r['failed']} failed)"
        )
    efficiency = results[2]["equivalents_per_hour"] / (2 * results[1]["equivalents_per_hour"])
    print(f"parallel efficiency with 2 workers: {efficiency:.0%}")
    if pinned is not None:
        per_core = results[2]["equivalents_per_hour"] / (2 * pinned["equivalents_per_hour"])
        print(
            f"1 worker held to one core (its stub and agent share it, as with one worker per core): "
            f"{pinned['equivalents_per_hour']:.0f} equivalents/h; 2 workers on 2 cores against twice that: "
            f"{per_core:.0%}"
        )
    one = results[1]
    if "stub_ms_per_cycle" in one and "worker_ms_per_cycle" in one:
        s, w = one["stub_ms_per_cycle"], one["worker_ms_per_cycle"]
        print(
            f"CPU per walked cycle, 1 worker: stub server s = {s:.3f} ms, worker (agent + judge) w = {w:.3f} ms; "
            f"two workers share 2 cores, so efficiency is at most s/(s+w) = {s / (s + w):.0%}"
        )
    if args.dask:
        d = measure(2, genes, config, dask=True)
        overhead = d["wall"] / results[2]["wall"] - 1
        print(
            f"Dask LocalCluster, 2 workers: {d['wall']:.1f} s wall, {d['equivalents_per_hour']:.0f} "
            f"equivalents/h; overhead against the local pool of 2: {overhead:+.1%} (target <= 10%)"
        )


if __name__ == "__main__":
    main()
