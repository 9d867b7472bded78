"""``python -m optimizer.gala``: the paper's Table I protocol, then the fastest walk the family holds.

For each crossover rate (0.1 ... 0.9 unless ``--crossover`` is given) a GALA learns the mutation
rate (automata(10) over 0.00 ... 0.09, a = 0.1, b = 0.2, 100 iterations, population 100), then a
final GA with (crossover, optimal mutation) runs ``--generations`` generations and gives the row's
best fitness. ``--budget quick`` is a first look (about 11 minutes on 2 cores).

Every gait is scored robustly by default (``optimizer.run.robust``): a gait whose first walk could
enter its search's top walks ``--robust-walks`` times in all, each with its own draw of the command
dither that reproduces the real server's run-to-run spread, and is scored by their
``--robust-quantile`` (default 0.25: the second-worst of 5), a fall counting the distance it
reached. ``--robust-walks 1 --command-noise 0`` is the paper's single undithered walk (eq. 9).

After the rows, a refinement phase (beyond the paper; ``--refine N``, 0 to skip) runs CMA-ES from
the fastest gait of the rows that held its check and from the best-scored gait (and, with
``--refine-reference``, the quick budget's default, from the reference walk too), its runs raced
(``--refine-race``), for N more gaits, scored the same way but by the worst of a gait's walks
(``--refine-quantile``, default 0: its walk is the one handed over) (``optimizer.cli.refine``,
which ``python -m optimizer.refine`` runs on a gait file of your own):
GALA's population levels off below what the gait family holds. By default it refines them as
tfs-start walks (``--refine-family``, ``gait.tfs_start``): each begun by itself, its start gait
held and its cruise gait searched, because what decides whether a fast TFS gait walks at all is
its first half second, while what makes it fast after that changes smoothly with its genes; the
walk handed over is then a tfs-start gait file. Several families (the quick budget's TFS and
tfs-start) each search their share of the N gaits in turn, and the checks walk the ten
best-scored gaits of each family. Table I is the same with or without it.
``--family`` searches another gait family (``gait.FAMILIES``).

Each row's best gait is then checked (``optimizer.run.stability``): walked ``--check-repeats``
more times (default 10), each with its own dither draw; Table I gives its falls, spread and
verdict (**FALLS** where a check walk fell). The ten best-scored gaits of the whole run (learning
phase and refinement included) are checked the same way, and those that held walk
``--check-confirm`` more (default 20, so that the best of ten is not merely the luckiest): of
those that held them all, the one whose worst check walk went farthest is the run's fastest walk.
At the run's end those walk on towards ``--hand-over-walks`` walks in all (default 200), best
first, each stopped once it fell, and the first that holds them all becomes fastest_gait.json (a
fall one walk in 30 hides in 30 walks a third of the time). When none holds, the rows' walk the
refinement started from walks the same, and is handed over if it holds (the summary names the
faster walk passed over); when it falls too, the steadiest, marked as falling in its notes and in
the summary.

Writes, as each row finishes and after the refinement: table1.csv and table1.md, gala-pc0.8.png
(Fig. 6), ga-pc0.8.png (Fig. 7), best_gait-pc0.8.json and best_gait.json (the final GAs' best:
Table I's gaits), fastest_gait.json, a walk card beside every gait file (``*.card.md``, ``.png``,
``.json``: speed, falls, drift, turn and the torso's tracks of its check walks), results.json; and
episodes.jsonl as each episode finishes (what ``--resume DIR`` continues from).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from gait import FAMILIES, TFS, TFS_START
from optimizer.cli.arguments import LEAD_WALKS_HELP, add_run_arguments, lead_walks, quantile_or_mean
from optimizer.job import JobPlan, JobRefused, main_job
from optimizer.run.run_settings import (
    HAND_OVER_DEFAULTS,
    apply_preset,
)
from optimizer.run.session import EvaluatorMaker, pool_evaluator, prepare_run, run_session
from optimizer.search.config import GAConfig, GALAConfig
from optimizer.search.refine import DEFAULTS as REFINE_DEFAULTS
from optimizer.search.refine import REFINE_QUANTILE
from protocol.cli_values import count, positive_float, positive_int, probability

#: The paper's protocol (section VI).
PAPER: dict[str, Any] = {
    "crossover": list(GALAConfig().crossover_rates),
    "iterations": GALAConfig().iterations,
    "population": GAConfig().population_size,
    "generations": GAConfig().generations,
    "generations_per_iteration": GALAConfig().generations_per_iteration,
    "restart_each_iteration": GALAConfig().restart_each_iteration,
    "scheme": "lrp",
    "elitism": GAConfig().elitism,
    "baseline_window": GALAConfig().baseline_window,
    **REFINE_DEFAULTS,
    "refine": 4000,
    "refine_family": TFS_START.name,
    "refine_quantile": REFINE_QUANTILE,
    "refine_reference": False,
    **HAND_OVER_DEFAULTS,
}

#: The quick budget's refinement families, in turn.
QUICK_FAMILIES = (TFS.name, TFS_START.name)

#: A first look on a 2-core machine: one row (the paper's best crossover rate), population 20,
#: 20 iterations (19 feedbacks to the automaton), a 6-generation final GA (515 gaits), then 3200
#: gaits of refinement, each gait raced as the default scoring says, plus the checks (10 walks for
#: the row's best and for each of the 10 best-scored gaits). Measured in bench/notebook-2026.md.
#: Its refinement searches 1600 TFS gaits, then 1600 tfs-start walks, and hands over the best of
#: both: a quick row's walks are slow and which family climbs from them depends on the seed (with
#: 1600 gaits, seed 1 handed over 8.08 m in TFS and 6.80 m in tfs-start; the README's random seed
#: 1836095818 7.45 m and 13.21 m), and half as many gaits each were too few (seed 1: 7.43 m;
#: bench/RESULTS.md).
#: Its refinement also starts from the reference walk (``--refine-reference``): a quick row's walks
#: can all sit where gaits fall (seed 2696547095: its row's best walked 2.93 m and fell, and it
#: handed over 5.01 m), while CMA-ES from the reference walk climbs (docs/optimizer.md, "The
#: reference start").
#: It races no leaders: its walks are slow and hold without them (three seeds, none fell in 200
#: walks or on the real server), and seed 1's leaders cost it 1,200 walks (a third of its
#: refinement) and 0.8 m (7.28 m handed over, against 8.08 m; docs/optimizer.md, "Leaders").
BUDGETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "quick": {
        "crossover": [0.8],
        "population": 20,
        "iterations": 20,
        "generations": 6,
        "refine": 3200,
        "refine_family": list(QUICK_FAMILIES),
        "refine_lead_walks": 0,
        "refine_reference": True,
    },
}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m optimizer.gala", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--budget",
        choices=sorted(BUDGETS),
        default=None,
        help="paper: the full Table I protocol (default); quick: crossover 0.8, population 20, "
        "20 iterations, 6 final generations, 3200 gaits of refinement (1600 TFS, 1600 tfs-start). "
        "Flags given override it",
    )
    p.add_argument(
        "--crossover",
        type=probability,
        action="append",
        default=None,
        help="a crossover rate (one Table I row); repeat for more rows (default 0.1 ... 0.9)",
    )
    p.add_argument("--iterations", type=positive_int, default=None, help="GALA iterations per row (default 100)")
    p.add_argument(
        "--generations",
        type=positive_int,
        default=None,
        help="generations of the final GA of each row (and of each iteration's GA with "
        "--restart-each-iteration), the first included (default 10)",
    )
    p.add_argument(
        "--generations-per-iteration",
        type=positive_int,
        default=None,
        help="generations the continuing population runs per iteration (default 1)",
    )
    p.add_argument(
        "--restart-each-iteration",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="a fresh GA of --generations generations per iteration instead of one continuing population",
    )
    p.add_argument(
        "--scheme",
        choices=("lrp", "lri"),
        default=None,
        help="learning scheme: lrp (L_R-P, eq. 7-8; default) or lri (L_R-I, eq. 6)",
    )
    p.add_argument(
        "--baseline-window",
        type=positive_int,
        default=None,
        metavar="K",
        help="reward an iteration whose best beats the average of the last K bests "
        "(default: of all preceding bests, as the paper)",
    )
    p.add_argument(
        "--refine",
        type=count,
        default=None,
        metavar="N",
        help=f"after the rows, CMA-ES tries N more gaits from the fastest gait that held its check, scored "
        f"the same way "
        f"(default {PAPER['refine']}; quick {BUDGETS['quick']['refine']}; 0: the paper's protocol alone)",
    )
    p.add_argument(
        "--refine-sigma",
        type=positive_float,
        default=None,
        metavar="S",
        nargs="+",
        help="the first step of each of the refinement's CMA-ES runs, a fraction of the gene box: one run "
        f"per step, the N gaits shared (default {' '.join(map(str, PAPER['refine_sigma']))})",
    )
    p.add_argument(
        "--refine-population",
        type=positive_int,
        default=None,
        metavar="N",
        help=f"gaits per CMA-ES generation of the refinement (default {PAPER['refine_population']}; "
        "the library's own for 7 genes is 9)",
    )
    p.add_argument(
        "--refine-patience",
        type=positive_int,
        default=None,
        metavar="G",
        help="start a refinement run again from its best, with twice the gaits a generation, when its best "
        "has not gained 1%% in G generations (default: only when CMA-ES itself stops)",
    )
    p.add_argument(
        "--refine-race",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="race the refinement's CMA-ES runs (from the fastest gait that held and the best-scored "
        "one, each step) and give the winner half the gaits (default); --no-refine-race: "
        "CMA-ES from the fastest gait alone (and from the reference walk with --refine-reference), "
        "the gaits shared evenly among its runs, as before the race",
    )
    p.add_argument(
        "--refine-quantile",
        type=quantile_or_mean,
        default=None,
        metavar="Q",
        help="score a raced gait of the refinement by this quantile of its walks' fitness, or 'mean' "
        f"(default {PAPER['refine_quantile']:g}: the worst walk, since the refinement's walk is the one "
        "handed over; --robust-quantile scores the rows' gaits)",
    )
    p.add_argument(
        "--refine-lead-walks",
        type=lead_walks,
        default=None,
        metavar="N",
        help=LEAD_WALKS_HELP,
    )
    p.add_argument(
        "--refine-family",
        choices=list(FAMILIES),
        nargs="+",
        default=None,
        metavar="FAMILY",
        help="the gait family the refinement searches, the run's own or one extending it (default "
        f"{PAPER['refine_family']}: the rows' walk begun by itself, its start held and its cruise gait "
        'searched; docs/optimizer.md, "The start-up decides"); several: each searches its share of '
        f"--refine in turn and the checks walk the best of each (quick: {' '.join(QUICK_FAMILIES)}). "
        f"Known: {', '.join(FAMILIES)}",
    )
    p.add_argument(
        "--refine-reference",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the refinement also starts from the reference walk (gait/default_gait.json: the slow "
        "calibration walk, which holds on the real server), besides the rows' walks: a short search's "
        "walks can all sit where gaits fall, and CMA-ES climbs only from where gaits walk (quick: on; "
        'default: off, the rows of 11,000 gaits start higher; docs/optimizer.md, "The reference start")',
    )
    add_run_arguments(p, hand_over=True)
    return p


def family_setting(names: Sequence[str] | None) -> str | list[str] | None:
    """``--refine-family`` as stored: one family as its name (so that a run of one family has the
    manifest it always had, and resumes as it was made), several as a list."""
    if names is None:
        return None
    return names[0] if len(names) == 1 else list(names)


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    args.refine_family = family_setting(args.refine_family)
    if isinstance(args.refine_family, list) and len(set(args.refine_family)) != len(args.refine_family):
        parser.error(f"--refine-family: a family is given twice ({' '.join(args.refine_family)})")
    apply_preset(args, BUDGETS[args.budget or "paper"])
    tags = [f"pc{pc:g}" for pc in args.crossover or ()]
    if len(set(tags)) != len(tags):
        parser.error(f"--crossover: a rate is given twice ({' '.join(t[2:] for t in tags)})")
    run = prepare_run(parser, args, "gala", PAPER, argv)
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
