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

import functools
import sys
from collections.abc import Sequence

from optimizer import settings
from optimizer.job_ga import ga_job, planned_episodes
from optimizer.run.session import EvaluatorMaker, pool_evaluator, prepare_run, run_session


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = settings.build_parser("ga", "python -m optimizer.ga", __doc__)
    args = parser.parse_args(argv)
    # a preset's rates are the defaults; --crossover/--mutation given override them
    preset = settings.GA_PRESETS[args.preset] if args.preset else {}
    run = prepare_run(parser, args, "ga", argv, {**settings.defaults("ga"), **preset})
    body = functools.partial(ga_job, run=run)
    return run_session(run, planned_episodes(run), body, make_evaluator=make_evaluator, quiet=args.quiet)
