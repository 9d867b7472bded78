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
import sys
from collections.abc import Sequence
from typing import Any

from optimizer.cli.common import (
    EvaluatorMaker,
    add_run_arguments,
    best_gait,
    card_of,
    pool_evaluator,
    prepare_run,
    run_session,
    search_box,
    stability_config,
    write_gait,
)
from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.report import plot_ga_convergence
from optimizer.run.stability import check_best
from optimizer.run.walk_card import write_card
from optimizer.search.config import (
    DE_JONG,
    GREFENSTETTE,
    PAPER_GALA_BEST,
    GAConfig,
    RatePreset,
)
from optimizer.search.ga import GAResult, GARun, planned_episodes
from optimizer.seeds import stable_seed
from protocol.cli_values import positive_int, probability

PRESETS: dict[str, RatePreset] = {"dejong": DE_JONG, "grefenstette": GREFENSTETTE, "gala": PAPER_GALA_BEST}

#: Keys of the GA's episodes start with this.
PREFIX = "ga"


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


def ga_config(settings: dict[str, Any]) -> GAConfig:
    return GAConfig(
        population_size=settings["population"],
        generations=settings["generations"],
        crossover_rate=settings["crossover"],
        mutation_rate=settings["mutation"],
        elitism=settings["elitism"],
    )


def title(settings: dict[str, Any]) -> str:
    name = PRESETS[settings["preset"]].name + ": " if settings["preset"] else ""
    return f"GA, {name}crossover {settings['crossover']:g}, mutation {settings['mutation']:g}"


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    run = prepare_run(parser, args, "ga", defaults(args.preset), argv)
    config = ga_config(run.settings)
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)

    def body(driver: Driver) -> str:
        search = GARun(bounds, config, stable_seed(run.seed, PREFIX), repair=repair, prefix=PREFIX)
        result: GAResult = driver.run(search)
        folder = run.folder.path
        best = best_gait(driver, search.best_key(PREFIX + "/"))
        checked = check_best(driver, best, run.setup.start, stability)
        verdict = "" if checked is None else f"; {checked.summary()}"
        write_json(
            folder / "results.json",
            {
                **result.to_dict(),
                "settings": run.settings,
                "best_episode": None if best is None else best.walks[0].to_json(),
                "check": None if checked is None else checked.to_dict(),
            },
        )
        plot_ga_convergence(result.history, folder / "ga.png", title(run.settings))
        write_gait(
            run,
            folder / "best_gait.json",
            result.best_genes,
            f"{title(run.settings)}: fitness {result.best_fitness:.4f}{verdict} (run {folder})",
        )
        if checked is not None:
            write_card(card_of(run, "GA best", checked), folder / "best_gait.json")
        distance = "-" if best is None else best.describe()
        return f"best fitness {result.best_fitness:.4f} ({distance}{verdict}); results in {folder}"

    return run_session(
        run, planned_episodes(config) + stability.repeats, body, make_evaluator=make_evaluator, quiet=args.quiet
    )
