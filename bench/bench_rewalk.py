"""Re-walk a run's logged episodes: the time an episode takes on a real workload, and proof that
the code walks them exactly as the code that logged them.

A run's ``episodes.jsonl`` holds every walk of a search (genes, family, seed, start) and its
outcome. This walks a seeded sample of them again, in this process, on one runner set up as the
run's workers were (its manifest's walk time, start, dither, family and drift penalty, the
embedded stand-in without sockets), and compares each outcome (distance, fall, time, fitness and,
for check walks, drift, turn and track) with the log, to the last bit. A search's walks mix the
kinds a default row spends its time on: random gaits that fall within a second, the converged
rows' full walks, the refinement's and the checks'. So ms per episode here is what the main
job's workers pay per walk, and the figure to compare two versions of the in-process path by
(alternate them in one sitting: the machine's speed drifts).

    python bench/bench_rewalk.py runs/gala-.../ [--episodes 300] [--sample-seed 0]

Exit status 1 when an outcome differs from the log.
"""

from __future__ import annotations

import argparse
import json
import logging
import random
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gait import Gait  # noqa: E402
from gait.families import family_named  # noqa: E402
from optimizer.cli.common import episode_config  # noqa: E402
from optimizer.episode.runner import EpisodeRunner  # noqa: E402

#: The outcome fields compared with the log (the last three only in check walks' records).
COMPARED = ("distance", "fell", "time", "fitness", "drift", "heading_change", "track")


def runner_of(run: Path) -> EpisodeRunner:
    """One runner as the run's workers had it (the embedded stand-in, in process)."""
    settings = json.loads((run / "manifest.json").read_text())["settings"]
    config = episode_config(
        settings["walk_time"],
        settings["start"],
        "inprocess",
        settings.get("command_noise", 0.0),
        settings.get("family", "tfs"),
        settings.get("drift_penalty", 0.0),
    )
    return EpisodeRunner(config, seed=0)


def gait_of(record: dict[str, Any]) -> Gait | list[float]:
    """The walk's gait: its genes, of the run's family unless the record names its own."""
    family = record.get("family")
    return record["genes"] if family is None else family_named(family).gait(tuple(record["genes"]))


def differences(record: dict[str, Any], outcome: dict[str, Any]) -> list[str]:
    """The fields in which ``outcome`` (as it would be logged: through JSON) differs from ``record``."""
    logged_again = json.loads(json.dumps(outcome))
    return [key for key in COMPARED if key in record and record[key] != logged_again.get(key)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", type=Path, help="a run folder (manifest.json and episodes.jsonl)")
    parser.add_argument("--episodes", type=int, default=300, help="how many logged walks to re-walk")
    parser.add_argument("--sample-seed", type=int, default=0, help="seed of the sample drawn from the log")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    log_file = args.run / "episodes.jsonl"
    if not log_file.is_file() or not (args.run / "manifest.json").is_file():
        parser.error(f"{args.run} is not a run folder: it needs manifest.json and episodes.jsonl")
    records = [json.loads(line) for line in log_file.read_text().splitlines() if line.strip()]
    records = [r for r in records if r.get("status") == "ok"]
    random.Random(args.sample_seed).shuffle(records)
    sample = records[: args.episodes]
    logging.disable(logging.WARNING)  # the agents' fall reports
    runner = runner_of(args.run)
    runner.evaluate(gait_of(sample[0]))  # kernels loaded, the stand-in made: not timed
    walked = 0.0
    differing = 0
    started = time.perf_counter()
    for record in sample:
        start = tuple(record["start"]) if record.get("start") else None
        outcome = runner.evaluate(
            gait_of(record), seed=record["seed"], start=start, trace=record["kind"] == "check"
        ).to_dict()
        walked += outcome["time"]
        fields = differences(record, outcome)
        if fields:
            differing += 1
            print(f"{record['key']}: differs from the log in {', '.join(fields)}")
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
