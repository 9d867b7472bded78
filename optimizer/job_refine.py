"""The refinement command's job (``python -m optimizer.refine GAIT``): the given walk scored, CMA-ES
from it (``optimizer.search.refinement``), and the fastest refined walk that holds handed over.
"""

from __future__ import annotations

from dataclasses import replace

from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.results import hand_over
from optimizer.run.run_settings import search_box, stability_config
from optimizer.run.session import Run
from optimizer.run.stability import fastest_walk
from optimizer.search.refinement import START_KEY, StartGait, refine


def refine_job(driver: Driver, run: Run) -> str:
    """The start gait scored as a search of one (so it is handed back if nothing beats it), the
    refinement from it, then the hand-over with the start as the fallback; returns the summary."""
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)
    start_genes = run.settings.refinement.start_gait
    assert start_genes is not None  # a refine run stores the gait it starts from
    driver.run(StartGait(start_genes))
    # the whole run is a refinement: its gaits are scored by the run's own quantile
    refinement = replace(run.settings.refinement, quantile=run.settings.scoring.quantile)
    refine(driver, refinement, run.seed, bounds, repair, [start_genes], run.family.held)
    driver.replan(stability.candidates * (stability.repeats + stability.confirm) + stability.hand_over)
    start = driver.scored.get(f"{START_KEY}/i000")
    fallback = [] if start is None else [start]  # when no refined walk holds, the given one may
    fastest = fastest_walk(driver, run.setup.start, stability, hand_over=True, fallback=fallback)
    write_json(
        run.folder.path / "results.json", {"settings": run.settings.stored(), **hand_over(run, fastest, "refined")}
    )
    lines = []
    if fastest is not None:
        lines.append(f"{fastest.describe()}; in fastest_gait.json (walk card: fastest_gait.card.md)")
    if start is not None:
        lines.append(f"start gait: scored {start.describe()}")
    lines.append(f"results in {run.folder.path}")
    return "\n".join(lines)


def planned_episodes(run: Run) -> int:
    """The episodes planned, an estimate: the start, the refinement's gaits (their racing walks
    not known ahead), the checks and the hand-over."""
    stability = stability_config(run.settings)
    planned = 1 + run.settings.refinement.budget + stability.candidates * (stability.repeats + stability.confirm)
    return planned + stability.hand_over
