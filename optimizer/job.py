"""The main job (``python -m optimizer.gala``) as its protocol: Table I rows, the checks, the
refinement, the hand-over.

``main_job`` is the whole pipeline; each stage is a function of the driver (the run's evaluator and
episode log) and the job's plan (its run and what its settings stand for). Every episode is keyed,
so a resumed run replays the stages from the log to where it stopped (``optimizer.run.driver``).
Why each stage is there: docs/optimizer.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from gait import DEFAULT_GAIT_PATH, GaitFamily, family_named, load_gait
from optimizer.episode.course import Course
from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.report import (
    TableRow,
    plot_ga_convergence,
    plot_gala_convergence,
    write_table_csv,
    write_table_markdown,
)
from optimizer.run.results import best_gait, card_of, hand_over, write_gait
from optimizer.run.robust import ScoredGait
from optimizer.run.run_settings import in_box, search_box, stability_config
from optimizer.run.session import Run
from optimizer.run.stability import Fastest, StabilityReport, check_best, fastest_walk, scored_summary
from optimizer.run.walk_card import write_card
from optimizer.search.config import GAConfig, GALAConfig, StabilityConfig
from optimizer.search.ga import planned_episodes as ga_episodes
from optimizer.search.gala import GALA, GALAResult
from optimizer.search.la import LearningScheme, LinearRewardInaction, LinearRewardPenalty
from optimizer.search.protocol import Repair
from optimizer.search.refinement import refine, refine_starts
from optimizer.seeds import stable_seed
from optimizer.settings import RefinementSettings, SearchSettings


def main_job(driver: Driver, plan: JobPlan) -> str:
    """The main job, stage by stage; returns its summary. Every result file is written anew after
    each row and after the hand-over, so that an interrupted run has its finished rows' files."""
    rows: list[Row] = []
    fastest: Fastest | None = None
    for pc in plan.config.crossover_rates:
        rows.append(table_row(driver, plan, pc))
        fastest = checked_walks(driver, plan)
        write_outputs(plan.run, rows, fastest)
    driver.replan(plan.refinement_episodes(driver) + plan.hand_over_episodes())
    fallback = refinement(driver, plan, fastest)
    driver.replan(plan.hand_over_episodes())
    fastest = hand_over_walk(driver, plan, rows, fastest, fallback)
    return summary(plan, rows, fastest)


class JobRefused(ValueError):
    """The settings ask for a job that cannot run; the message names the flag and what to give."""


@dataclass(frozen=True)
class JobPlan:
    """What the run's settings stand for: the GALA rows, the check, the search box and the
    refinement's families and extra start."""

    run: Run
    config: GALAConfig
    stability: StabilityConfig
    bounds: np.ndarray
    repair: Repair
    #: the families the refinement searches, in turn
    families: list[GaitFamily]
    #: the reference walk's genes where the refinement also starts from it (``--refine-reference``)
    reference: list[tuple[float, ...]]

    @classmethod
    def of(cls, run: Run) -> JobPlan:
        """The plan of ``run``; a JobRefused when a refinement family cannot refine the run's walks
        or the reference walk lies outside the box."""
        settings = run.settings
        families = refinement_families(settings.refinement)
        for refined in families:
            if refined is not run.family and refined.extends is not run.family:
                raise JobRefused(
                    f"--refine-family {refined.name}: it cannot refine {run.family.name} walks; give the run's own "
                    f"family (--refine-family {run.family.name}) or one that extends it"
                )
            if settings.episode.bounds not in refined.boxes:
                raise JobRefused(
                    f"--refine-family {refined.name}: it has no {settings.episode.bounds} box (its "
                    f"boxes: {', '.join(refined.boxes)}); give --refine-family {run.family.name}"
                )
        bounds, repair = search_box(settings)
        reference: list[tuple[float, ...]] = []
        if settings.refinement.budget and settings.refinement.reference:
            try:
                reference.append(reference_start(run.family, bounds))
            except ValueError as exc:
                raise JobRefused(f"--refine-reference: {exc}; give --no-refine-reference") from None
        return cls(run, gala_config(settings.search), stability_config(settings), bounds, repair, families, reference)

    @property
    def checked_families(self) -> int:
        """How many families' best gaits the checks walk: the refinement's, when it runs (the rows'
        gaits count as TFS)."""
        return len(self.families) if self.run.settings.refinement.budget else 1

    def planned_episodes(self) -> int:
        """The episodes planned, an estimate: the racing walks and how many candidates the checks
        walk are not known ahead; each stage plans again when it starts (``Driver.replan``)."""
        rows = len(self.config.crossover_rates) * planned_episodes(self.config, self.stability.repeats)
        return rows + self.run.settings.refinement.budget + self.hand_over_episodes()

    def refinement_episodes(self, driver: Driver) -> int:
        """The refinement's episodes, estimated from how many walks a gait has taken so far."""
        return round(self.run.settings.refinement.budget * driver.walks_per_gait())

    def hand_over_episodes(self) -> int:
        """The checks of the best-scored gaits and the hand-over's walks, an estimate (how many
        candidates walk on depends on which of them fall)."""
        stability = self.stability
        checks = stability.candidates * self.checked_families * (stability.repeats + stability.confirm)
        return checks + stability.hand_over


