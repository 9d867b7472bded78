"""``python -m optimizer.refine GAIT``: make a walk you already have faster, and keep it standing.

    python -m optimizer.refine runs/gala-.../fastest_gait.json                 # 3000 gaits of CMA-ES
    python -m optimizer.refine fastest_gait.json --family tfs-plus             # the TFS walk, then the additions
    python -m optimizer.refine my_walk.json --budget 800 --real 2              # on real servers

CMA-ES (the main job's refinement phase, ``optimizer.cli.gala``) starts from the gait in the file,
scored as every search of the project scores (robustly: ``--robust-walks`` dithered walks of the
gaits that could enter the top, ``optimizer.run.robust``). The start itself is scored first, so a
refinement never hands over less than it was given. The best-scored gaits are then checked
(``--check-repeats`` walks each, dithered, from moved starts) and the fastest that held becomes
fastest_gait.json, with its walk card.

``--family`` searches a larger family than the file's: a TFS walk starts a tfs-plus search as the
tfs-plus gait with its additions at 0, the walk it already is (``GaitFamily.from_gait``).

Writes fastest_gait.json (and its walk card), results.json and episodes.jsonl (what ``--resume DIR``
continues from) into the run folder.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from gait import FAMILIES, GaitFileError, load_gait
from optimizer.cli.common import (
    EvaluatorMaker,
    add_walk_run_arguments,
    hand_over,
    pool_evaluator,
    prepare_run,
    run_session,
    search_box,
    stability_config,
)
from optimizer.evaluation.pool import stable_seed
from optimizer.run.driver import Driver
from optimizer.run.folder import write_json
from optimizer.run.stability import fastest_walk
from optimizer.search.cmaes import CMAESRun
from optimizer.search.ga import Batch, KeyedSearch, Repair, SearchProgram
from protocol.cli_values import positive_float, positive_int

#: Keys of the refinement's episodes start with this (in the main job too).
REFINE_PREFIX = "refine"
#: The start gait's episodes are keyed under this.
START_KEY = "start"

#: The refinement's defaults, in the main job and here: 8000 gaits, shared by two CMA-ES runs
#: from the same start, one with a first step of 0.05 of the box and one of 0.1, 20 gaits a
#: generation (docs/optimizer.md, "Why a refinement phase": which step climbs higher depends on the
#: start's neighbourhood, and on two seeds of the default row each step won once).
DEFAULTS: dict[str, Any] = {"refine": 8000, "refine_sigma": [0.05, 0.1], "refine_population": 20}


def refinements(settings: Mapping[str, Any]) -> list[tuple[str, float, int]]:
    """The refinement's CMA-ES runs as (key prefix, first step, gaits): one per step of
    ``settings["refine_sigma"]``, the ``settings["refine"]`` gaits shared evenly (the first runs
    take one more where they do not divide), keyed ``refine<j>/...``. A run from before several
    steps stored one number: one run keyed ``refine/...``, as it was made."""
    sigmas = settings["refine_sigma"]
    total = settings["refine"]
    if isinstance(sigmas, (int, float)):
        return [(REFINE_PREFIX, float(sigmas), total)]
    share, extra = divmod(total, len(sigmas))
    return [(f"{REFINE_PREFIX}{j}", float(s), share + (j < extra)) for j, s in enumerate(sigmas)]


def refine(
    driver: Driver, settings: Mapping[str, Any], seed: int, bounds: np.ndarray, repair: Repair, start: Sequence[float]
) -> None:
    """CMA-ES from ``start`` (genes), once per step of the settings (``refinements``), each run
    seeded from the run's seed and its prefix; every gait scored as the run scores.

    The main job runs it after its Table I rows, from the fastest gait of the rows that held its
    check: a fragile start's neighbourhood falls almost everywhere, and CMA-ES learns nothing from
    a population of falls (measured: from a gait that fell in 4 of its 10 check walks, 2,997 of
    3,000 refined gaits fell). Two steps, because a start on a narrow ridge loses a large step's
    first generations to falls while a start on a broad one climbs further with it."""
    for prefix, sigma, gaits in refinements(settings):
        driver.run(
            CMAESRun(
                bounds,
                repair,
                stable_seed(seed, prefix),
                start,
                sigma,
                gaits,
                prefix,
                settings.get("refine_population"),  # a run from before the flag: the library's default
            )
        )


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
    add_walk_run_arguments(p)
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
    run = prepare_run(parser, args, "refine", {**DEFAULTS, "start_gait": None}, argv)
    stability = stability_config(run.settings)
    bounds, repair = search_box(run.settings)
    start_genes = run.settings["start_gait"]
    if np.any(np.asarray(start_genes) < bounds[:, 0]) or np.any(np.asarray(start_genes) > bounds[:, 1]):
        parser.error(f"GAIT: the start gait lies outside the {run.family.name} family's search box")

    def body(driver: Driver) -> str:
        driver.run(StartGait(start_genes))
        refine(driver, run.settings, run.seed, bounds, repair, start_genes)
        fastest = fastest_walk(driver, run.setup.start, stability)
        write_json(run.folder.path / "results.json", {"settings": run.settings, **hand_over(run, fastest, "refined")})
        start = driver.scored.get(f"{START_KEY}/i000")
        lines = []
        if start is not None:
            lines.append(f"start gait: scored {start.describe()}")
        if fastest is not None:
            lines.append(f"{fastest.describe()}; in fastest_gait.json (walk card: fastest_gait.card.md)")
        lines.append(f"results in {run.folder.path}")
        return "\n".join(lines)

    planned = 1 + run.settings["refine"] + stability.candidates * stability.repeats
    return run_session(run, planned, body, make_evaluator=make_evaluator, quiet=args.quiet)
