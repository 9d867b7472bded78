"""``python -m optimizer.refine GAIT``: make a walk you already have faster, and keep it standing.

    python -m optimizer.refine runs/gala-.../fastest_gait.json                 # 8000 gaits of CMA-ES
    python -m optimizer.refine fastest_gait.json --family tfs-plus             # the TFS walk, then the additions
    python -m optimizer.refine my_walk.json --budget 800 --real 2              # on real servers

CMA-ES (the main job's refinement phase, ``optimizer.cli.gala``) starts from the gait in the file,
scored as every search of the project scores (robustly: ``--robust-walks`` dithered walks of the
gaits that could enter the top, ``optimizer.run.robust``), but by the worst of a gait's walks
(``--robust-quantile``, default 0 here: what it finds is handed over). The start itself is scored
first, so a refinement never hands over less than it was given. The best-scored gaits are then
checked (``--check-repeats`` walks each, dithered, from moved starts; ``--check-confirm`` more for
those that held), those that held walk on towards ``--hand-over-walks`` walks, best first, each
stopped once it fell, and the first that holds them all becomes fastest_gait.json, with its walk
card; when none does, the given walk, if it holds them.

``--family`` searches a larger family than the file's: a TFS walk starts a tfs-plus search as the
tfs-plus gait with its additions at 0, the walk it already is (``GaitFamily.from_gait``), and a
tfs-start search as the walk begun by itself, of which the search holds the start gait and moves
only the cruise gait (``gait.tfs_start``: fast TFS gaits fall at the start when moved at all).

Writes fastest_gait.json (and its walk card), results.json and episodes.jsonl (what ``--resume DIR``
continues from) into the run folder.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from gait import FAMILIES, GaitFileError, load_gait
from optimizer.cli.common import (
    HAND_OVER_DEFAULTS,
    EvaluatorMaker,
    add_walk_run_arguments,
    apply_preset,
    hand_over,
    in_box,
    pool_evaluator,
    prepare_run,
    run_session,
    search_box,
    stability_config,
    stored_quantile,
)
from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.robust import Race
from optimizer.run.stability import Fastest, fastest_walk, ranked_gaits
from optimizer.search.cmaes import CMAESRun, population_size
from optimizer.search.config import ScoringConfig
from optimizer.search.protocol import Batch, Candidate, KeyedSearch, Repair, SearchProgram
from optimizer.seeds import stable_seed
from protocol.cli_values import count, positive_float, positive_int

#: Keys of the refinement's episodes start with this (in the main job too).
REFINE_PREFIX = "refine"
#: The start gait's episodes are keyed under this.
START_KEY = "start"

#: The refinement's defaults, in the main job and here: 8000 gaits of CMA-ES, 20 a generation, from
#: each start with a first step of 0.05 of the box and one of 0.1, raced (``refine``): which step
#: climbs higher depends on the start's neighbourhood (docs/optimizer.md, "Why a refinement phase"),
#: and so does which start. Restarts after a patience without a gain (``optimizer.search.cmaes``;
#: docs/optimizer.md, "Restarts") are off until measured on the default rows' seeds.
DEFAULTS: dict[str, Any] = {
    "refine": 8000,
    "refine_sigma": [0.05, 0.1],
    "refine_population": 20,
    "refine_race": True,
    "refine_patience": None,
    "refine_lead_walks": 20,
}

#: The help of the refinement's leaders' walks, in the main job and here.
LEAD_WALKS_HELP = (
    "a refined gait that would be its run's best walks on to N walks in all first, and is scored by all "
    f"of them, so that a walk that falls once in 30 is seldom the best (default {DEFAULTS['refine_lead_walks']}; "
    "0: none; more than --robust-walks)"
)


def lead_walks(text: str) -> int:
    """``--lead-walks``'s value: 0 or a whole number of walks above 1."""
    value = count(text)
    if value == 1:
        raise argparse.ArgumentTypeError("1 is not more walks than a gait's first: give 0 (none) or at least 2")
    return value


