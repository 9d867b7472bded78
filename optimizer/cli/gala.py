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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gait import DEFAULT_GAIT_PATH, FAMILIES, TFS, TFS_START, GaitFamily, family_named, load_gait
from optimizer.cli.common import (
    HAND_OVER_DEFAULTS,
    EvaluatorMaker,
    Run,
    add_run_arguments,
    apply_preset,
    best_gait,
    card_of,
    hand_over,
    in_box,
    pool_evaluator,
    prepare_run,
    quantile_or_mean,
    run_family,
    run_session,
    search_box,
    stability_config,
    write_gait,
)
from optimizer.cli.refine import DEFAULTS as REFINE_DEFAULTS
from optimizer.cli.refine import LEAD_WALKS_HELP, REFINE_QUANTILE, lead_walks, refine, refine_starts
from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.report import (
    TableRow,
    plot_ga_convergence,
    plot_gala_convergence,
    write_table_csv,
    write_table_markdown,
)
from optimizer.run.robust import ScoredGait
from optimizer.run.stability import (
    Fastest,
    StabilityReport,
    check_best,
    fastest_walk,
    scored_summary,
)
from optimizer.run.walk_card import write_card
from optimizer.search.config import GAConfig, GALAConfig
from optimizer.search.ga import planned_episodes as ga_episodes
from optimizer.search.gala import GALA, GALAResult
from optimizer.search.la import (
    LearningScheme,
    LinearRewardInaction,
    LinearRewardPenalty,
)
from optimizer.seeds import stable_seed
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


def planned_episodes(config: GALAConfig, check_repeats: int = 0) -> int:
    """Episodes of one GALA row: the search iterations, the final GA, and the checks of the row's
    best and (an estimate: once a row) of the fastest walk."""
    ga = config.ga
    if config.restart_each_iteration:
        search = config.iterations * ga_episodes(ga)
    else:
        search = ga.population_size + config.iterations * config.generations_per_iteration * (
            ga.population_size - int(ga.elitism)
        )
    return search + ga_episodes(ga) + 2 * check_repeats


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


def reference_start(family: GaitFamily, bounds: np.ndarray) -> tuple[float, ...]:
    """The reference walk (``DEFAULT_GAIT_PATH``) as genes of the run's ``family``, where
    ``--refine-reference`` starts a refinement: a ValueError when the family cannot take a TFS walk
    or the walk lies outside the run's box."""
    genes = family.from_gait(load_gait(DEFAULT_GAIT_PATH)).genes
    if not in_box(genes, bounds):
        raise ValueError(f"the reference walk lies outside the {family.name} family's search box")
    return genes


def refinement_families(settings: Mapping[str, Any]) -> list[GaitFamily]:
    """The families the refinement searches, in turn: ``refine_family`` (one name, stored as runs
    made before several were possible stored it, or a list of names), else (a run from before the
    setting) the run's own."""
    named = settings.get("refine_family") or run_family(settings)
    return [family_named(name) for name in ([named] if isinstance(named, str) else named)]


def family_setting(names: Sequence[str] | None) -> str | list[str] | None:
    """``--refine-family`` as stored: one family as its name (so that a run of one family has the
    manifest it always had, and resumes as it was made), several as a list."""
    if names is None:
        return None
    return names[0] if len(names) == 1 else list(names)


def gala_config(settings: dict[str, Any]) -> GALAConfig:
    return GALAConfig(
        ga=GAConfig(
            population_size=settings["population"], generations=settings["generations"], elitism=settings["elitism"]
        ),
        iterations=settings["iterations"],
        generations_per_iteration=settings["generations_per_iteration"],
        restart_each_iteration=settings["restart_each_iteration"],
        baseline_window=settings["baseline_window"],
        crossover_rates=tuple(settings["crossover"]),
    )


def scheme(settings: dict[str, Any], config: GALAConfig) -> LearningScheme:
    la = config.la
    if settings["scheme"] == "lri":
        return LinearRewardInaction(la.reward_step)
    return LinearRewardPenalty(la.reward_step, la.penalty_step)


@dataclass
class Row:
    """A finished Table I row: the GALA result, its best gait as the search scored it, and that
    gait's check."""

    result: GALAResult
    best: ScoredGait | None
    check: StabilityReport | None
    walk_time: float

    def table_row(self) -> TableRow:
        best, check = self.best, self.check
        spread = None if check is None else check.spread()
        return TableRow.from_gala(
            self.result,
            None if best is None else best.mean_distance,
            None if best is None else best.mean_distance / self.walk_time,
            None if check is None else len(check.repeats),
            None if check is None else check.falls,
            spread,
            None if check is None else check.stable,
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            **self.result.to_dict(),
            "best_episode": None if self.best is None else self.best.walks[0].to_json(),
            "best_score": None if self.best is None else scored_summary(self.best),
            "check": None if self.check is None else self.check.to_dict(),
        }