# --- the stages ------------------------------------------------------------------------------------


def table_row(driver: Driver, plan: JobPlan, pc: float) -> Row:
    """A row of Table I: a GALA learns the mutation rate at crossover rate ``pc``, its final GA
    gives the row's best gait, and that gait is checked."""
    run = plan.run
    tag = f"pc{pc:g}"
    search = GALA(
        plan.bounds,
        plan.config,
        pc,
        stable_seed(run.seed, tag),
        scheme=scheme(run.settings.search, plan.config),
        repair=plan.repair,
    )
    result: GALAResult = driver.run(search)
    best = best_gait(driver, search.best_key(f"{tag}/final/"))
    check = check_best(driver, best, run.setup.start, plan.stability)
    return Row(result, best, check, run.setup.walk_time)


def checked_walks(driver: Driver, plan: JobPlan) -> Fastest | None:
    """The run's best-scored gaits so far checked (and confirmed): the fastest walk that holds."""
    return fastest_walk(driver, plan.run.setup.start, plan.stability)


def refinement(driver: Driver, plan: JobPlan, fastest: Fastest | None) -> list[ScoredGait]:
    """CMA-ES from the rows' walks (``optimizer.search.refinement``), each family its share of the
    gaits in turn; returns the walk it started from, which the hand-over falls back on when no
    refined walk holds (none when the run does not refine)."""
    settings = plan.run.settings
    refinement = settings.refinement
    if not refinement.budget or fastest is None:
        return []
    starts = refine_starts(driver, fastest) if refinement.race else [fastest.gait.genes]
    starts += [start for start in plan.reference if start not in starts]
    share, extra = divmod(refinement.budget, len(plan.families))
    first = 0
    for j, refined in enumerate(plan.families):
        lifted = [refined.from_gait(plan.run.family.gait(start)).genes for start in starts]
        box, box_repair = search_box(settings, refined)
        named = None if refined is plan.run.family else refined.name
        own = replace(refinement, budget=share + (j < extra))
        first += refine(driver, own, plan.run.seed, box, box_repair, lifted, refined.held, named, first)
    return [fastest.gait]


def hand_over_walk(
    driver: Driver, plan: JobPlan, rows: list[Row], fastest: Fastest | None, fallback: list[ScoredGait]
) -> Fastest | None:
    """The walk handed over: the checked candidates walk on towards ``--hand-over-walks`` walks,
    best first, and the first that holds them all is fastest_gait.json (``fastest_walk``)."""
    if fastest is None:
        return None
    run = plan.run
    fastest = fastest_walk(
        driver,
        run.setup.start,
        plan.stability,
        hand_over=True,
        fallback=fallback,
        by_family=plan.checked_families > 1,
    )
    write_outputs(run, rows, fastest)
    return fastest


def summary(plan: JobPlan, rows: list[Row], fastest: Fastest | None) -> str:
    """What the run hands over first (the walk, its card, how it held), then Table I."""
    lines = []
    if fastest is not None:
        lines.append(f"{fastest.describe()}; in fastest_gait.json (walk card: fastest_gait.card.md)")
    lines.append((plan.run.folder.path / "table1.md").read_text().rstrip("\n"))
    falling = [f"{row.result.crossover:g}" for row in rows if row.check is not None and not row.check.stable]
    if falling:
        lines.append(f"FALLS: the best gait of the row(s) with crossover {', '.join(falling)} fell in its check")
    lines.append(f"results in {plan.run.folder.path}")
    return "\n".join(lines)