#: The quantile of its walks a refined gait is scored by: the worst (``refine_scoring``).
REFINE_QUANTILE = 0.0


@dataclass(frozen=True)
class Arm:
    """One CMA-ES run of the refinement: its key prefix, start (genes) and first step."""

    prefix: str
    start: tuple[float, ...]
    sigma: float


def refinement_arms(settings: Mapping[str, Any], starts: Sequence[Sequence[float]], first: int = 0) -> list[Arm]:
    """The refinement's CMA-ES runs: one per start and step of ``settings["refine_sigma"]``, the
    starts in the order given, keyed ``refine<j>`` from j = ``first`` (a refinement of several
    families numbers on from the previous family's runs). A run from before several steps stored
    one number: one run keyed ``refine``, as it was made."""
    sigmas = settings["refine_sigma"]
    if isinstance(sigmas, (int, float)):
        return [Arm(REFINE_PREFIX, tuple(starts[0]), float(sigmas))]
    pairs = [(tuple(start), float(sigma)) for start in starts for sigma in sigmas]
    return [Arm(f"{REFINE_PREFIX}{first + j}", start, sigma) for j, (start, sigma) in enumerate(pairs)]


def refine_scoring(settings: Mapping[str, Any], scoring: ScoringConfig) -> ScoringConfig:
    """How the refinement scores a gait: as the run scores (``scoring``), but, in the main job, by
    the ``refine_quantile`` of its walks (a main job from before the setting, and this command,
    whose whole run is a refinement: the run's own quantile, by default here ``REFINE_QUANTILE``).

    The rows forgive one fall in five walks, which gives a population of falling gaits its slope
    towards walking. The refinement starts from walks that hold, and what it finds is handed over,
    so it forgives none: scored by the second-worst of 5, it climbed to where the walk falls one
    time in four (the seed-1 default row: 16.1 m on the stand-in, then 3 falls in 10 real walks);
    by the worst, to 15.5 m, 1 fall in 20 real walks (docs/optimizer.md, "The hand-over").

    A gait that would be the refinement's best walks on to ``refine_lead_walks`` walks first
    (``ScoringConfig.lead_walks``): the best is where a CMA-ES run starts again, which run wins the
    race, and the hand-over's first candidate."""
    quantile = settings.get("refine_quantile", scoring.quantile)
    lead = settings.get("refine_lead_walks", 0)  # a run from before leaders' walks: none, as it was made
    return replace(scoring, quantile=stored_quantile(quantile), lead_walks=lead)


def heat_gaits(settings: Mapping[str, Any], arms: int, genes: int) -> int:
    """Gaits each run walks in the race's heat: whole generations, a quarter of the budget over two
    runs (half of it over all of them), so the winner keeps half for itself. 0 where the settings
    do not race or the budget is too small for a generation each: then every run takes its share
    (the first ones one more where they do not divide)."""
    population = population_size(genes, settings.get("refine_population"))
    if arms < 2 or not settings.get("refine_race", False):  # a run from before the race: shares
        return 0
    return settings["refine"] // (2 * arms * population) * population


