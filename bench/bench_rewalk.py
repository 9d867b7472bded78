"""Re-walk a run's logged episodes: the time an episode takes on a real workload, and proof that
the code walks them exactly as the code that logged them.

A run's ``episodes.jsonl`` holds every walk of a search (genes, family, seed, start) and its
outcome. This walks a seeded sample of them again, in this process, on one runner set up as the
run's workers were (its manifest's walk time, start, dither, family and drift penalty, the
embedded stand-in without sockets), each as a worker runs its task, and compares each record
(distance, fall, time, fitness, speed, status and, for check walks, drift, turn and track: every
field but the wall time and the worker) with the logged one, to the last bit. A search's walks mix the
kinds a default row spends its time on: random gaits that fall within a second, the converged
rows' full walks, the refinement's and the checks'. So ms per episode here is what the main
job's workers pay per walk, and the figure to compare two versions of the in-process path by
(alternate them in one sitting: the machine's speed drifts).

    python -m bench.bench_rewalk runs/gala-.../ [--episodes 300] [--sample-seed 0]

Exit status 1 when an outcome differs from the log.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import random
import sys
import time
from pathlib import Path

from optimizer.episode.runner import EpisodeRunner
from optimizer.evaluation.pool import EpisodeTask
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.folder import RunFolder, RunFolderError, read_episode_log
from optimizer.run.run_settings import course_of, episode_config, manifest_settings

#: What a re-walk may change: how long it took and which worker ran it.
NOT_COMPARED = {"wall", "worker"}


def runner_of(folder: RunFolder) -> EpisodeRunner:
    """One runner as the run's workers had it (the embedded stand-in, in process)."""
    settings = manifest_settings(folder.manifest)
    episode, scoring = settings.episode, settings.scoring
    config = episode_config(
        episode.walk_time,
        episode.start,
        "inprocess",
        scoring.command_noise,
        episode.family,
        scoring.drift_penalty,
        course_of(settings),
        episode.true_pose,
    )
    return EpisodeRunner(config, seed=0)


def rewalked(runner: EpisodeRunner, logged: EpisodeRecord) -> EpisodeRecord:
    """``logged``'s walk again, run as a worker runs its task, recorded as the run recorded it."""
    task = EpisodeTask(
        logged.key,
        logged.genes,
        logged.seed if logged.seed is not None else 0,
        logged.start,
        logged.kind,
        trace=logged.kind is WalkKind.CHECK,
        family=logged.family,
    )
    result = task.run_on(runner)
    return EpisodeRecord.of(task.key, task.genes, task.seed, task.start, task.kind, 0, result, task.family)


def differences(logged: EpisodeRecord, again: EpisodeRecord) -> list[str]:
    """The fields in which the walk again differs from the logged one."""
    return [
        field.name
        for field in dataclasses.fields(EpisodeRecord)
        if field.name not in NOT_COMPARED and getattr(logged, field.name) != getattr(again, field.name)
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.bench_rewalk", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run", type=Path, help="a run folder (manifest.json and episodes.jsonl)")
    parser.add_argument("--episodes", type=int, default=300, help="how many logged walks to re-walk")
    parser.add_argument("--sample-seed", type=int, default=0, help="seed of the sample drawn from the log")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    try:
        folder = RunFolder.open(args.run)
        records, _, _ = read_episode_log(folder.episodes_path)
    except (RunFolderError, FileNotFoundError) as exc:
        parser.error(f"{args.run}: {exc}")
    walks = [record for record in records.values() if record.ran and record.seed is not None]
    if not walks:
        parser.error(f"{args.run}: its log holds no walk with its seed")
    random.Random(args.sample_seed).shuffle(walks)
    sample = walks[: args.episodes]
    logging.disable(logging.WARNING)  # the agents' fall reports
    runner = runner_of(folder)
    rewalked(runner, sample[0])  # kernels loaded, the stand-in made: not timed
    walked = 0.0
    differing = 0
    started = time.perf_counter()
    for logged in sample:
        again = rewalked(runner, logged)
        walked += again.time
        fields = differences(logged, again)
        if fields:
            differing += 1
            print(f"{logged.key}: differs from the log in {', '.join(fields)}")
    wall = time.perf_counter() - started
    n = len(sample)
    print(
        f"{n} logged walks of {args.run.name} re-walked: {wall:.1f} s wall, {1000 * wall / n:.1f} ms per episode, "
        f"{walked / 15.0 / wall * 3600:.0f} 15-s-episode equivalents/h on one core; "
        f"{n - differing} of {n} the same as logged, bit for bit"
    )
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
