"""``python -m optimizer.gala``: the paper's Table I protocol, then the fastest walk the family holds.

For each crossover rate (0.1 ... 0.9 unless --crossover is given) a GALA learns the mutation rate and
a final GA gives the row's best gait; CMA-ES then refines the rows' walks, and the fastest walk that
holds 200 walks is handed over as fastest_gait.json with its walk card. --budget quick is a first
look. The stages: optimizer/job.py; what each setting does and why: docs/optimizer.md.

    python -m optimizer.gala --budget quick                  # a first look
    python -m optimizer.gala --crossover 0.8 --seed 1        # one Table I row, then the refinement
    python -m optimizer.gala --resume runs/gala-20261123-101500   # continue after Ctrl-C or kill -9
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from optimizer import settings
from optimizer.job import JobPlan, JobRefused, main_job
from optimizer.run.run_settings import apply_preset
from optimizer.run.session import EvaluatorMaker, pool_evaluator, prepare_run, run_session


def family_setting(names: Sequence[str] | None) -> str | list[str] | None:
    """``--refine-family`` as stored: one family as its name (so that a run of one family has the
    manifest it always had, and resumes as it was made), several as a list."""
    if names is None:
        return None
    return names[0] if len(names) == 1 else list(names)


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = settings.build_parser("gala", "python -m optimizer.gala", __doc__)
    args = parser.parse_args(argv)
    args.refine_family = family_setting(args.refine_family)
    if isinstance(args.refine_family, list) and len(set(args.refine_family)) != len(args.refine_family):
        parser.error(f"--refine-family: a family is given twice ({' '.join(args.refine_family)})")
    apply_preset(args, settings.BUDGETS[args.budget or "paper"])
    tags = [f"pc{pc:g}" for pc in args.crossover or ()]
    if len(set(tags)) != len(tags):
        parser.error(f"--crossover: a rate is given twice ({' '.join(t[2:] for t in tags)})")
    run = prepare_run(parser, args, "gala", argv)
    try:
        plan = JobPlan.of(run)
    except JobRefused as exc:
        parser.error(str(exc))
    return run_session(
        run,
        plan.planned_episodes(),
        lambda driver: main_job(driver, plan),
        make_evaluator=make_evaluator,
        quiet=args.quiet,
    )