def refine(
    driver: Driver,
    settings: Mapping[str, Any],
    seed: int,
    bounds: np.ndarray,
    repair: Repair,
    starts: Sequence[Sequence[float]],
    held: Sequence[int] = (),
    family: str | None = None,
    first: int = 0,
) -> int:
    """CMA-ES from each of ``starts`` (genes) with each step of the settings (``refinement_arms``,
    numbered from ``first``), each run seeded from the run's seed and its prefix; every gait scored
    as the run scores. The genes ``held`` keep each start's values (the family's ``held``: a
    tfs-start search holds the start gait and searches the cruise gait). ``family`` names the
    genes' family where it is not the run's (the main job refines its TFS rows' walks as tfs-start
    walks). Returns the number of CMA-ES runs, where the next family's numbering goes on.

    The runs race: each walks a heat (``heat_gaits``), then the one whose best score is highest
    (the first on a tie) walks the rest of the budget, going on where it stopped, with its own
    racing bar. A start on a narrow ridge loses a large step's first generations to falls while one
    on a broad ridge climbs further with it, and a start the checks trusted can sit in a lower
    basin than the best-scored gait, which fell once: measured on a quick run whose start held at
    1.2 m, its two steps reached 6.38 m in 1600 gaits, and from the row's best (3.1 m, one fall in
    10 checks) 9.13 m (docs/optimizer.md). The heat costs each loser what it would have cost to
    know.

    The main job starts it from the fastest gait of the rows that held its check and from the
    best-scored gait (``refine_starts``): a fragile start's neighbourhood falls almost everywhere,
    and CMA-ES learns nothing from a population of falls (measured: from a gait that fell in 4 of
    its 10 check walks, 2,997 of 3,000 refined gaits fell), so such a run loses its heat. With
    ``--refine-reference`` the reference walk is one more start, for when every walk of the rows
    sits where gaits fall (``optimizer.cli.gala``)."""
    arms = refinement_arms(settings, starts, first)
    scoring = refine_scoring(settings, driver.scoring)
    total = settings["refine"]
    population = settings.get("refine_population")  # a run from before the flag: the library's default
    patience = settings.get("refine_patience")  # a run from before restarts: None, as it was made
    heat = heat_gaits(settings, len(arms), len(bounds))
    if heat == 0:
        share, extra = divmod(total, len(arms))
        for j, arm in enumerate(arms):
            driver.run(
                CMAESRun(
                    bounds,
                    repair,
                    stable_seed(seed, arm.prefix),
                    arm.start,
                    arm.sigma,
                    share + (j < extra),
                    arm.prefix,
                    population,
                    patience,
                    held,
                ),
                Race(scoring),
                family,
            )
        return len(arms)
    whole = total - (len(arms) - 1) * heat  # what the winner walks in all
    runs = [
        CMAESRun(
            bounds,
            repair,
            stable_seed(seed, arm.prefix),
            arm.start,
            arm.sigma,
            whole,
            arm.prefix,
            population,
            patience,
            held,
        )
        for arm in arms
    ]
    races = [Race(scoring) for _ in runs]
    for run, race in zip(runs, races):
        driver.run(Heat(run, heat), race, family)
    winner = max(range(len(runs)), key=lambda j: (_best_score(runs[j]), -j))
    driver.run(runs[winner], races[winner], family)
    return len(arms)


def refine_starts(driver: Driver, fastest: Fastest) -> list[tuple[float, ...]]:
    """Where the main job's refinement starts: the fastest gait that held its check, and the
    best-scored gait of the run when that is another (it may have fallen in its check)."""
    starts = [fastest.gait.genes]
    ranked = ranked_gaits(driver.scored)
    if ranked and ranked[0].genes != fastest.gait.genes:
        starts.append(ranked[0].genes)
    return [tuple(start) for start in starts]


def _best_score(run: CMAESRun) -> float:
    best = run.result()
    return -math.inf if best is None else best[0]


class Heat:
    """A search's next ``gaits`` gaits (whole batches), for the race of ``refine``."""

    def __init__(self, search: CMAESRun, gaits: int) -> None:
        self._search = search
        self._left = gaits

    @property
    def done(self) -> bool:
        return self._search.done or self._left <= 0

    def ask(self) -> list[Candidate]:
        return self._search.ask()

    def tell(self, results: Mapping[str, float]) -> None:
        self._left -= len(results)
        self._search.tell(results)

    def result(self) -> Any:
        return self._search.result()


