"""``python -m optimizer.compare``: search methods at equal episode budgets over many seeds.

    python -m optimizer.compare --preset quick               # a first look: minutes on 2 cores
    python -m optimizer.compare                              # 6 methods x 10 seeds x 800 episodes (hours)
    python -m optimizer.compare --methods gala,cmaes --seeds 20 --budget 400
    python -m optimizer.compare --robust-walks 1                  # score every gait by one walk (eq. 9)
    python -m optimizer.compare --resume runs/compare-...   # continue after Ctrl-C or kill -9

Methods (each a module of ``optimizer/compare/methods``): GALA at the paper's settings, the GA
with De Jong's, Grefenstette's and the paper's best rates, CMA-ES (the ``cma`` library) and
uniform random search. Each run of a method on a seed gets the same budget of search episodes;
its best gait is then checked for stability (``--check-repeats`` walks from moved starts,
counted apart). Writes into the run folder: runs.csv (every method x seed), summary.csv
(median, interquartile range, best and success rate per method), pairs.csv and comparison.md
(pairwise Mann-Whitney U tests, Holm-corrected, with effect sizes), convergence.png and
results.json (its ``reported`` gaits work with ``python -m optimizer.transfer``), and
episodes.jsonl as each episode finishes (what ``--resume`` continues from).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from optimizer import settings as table
from optimizer.compare.budget import drive
from optimizer.compare.methods import Method, Problem, discover
from optimizer.compare.report import RunOutcome, plot_convergence, write_tables
from optimizer.compare.statistics import pairwise, summarise
from optimizer.episode.course import Course
from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.robust import ScoredGait
from optimizer.run.run_settings import apply_preset, course_of, search_box, stability_config
from optimizer.run.session import EvaluatorMaker, pool_evaluator, prepare_run, run_session
from optimizer.run.stability import check_best
from optimizer.seeds import stable_seed


def _outcome(
    method: Method,
    index: int,
    scored: Sequence[ScoredGait],
    best: ScoredGait,
    check_report: Any,
    success_distance: float,
    course: Course | None = None,
) -> RunOutcome:
    """One method's run on one seed. Its "distance" is the best's score / 10 (eq. 9: the metres its
    scoring walks were counted as); on a ``course`` the same figure is metres of course done, or for
    a finished walk the course's size x (2 - time / time limit), and success is a best whose scoring
    walks finished (score >= 10 x the size) and whose check did not fall."""
    curve: list[float] = []
    so_far = float("-inf")
    for candidate in scored:
        so_far = max(so_far, candidate.fitness / 10.0)
        curve.extend([so_far] * len(candidate.walks))  # each episode the candidate took
    spread = None if check_report is None else check_report.spread()
    stable = check_report is None or check_report.stable
    return RunOutcome(
        method.name,
        index,
        best.key,
        best.genes,
        best.fitness / 10.0,
        0 if check_report is None else len(check_report.repeats),
        0 if check_report is None else check_report.falls,
        None if spread is None else spread[2],
        stable and best.fitness / 10.0 >= (success_distance if course is None else course.size),
        tuple(curve),
        None if check_report is None else check_report.to_dict(),
        tuple((w.distance, w.fell) for w in best.walks if w.ran),
    )


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = table.build_parser("compare", "python -m optimizer.compare", __doc__)
    args = parser.parse_args(argv)
    apply_preset(args, table.COMPARE_PRESETS[args.preset or "default"])
    run = prepare_run(parser, args, "compare", argv)
    search = run.settings.search
    methods = [discover()[name] for name in search.methods or discover()]
    bounds, repair = search_box(run.settings)
    stability = stability_config(run.settings)
    course = course_of(run.settings)
    budget = search.budget  # episodes, the same for every run (a raced candidate spends several)
    seeds = search.seeds

    def body(driver: Driver) -> str:
        runs: list[RunOutcome] = []
        for method in methods:
            for index in range(seeds):
                prefix = f"{method.name}/s{index:02d}"
                problem = Problem(
                    bounds, repair, stable_seed(run.seed, prefix), budget, search.population, search.elitism
                )
                scored = drive(driver, method.program(problem), budget, prefix)
                best = max(scored, key=lambda s: s.fitness)  # the first of equals: the earliest found
                report = check_best(driver, best, run.setup.start, stability)
                runs.append(_outcome(method, index, scored, best, report, search.success_distance, course))
            _write(run.folder.path, runs, run.settings.stored(), budget, course)
        return (run.folder.path / "comparison.md").read_text() + f"results in {run.folder.path}"

    planned = len(methods) * seeds * (budget + stability.repeats)
    return run_session(run, planned, body, make_evaluator=make_evaluator, quiet=args.quiet)


def _write(
    folder: Any, runs: Sequence[RunOutcome], settings: dict[str, Any], episodes: int, course: Course | None = None
) -> None:
    """Every output file for the runs finished so far (rewritten after each method)."""
    methods = list(dict.fromkeys(r.method for r in runs))
    distances = {m: [r.best_distance for r in runs if r.method == m] for m in methods}
    summaries = [summarise(m, distances[m], [r.success for r in runs if r.method == m]) for m in methods]
    pairs = pairwise(distances) if all(len(d) > 0 for d in distances.values()) else []
    write_tables(runs, summaries, pairs, folder, settings["success_distance"], episodes, course)
    plot_convergence(runs, folder / "convergence.png")
    write_json(
        folder / "results.json",
        {
            "settings": settings,
            "summaries": [s.__dict__ for s in summaries],
            "pairs": [p.__dict__ for p in pairs],
            "runs": [{**r.row(), "best_genes": list(r.best_genes), "curve": list(r.curve)} for r in runs],
            "reported": [
                {
                    "name": f"{r.method} s{r.seed_index:02d}",
                    "genes": list(r.best_genes),
                    "check": r.check,
                    "walk": r.scoring_walk(),
                }
                for r in runs
            ],
        },
    )


if __name__ == "__main__":
    raise SystemExit(main())