def write_outputs(run: Run, rows: list[Row], fastest: Fastest | None) -> None:
    """Every result file, for the rows finished so far (rewritten after each row and after the
    refinement): the tables, plots and gait files, and a walk card beside every gait file."""
    path, settings = run.folder.path, run.settings
    table = [row.table_row() for row in rows]
    write_table_csv(table, path / "table1.csv")
    write_table_markdown(table, path / "table1.md")
    write_json(
        path / "results.json",
        {
            "settings": settings,
            "rows": [row.to_dict() for row in rows],
            **hand_over(run, fastest, "GALA run"),
        },
    )
    if not rows:
        return
    latest = rows[-1]
    result, best = latest.result, latest.best
    tag = f"pc{result.crossover:g}"
    plot_gala_convergence(result, path / f"gala-{tag}.png")
    plot_ga_convergence(
        result.final_ga_history,
        path / f"ga-{tag}.png",
        f"Final GA: crossover {result.crossover:g}, mutation {result.optimal_mutation:g}",
    )
    verdict = "" if latest.check is None else ("; holds" if latest.check.stable else "; FALLS")
    notes = (
        f"GALA row pc={result.crossover:g}, pm={result.optimal_mutation:g}: fitness {result.best_fitness:.4f}"
        + ("" if best is None else f", {best.describe()}")
        + ("" if latest.check is None else f"; check: {latest.check.summary()}{verdict}")
    )
    names = [f"best_gait-{tag}.json"]
    if max(range(len(rows)), key=lambda k: rows[k].result.best_fitness) == len(rows) - 1:
        names.append("best_gait.json")
    for name in names:
        write_gait(run, path / name, result.best_genes, notes)
        if latest.check is not None:
            write_card(card_of(run, f"Table I row pc {result.crossover:g}", latest.check), path / name)


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
    families = refinement_families(run.settings)
    # the check candidates' families: the refinement's, when it runs (the rows' gaits count as TFS)
    checked_families = len(families) if run.settings.get("refine") else 1
    for refined in families:
        if refined is not run.family and refined.extends is not run.family:
            parser.error(
                f"--refine-family {refined.name}: it cannot refine {run.family.name} walks; give the run's own "
                f"family (--refine-family {run.family.name}) or one that extends it"
            )
        if run.settings.get("bounds", "legacy") not in refined.boxes:
            parser.error(
                f"--refine-family {refined.name}: it has no {run.settings.get('bounds', 'legacy')} box (its "
                f"boxes: {', '.join(refined.boxes)}); give --refine-family {run.family.name}"
            )
    config = gala_config(run.settings)
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)
    reference: list[tuple[float, ...]] = []
    if run.settings.get("refine") and run.settings.get("refine_reference"):  # a run from before it: none
        try:
            reference.append(reference_start(run.family, bounds))
        except ValueError as exc:
            parser.error(f"--refine-reference: {exc}; give --no-refine-reference")
    rates = config.crossover_rates

    def body(driver: Driver) -> str:
        rows: list[Row] = []
        fastest: Fastest | None = None
        walk_time = run.setup.walk_time
        for pc in rates:
            tag = f"pc{pc:g}"
            search = GALA(
                bounds, config, pc, stable_seed(run.seed, tag), scheme=scheme(run.settings, config), repair=repair
            )
            result: GALAResult = driver.run(search)
            best = best_gait(driver, search.best_key(f"{tag}/final/"))
            rows.append(Row(result, best, check_best(driver, best, run.setup.start, stability), walk_time))
            fastest = fastest_walk(driver, run.setup.start, stability)
            write_outputs(run, rows, fastest)
        fallback: list[ScoredGait] = []
        if run.settings.get("refine", 0) and fastest is not None:  # a run from before it: none
            starts = refine_starts(driver, fastest) if run.settings.get("refine_race") else [fastest.gait.genes]
            starts += [start for start in reference if start not in starts]
            share, extra = divmod(run.settings["refine"], len(families))
            first = 0
            for j, refined in enumerate(families):
                lifted = [refined.from_gait(run.family.gait(start)).genes for start in starts]
                box, box_repair = search_box(run.settings, refined)
                named = None if refined is run.family else refined.name
                own = {**run.settings, "refine": share + (j < extra)}
                first += refine(driver, own, run.seed, box, box_repair, lifted, refined.held, named, first)
            fallback.append(fastest.gait)  # when no refined walk holds, the rows' may
        if fastest is not None:  # the walk handed over: its candidates walk on (--hand-over-walks)
            fastest = fastest_walk(
                driver, run.setup.start, stability, hand_over=True, fallback=fallback, by_family=checked_families > 1
            )
            write_outputs(run, rows, fastest)
        falling = [f"{row.result.crossover:g}" for row in rows if row.check is not None and not row.check.stable]
        lines = [(run.folder.path / "table1.md").read_text().rstrip("\n")]
        if falling:
            lines.append(f"FALLS: the best gait of the row(s) with crossover {', '.join(falling)} fell in its check")
        if fastest is not None:
            lines.append(f"{fastest.describe()}; in fastest_gait.json (walk card: fastest_gait.card.md)")
        lines.append(f"results in {run.folder.path}")
        return "\n".join(lines)

    # the racing walks and how many candidates the checks walk are not known ahead: an estimate
    planned = len(rates) * planned_episodes(config, stability.repeats) + run.settings.get("refine", 0)
    planned += stability.candidates * checked_families * (stability.repeats + stability.confirm) + stability.hand_over
    return run_session(
        run,
        planned,
        body,
        make_evaluator=make_evaluator,
        quiet=args.quiet,
    )