class StartGait(KeyedSearch):
    """The start gait, scored as a search of one candidate (keyed ``start/i000``), so that it can be
    handed back if nothing beats it."""

    def __init__(self, genes: Sequence[float]) -> None:
        super().__init__(self._one(np.array([list(genes)], dtype=float)))

    @staticmethod
    def _one(genes: np.ndarray) -> SearchProgram:
        yield Batch(START_KEY, genes)

    def result(self) -> None:
        return None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m optimizer.refine", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("gait", metavar="GAIT", nargs="?", help="gait file to start from (not with --resume)")
    p.add_argument(
        "--budget",
        dest="refine",
        type=positive_int,
        default=None,
        metavar="N",
        help=f"gaits CMA-ES tries, all its runs together (default {DEFAULTS['refine']})",
    )
    p.add_argument(
        "--sigma",
        dest="refine_sigma",
        type=positive_float,
        nargs="+",
        default=None,
        metavar="S",
        help="the first step of each CMA-ES run, a fraction of the gene box; one run per step, the "
        f"budget shared (default {' '.join(map(str, DEFAULTS['refine_sigma']))})",
    )
    p.add_argument(
        "--population",
        dest="refine_population",
        type=positive_int,
        default=None,
        metavar="N",
        help=f"gaits per CMA-ES generation (default {DEFAULTS['refine_population']})",
    )
    p.add_argument(
        "--patience",
        dest="refine_patience",
        type=positive_int,
        default=None,
        metavar="G",
        help="start a CMA-ES run again from its best, with twice the gaits a generation, when its best has "
        "not gained 1%% in G generations (default: only when CMA-ES itself stops)",
    )
    p.add_argument(
        "--race",
        dest="refine_race",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="race the CMA-ES runs (one per step) and give the winner half the gaits (default); "
        "--no-race: the gaits shared evenly among the steps",
    )
    p.add_argument(
        "--lead-walks",
        dest="refine_lead_walks",
        type=lead_walks,
        default=None,
        metavar="N",
        help=LEAD_WALKS_HELP,
    )
    add_walk_run_arguments(p, REFINE_QUANTILE, hand_over=True)
    return p


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    args.start_gait = None
    if args.resume is None:
        if args.gait is None:
            parser.error("GAIT: a gait file to start from is needed (or --resume DIR)")
        try:
            given = load_gait(args.gait)
        except GaitFileError as exc:
            parser.error(f"GAIT: {exc}")
        family = FAMILIES[args.family] if args.family is not None else given.family
        try:
            start = family.from_gait(given)
        except ValueError as exc:
            parser.error(f"--family {family.name}: {exc}")
        args.family = family.name
        args.start_gait = list(start.genes)
    elif args.gait is not None:
        parser.error("GAIT: --resume continues from the run's own start gait; give no file")
    if args.resume is None:  # a resumed run keeps the quantile it was made with
        apply_preset(args, {"robust_quantile": REFINE_QUANTILE})
    run = prepare_run(parser, args, "refine", {**DEFAULTS, **HAND_OVER_DEFAULTS, "start_gait": None}, argv)
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)
    start_genes = run.settings["start_gait"]
    if not in_box(start_genes, bounds):
        parser.error(f"GAIT: the start gait lies outside the {run.family.name} family's search box")

    def body(driver: Driver) -> str:
        driver.run(StartGait(start_genes))
        refine(driver, run.settings, run.seed, bounds, repair, [start_genes], run.family.held)
        start = driver.scored.get(f"{START_KEY}/i000")
        fallback = [] if start is None else [start]  # when no refined walk holds, the given one may
        fastest = fastest_walk(driver, run.setup.start, stability, hand_over=True, fallback=fallback)
        write_json(run.folder.path / "results.json", {"settings": run.settings, **hand_over(run, fastest, "refined")})
        lines = []
        if start is not None:
            lines.append(f"start gait: scored {start.describe()}")
        if fastest is not None:
            lines.append(f"{fastest.describe()}; in fastest_gait.json (walk card: fastest_gait.card.md)")
        lines.append(f"results in {run.folder.path}")
        return "\n".join(lines)

    planned = 1 + run.settings["refine"] + stability.candidates * (stability.repeats + stability.confirm)
    planned += stability.hand_over
    return run_session(run, planned, body, make_evaluator=make_evaluator, quiet=args.quiet)
