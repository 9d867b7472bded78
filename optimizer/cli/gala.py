"""``python -m optimizer.gala``: the paper's Table I protocol, in a run folder.

For each crossover rate (0.1 ... 0.9 unless ``--crossover`` is given) a GALA learns the mutation
rate (automata(10) over 0.00 ... 0.09, a = 0.1, b = 0.2, 100 iterations, population 100), then a
final GA with (crossover, optimal mutation) runs ``--generations`` generations and gives the row's
best fitness. ``--budget quick`` is a first look in a few minutes.

Each row's best gait is then checked (``optimizer.run.stability``): walked ``--check-repeats`` times
(default 10) from starts moved within ``--check-jitter`` (default the real server's beam noise,
+-5 cm and +-10 deg); Table I reports its falls and shortest walk. The fastest walk of the whole
search, learning phase included, is checked the same way: the fastest that passes (of the five
fastest) becomes fastest_gait.json.

Writes, as each row finishes: table1.csv and table1.md, gala-pc0.8.png (Fig. 6), ga-pc0.8.png
(Fig. 7), best_gait-pc0.8.json and best_gait.json (the final GAs' best: Table I's gaits),
fastest_gait.json (the fastest stable walk of every episode so far), results.json; and
episodes.jsonl as each episode finishes (what ``--resume DIR`` continues from).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from optimizer.cli.common import (
    EvaluatorMaker,
    add_run_arguments,
    apply_preset,
    best_episode,
    pool_evaluator,
    prepare_run,
    run_session,
    search_box,
    stability_config,
    write_gait,
)
from optimizer.episode import Start
from optimizer.evaluation.pool import stable_seed
from optimizer.evaluation.record import EpisodeRecord
from optimizer.run.driver import Driver
from optimizer.run.folder import RunFolder, write_json
from optimizer.run.report import (
    TableRow,
    plot_ga_convergence,
    plot_gala_convergence,
    write_table_csv,
    write_table_markdown,
)
from optimizer.run.stability import (
    StabilityReport,
    check_best,
    fastest_stable,
    standing_walks,
)
from optimizer.search.config import GAConfig, GALAConfig, StabilityConfig
from optimizer.search.ga import planned_episodes as ga_episodes
from optimizer.search.gala import GALA, GALAResult
from optimizer.search.la import (
    LearningScheme,
    LinearRewardInaction,
    LinearRewardPenalty,
)
from protocol.cli_values import positive_int, probability

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
}

#: A first look on a 2-core machine: one row (the paper's best crossover rate), population 20,
#: 20 iterations (19 feedbacks to the automaton), a 6-generation final GA: 515 episodes, plus up
#: to 20 check walks (the row's best and the fastest walk, 10 each; one check when they are one).
#: Measured on the stub with 2 workers: 2.2-6.4 episodes/s (random early gaits fall within a
#: second, a 15-s walk costs ~0.85 s of wall time per worker), so 1.5-4 minutes.
BUDGETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "quick": {"crossover": [0.8], "population": 20, "iterations": 20, "generations": 6},
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
        "20 iterations, 6 final generations (2-4 minutes on 2 cores). Flags given "
        "override it",
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
    add_run_arguments(p)
    return p


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


def fastest_episode(records: Mapping[str, EpisodeRecord]) -> EpisodeRecord | None:
    """The farthest walk that did not fall, of every episode the search logged. Table I takes each
    row's best from a fresh final GA, as the paper does; the continuing population of the learning
    phase evaluates ten times as many gaits and often walks farther (pc 0.8, seed 1: 10.29 m against
    the final GA's 6.38 m), and a user wants that gait too."""
    walks = standing_walks(records)
    return walks[0] if walks else None


@dataclass
class Row:
    """A finished Table I row: the GALA result, its best walk as logged, and that walk's check."""

    result: GALAResult
    best: EpisodeRecord | None
    check: StabilityReport | None

    def table_row(self) -> TableRow:
        best, check = self.best, self.check
        spread = None if check is None else check.spread()
        return TableRow.from_gala(
            self.result,
            None if best is None else best.distance,
            None if best is None else best.mean_speed,
            None if check is None else len(check.repeats),
            None if check is None else check.falls,
            spread,
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            **self.result.to_dict(),
            "best_episode": None if self.best is None else self.best.to_json(),
            "check": None if self.check is None else self.check.to_dict(),
        }


@dataclass
class Fastest:
    """The fastest walk of the search so far and its check (None when checks are off)."""

    walk: EpisodeRecord
    check: StabilityReport | None

    def describe(self) -> str:
        walk, check = self.walk, self.check
        text = f"{walk.distance:.2f} m in {walk.time:g} s ({walk.key})"
        if check is None:
            return f"farthest walk without a fall: {text}"
        verdict = "fastest stable walk" if check.stable else "no fast walk passed its check; the steadiest"
        return f"{verdict}: {text}, {check.summary()}"


def fastest_walk(driver: Driver, base: Start, stability: StabilityConfig) -> Fastest | None:
    if stability.repeats == 0:
        walk = fastest_episode(driver.log.records)
        return None if walk is None else Fastest(walk, None)
    report = fastest_stable(driver, driver.log.records, base, stability)
    return None if report is None else Fastest(report.walk, report)


def write_outputs(folder: RunFolder, settings: dict[str, Any], rows: list[Row], fastest: Fastest | None) -> None:
    """Every result file, for the rows finished so far (rewritten after each row)."""
    path = folder.path
    table = [row.table_row() for row in rows]
    write_table_csv(table, path / "table1.csv")
    write_table_markdown(table, path / "table1.md")
    write_json(
        path / "results.json",
        {
            "settings": settings,
            "rows": [row.to_dict() for row in rows],
            "fastest_episode": None if fastest is None else fastest.walk.to_json(),
            "fastest_check": None if fastest is None or fastest.check is None else fastest.check.to_dict(),
        },
    )
    if fastest is not None:
        write_gait(path / "fastest_gait.json", np.array(fastest.walk.genes), f"GALA run: {fastest.describe()}")
    latest = rows[-1]
    result, best = latest.result, latest.best
    tag = f"pc{result.crossover:g}"
    plot_gala_convergence(result, path / f"gala-{tag}.png")
    plot_ga_convergence(
        result.final_ga_history,
        path / f"ga-{tag}.png",
        f"Final GA: crossover {result.crossover:g}, mutation {result.optimal_mutation:g}",
    )
    notes = (
        f"GALA row pc={result.crossover:g}, pm={result.optimal_mutation:g}: fitness {result.best_fitness:.4f}"
        + ("" if best is None else f", {best.distance:.2f} m in {best.time:.1f} s")
        + ("" if latest.check is None else f"; {latest.check.summary()}")
    )
    write_gait(path / f"best_gait-{tag}.json", result.best_genes, notes)
    top = max(range(len(rows)), key=lambda k: rows[k].result.best_fitness)
    if top == len(rows) - 1:
        write_gait(path / "best_gait.json", result.best_genes, notes)


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    apply_preset(args, BUDGETS[args.budget or "paper"])
    tags = [f"pc{pc:g}" for pc in args.crossover or ()]
    if len(set(tags)) != len(tags):
        parser.error(f"--crossover: a rate is given twice ({' '.join(t[2:] for t in tags)})")
    run = prepare_run(parser, args, "gala", PAPER, argv)
    config = gala_config(run.settings)
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)
    rates = config.crossover_rates

    def body(driver: Driver) -> str:
        rows: list[Row] = []
        fastest: Fastest | None = None
        for pc in rates:
            tag = f"pc{pc:g}"
            search = GALA(
                bounds, config, pc, stable_seed(run.seed, tag), scheme=scheme(run.settings, config), repair=repair
            )
            result: GALAResult = driver.run(search)
            best = best_episode(driver.log.records, search.best_key(f"{tag}/final/"))
            rows.append(Row(result, best, check_best(driver, best, run.setup.start, stability)))
            fastest = fastest_walk(driver, run.setup.start, stability)
            write_outputs(run.folder, run.settings, rows, fastest)
        found = "" if fastest is None else f"{fastest.describe()}; in fastest_gait.json\n"
        return (run.folder.path / "table1.md").read_text() + found + f"results in {run.folder.path}"

    return run_session(
        run,
        len(rates) * planned_episodes(config, stability.repeats),
        body,
        make_evaluator=make_evaluator,
        quiet=args.quiet,
    )
