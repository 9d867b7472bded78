"""``python -m optimizer.ga``: one GA with fixed rates (paper Fig. 4, 5, 7), in a run folder.

    python -m optimizer.ga --preset dejong            # (0.6, 0.001), Fig. 4
    python -m optimizer.ga --preset grefenstette      # (0.95, 0.01), Fig. 5
    python -m optimizer.ga --crossover 0.8 --mutation 0.07 --generations 10

Writes manifest.json, episodes.jsonl, results.json, ga.png (best and mean fitness per
generation) and best_gait.json into the run folder (default runs/ga-YYYYmmdd-HHMMSS). The best
gait is then checked as GALA's are (``--check-repeats``, ``--check-jitter``; ``optimizer.run.stability``)
and gets a walk card beside it (best_gait.card.md/.png/.json). Gaits are scored as GALA's are:
robustly over dithered walks by default (``--robust-walks``, ``--command-noise``).
"""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Sequence
from typing import Any

from optimizer.cli.arguments import add_run_arguments
from optimizer.job_ga import PRESETS, ga_job, planned_episodes
from optimizer.run.session import EvaluatorMaker, pool_evaluator, prepare_run, run_session
from optimizer.search.config import (
    GAConfig,
)
from protocol.cli_values import positive_int, probability


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m optimizer.ga", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--preset",
        choices=sorted(PRESETS),
        default=None,
        help="published rates: dejong (0.6, 0.001), grefenstette (0.95, 0.01), gala (0.8, 0.07, "
        "the paper's Table I best; the default); --crossover/--mutation override it",
    )
    p.add_argument("--crossover", type=probability, default=None, help="crossover rate pc")
    p.add_argument("--mutation", type=probability, default=None, help="mutation rate pm (per gene)")
    p.add_argument(
        "--generations", type=positive_int, default=None, help="generations, the random first one included (default 10)"
    )
    add_run_arguments(p)
    return p


def defaults(preset: str | None) -> dict[str, Any]:
    rates = PRESETS[preset or "gala"]
    base = GAConfig()
    return {
        "preset": preset,
        "crossover": rates.crossover_rate,
        "mutation": rates.mutation_rate,
        "population": base.population_size,
        "generations": base.generations,
        "elitism": base.elitism,
    }


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    run = prepare_run(parser, args, "ga", defaults(args.preset), argv)

    body = functools.partial(ga_job, run=run)
    return run_session(run, planned_episodes(run), body, make_evaluator=make_evaluator, quiet=args.quiet)