# --- what the settings stand for -------------------------------------------------------------------


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


def reference_start(family: GaitFamily, bounds: np.ndarray) -> tuple[float, ...]:
    """The reference walk (``DEFAULT_GAIT_PATH``) as genes of the run's ``family``, where
    ``--refine-reference`` starts a refinement: a ValueError when the family cannot take a TFS walk
    or the walk lies outside the run's box."""
    genes = family.from_gait(load_gait(DEFAULT_GAIT_PATH)).genes
    if not in_box(genes, bounds):
        raise ValueError(f"the reference walk lies outside the {family.name} family's search box")
    return genes


def refinement_families(settings: RefinementSettings) -> list[GaitFamily]:
    """The families the refinement searches, in turn: one name (stored as runs made before several
    were possible stored it) or several."""
    named = settings.family
    assert named is not None  # a main job stores its refinement's families
    return [family_named(name) for name in ([named] if isinstance(named, str) else named)]


def gala_config(search: SearchSettings) -> GALAConfig:
    """The GALA of every row (paper section VI, or the budget's numbers)."""
    rates = search.crossover
    return GALAConfig(
        ga=GAConfig(population_size=search.population, generations=search.generations, elitism=search.elitism),
        iterations=search.iterations,
        generations_per_iteration=search.generations_per_iteration,
        restart_each_iteration=search.restart_each_iteration,
        baseline_window=search.baseline_window,
        crossover_rates=(rates,) if isinstance(rates, float) else tuple(rates),
    )


def scheme(search: SearchSettings, config: GALAConfig) -> LearningScheme:
    """The automaton's learning scheme: L_R-P (eq. 7-8) or L_R-I (eq. 6)."""
    la = config.la
    if search.scheme == "lri":
        return LinearRewardInaction(la.reward_step)
    return LinearRewardPenalty(la.reward_step, la.penalty_step)


# --- the result files --------------------------------------------------------------------------------


@dataclass
class Row:
    """A finished Table I row: the GALA result, its best gait as the search scored it, and that
    gait's check."""

    result: GALAResult
    best: ScoredGait | None
    check: StabilityReport | None
    walk_time: float

    def table_row(self) -> TableRow:
        """The row's figures; on a course a distance is metres of course done and a speed those metres
        over each walk's own time (a walk ends when it finishes), not over the time limit."""
        best, check = self.best, self.check
        spread = None if check is None else check.spread()
        if best is None:
            speed = None
        elif best.walks[0].on_course:
            ran = [w.mean_speed for w in best.walks if w.ran]
            speed = sum(ran) / len(ran) if ran else 0.0
        else:
            speed = best.mean_distance / self.walk_time
        return TableRow.from_gala(
            self.result,
            None if best is None else best.mean_distance,
            speed,
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


def course_note(course: Course | None) -> str | None:
    """What a course run's Table I figures mean (None for eq. 9's)."""
    if course is None:
        return None
    return (
        f"A course run (optimizer.episode.course: {len(course.poses)} poses, {course.size:.2f} m of course, "
        f"at most {course.time_limit:g} s): a distance is metres of course done ({course.size:.2f} m for a walk "
        "that finished), a speed those metres over the walk's own time; fitness is 10 x the metres done for a walk "
        "that did not finish, 10 x the course's size x (2 - time / time limit) for one that did."
    )


def write_outputs(run: Run, rows: list[Row], fastest: Fastest | None) -> None:
    """Every result file, for the rows finished so far (rewritten after each row and after the
    refinement): the tables, results.json and the walk handed over, then the latest row's plots
    and gait files."""
    path = run.folder.path
    table = [row.table_row() for row in rows]
    write_table_csv(table, path / "table1.csv")
    write_table_markdown(table, path / "table1.md", course_note(run.setup.course))
    write_json(
        path / "results.json",
        {
            "settings": run.settings.stored(),
            "rows": [row.to_dict() for row in rows],
            **hand_over(run, fastest, "GALA run"),
        },
    )
    if rows:
        write_row_files(run, rows)


def write_row_files(run: Run, rows: list[Row]) -> None:
    """The latest row's convergence plots (Fig. 6 and 7), its gait file and walk card, and
    best_gait.json when it is the best row so far."""
    path = run.folder.path
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
