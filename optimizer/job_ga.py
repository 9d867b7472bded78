"""The plain GA command's job (``python -m optimizer.ga``): one GA with fixed rates (paper Fig. 4,
5, 7), its best gait checked, written as a gait file with its walk card.
"""

from __future__ import annotations

from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.report import plot_ga_convergence
from optimizer.run.results import best_gait, card_of, write_gait
from optimizer.run.run_settings import search_box, stability_config
from optimizer.run.session import Run
from optimizer.run.stability import check_best
from optimizer.run.walk_card import write_card
from optimizer.search.config import GAConfig
from optimizer.search.ga import GAResult, GARun
from optimizer.search.ga import planned_episodes as ga_episodes
from optimizer.seeds import stable_seed
from optimizer.settings import GA_RATES, SearchSettings

#: Keys of the GA's episodes start with this.
PREFIX = "ga"


def ga_config(search: SearchSettings) -> GAConfig:
    """The GA the settings stand for."""
    assert isinstance(search.crossover, float)  # a GA has one crossover rate
    return GAConfig(
        population_size=search.population,
        generations=search.generations,
        crossover_rate=search.crossover,
        mutation_rate=search.mutation,
        elitism=search.elitism,
    )


def title(search: SearchSettings) -> str:
    """The GA named by its preset and rates, for its plot and gait file."""
    name = GA_RATES[search.preset].name + ": " if search.preset else ""
    return f"GA, {name}crossover {search.crossover:g}, mutation {search.mutation:g}"


def ga_job(driver: Driver, run: Run) -> str:
    """The GA, then its best gait checked and written; returns the summary."""
    config = ga_config(run.settings.search)
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)
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
            "settings": run.settings.stored(),
            "best_episode": None if best is None else best.walks[0].to_json(),
            "check": None if checked is None else checked.to_dict(),
        },
    )
    plot_ga_convergence(result.history, folder / "ga.png", title(run.settings.search))
    write_gait(
        run,
        folder / "best_gait.json",
        result.best_genes,
        f"{title(run.settings.search)}: fitness {result.best_fitness:.4f}{verdict} (run {folder})",
    )
    if checked is not None:
        write_card(card_of(run, "GA best", checked), folder / "best_gait.json")
    distance = "-" if best is None else best.describe()
    return f"best fitness {result.best_fitness:.4f} ({distance}{verdict}); results in {folder}"


def planned_episodes(run: Run) -> int:
    """The GA's episodes and its best gait's check."""
    return ga_episodes(ga_config(run.settings.search)) + stability_config(run.settings).repeats
