"""``python -m optimizer.refine GAIT``: make a walk you already have faster, and keep it standing.

    python -m optimizer.refine runs/gala-.../fastest_gait.json                 # 8000 gaits of CMA-ES
    python -m optimizer.refine fastest_gait.json --family tfs-plus             # the TFS walk, then the additions
    python -m optimizer.refine my_walk.json --budget 800 --real 2              # on real servers

CMA-ES (the main job's refinement phase, ``optimizer.job``) starts from the gait in the file,
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

import functools
import sys
from collections.abc import Sequence

from gait import FAMILIES, GaitFileError, load_gait
from optimizer import settings
from optimizer.job_refine import planned_episodes, refine_job
from optimizer.run.run_settings import apply_preset, in_box
from optimizer.run.session import EvaluatorMaker, pool_evaluator, prepare_run, run_session


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = settings.build_parser("refine", "python -m optimizer.refine", __doc__)
    parser.add_argument("gait", metavar="GAIT", nargs="?", help="gait file to start from (not with --resume)")
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
        # refused before the run folder is made, so that a refused start leaves no empty run behind
        box = family.boxes.get(args.bounds or settings.defaults("refine")["bounds"])  # no such box: refused below
        if box is not None and not in_box(args.start_gait, box):
            parser.error(f"GAIT: the start gait lies outside the {family.name} family's search box")
    elif args.gait is not None:
        parser.error("GAIT: --resume continues from the run's own start gait; give no file")
    if args.resume is None:  # a resumed run keeps the quantile it was made with
        apply_preset(args, settings.REFINE_NEW_RUN)
    run = prepare_run(parser, args, "refine", argv)

    body = functools.partial(refine_job, run=run)
    return run_session(run, planned_episodes(run), body, make_evaluator=make_evaluator, quiet=args.quiet)
