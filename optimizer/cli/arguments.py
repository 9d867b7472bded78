"""The optimizer commands' shared flags and argument types: each type names what is wrong with a
value, and argparse adds the flag.

Flags default to None, so that a resumed run can tell a given flag from a default
(``optimizer.run.run_settings.resolve_settings``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gait import FAMILIES
from optimizer.episode import (
    CALIBRATED_COMMAND_NOISE,
    DEFAULT_START,
    ServerAddress,
)
from optimizer.run.folder import RunFolder, RunFolderError
from optimizer.run.run_settings import MEAN
from optimizer.search.config import ScoringConfig, StabilityConfig
from optimizer.search.refine import DEFAULTS as REFINE_DEFAULTS
from protocol.cli_values import (
    count,
    non_negative,
    number,
    positive_float,
    positive_int,
    probability,
)


def server_address(text: str) -> ServerAddress:
    """``HOST:AGENT_PORT:MONITOR_PORT`` of a running rcssserver3d."""
    try:
        return ServerAddress.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def quantile_or_mean(text: str) -> float | str:
    """A quantile within [0, 1], or ``mean``."""
    return MEAN if text == MEAN else probability(text)


def existing_run(text: str) -> RunFolder:
    try:
        return RunFolder.open(Path(text))
    except RunFolderError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_episode_arguments(parser: argparse.ArgumentParser) -> None:
    """How one episode is run: ``--walk-time``, ``--start`` and ``--agent-mode`` (default None:
    resolved later, so a resumed run can tell a given flag from a default)."""
    parser.add_argument(
        "--walk-time", type=positive_float, default=None, help="seconds of walking per episode (eq. 9; default 15)"
    )
    parser.add_argument(
        "--start",
        type=number,
        nargs=3,
        default=None,
        metavar=("X", "Y", "DEG"),
        help="where each walk starts: field position (m) and heading (deg, 0 = +x); the "
        "distance is measured along the heading from where the torso stands when the "
        "walk begins (default {:g} {:g} {:g})".format(*DEFAULT_START),
    )
    parser.add_argument(
        "--agent-mode",
        choices=("inprocess", "process"),
        default=None,
        help="run the agent inside the worker or as its own process (default inprocess)",
    )


def add_check_arguments(parser: argparse.ArgumentParser, hand_over: bool = False) -> None:
    """``--check-repeats`` and ``--check-jitter``: the stability check of the gaits a run finds
    (``optimizer.run.stability``); ``--check-confirm`` where the command hands over a fastest walk
    (``hand_over``; its settings then need ``HAND_OVER_DEFAULTS``)."""
    parser.add_argument(
        "--check-repeats",
        type=count,
        default=None,
        metavar="N",
        help="walk each gait the run reports N more times, each with its own draw of the command "
        "dither, and count the falls (default 10; 0: no check)",
    )
    parser.add_argument(
        "--check-jitter",
        type=non_negative,
        nargs=3,
        default=None,
        metavar=("DX", "DY", "DEG"),
        help="move the start of each check walk, and of each raced walk but a gait's first, within "
        "+-DX, +-DY (m) and +-DEG (heading) (default 0.05 0.05 10, the real server's beam noise)",
    )
    if not hand_over:
        return
    parser.add_argument(
        "--check-confirm",
        type=count,
        default=None,
        metavar="N",
        help="walk each candidate for the fastest walk that held its check N more times before it may be "
        f"handed over, so that the best of several is not the luckiest (default {StabilityConfig().confirm}; "
        "0: hand over on the checks alone)",
    )
    parser.add_argument(
        "--hand-over-walks",
        type=count,
        default=None,
        metavar="N",
        help="before the run's fastest walk is handed over at its end, its confirmed candidates walk on, "
        "best first, towards N walks each (stopped once one falls), and the first that holds them all "
        "is it; when none does, the walk the refinement started from, if it holds them "
        f"(default {StabilityConfig().hand_over}; at most the check and confirming walks: no more walks)",
    )


def add_scoring_arguments(parser: argparse.ArgumentParser, quantile: float | None = ScoringConfig().quantile) -> None:
    """How candidates are scored (``optimizer.run.robust``) and the dither every walk gets;
    ``quantile`` is the command's default, for its help."""
    parser.add_argument(
        "--robust-walks",
        type=positive_int,
        default=None,
        metavar="K",
        help=f"score a gait over K walks, each with its own draw of the command dither, raced: only a "
        f"gait whose first walk could enter its search's top walks the rest (default {ScoringConfig().walks}; "
        "1: one walk, the paper's eq. 9)",
    )
    parser.add_argument(
        "--robust-top",
        type=positive_int,
        default=None,
        metavar="N",
        help=f"racing: a first walk earns the other K - 1 when it beats the N-th best score of its "
        f"search so far (default {ScoringConfig().top})",
    )
    parser.add_argument(
        "--robust-quantile",
        type=quantile_or_mean,
        default=None,
        metavar="Q",
        help="score K walks by this quantile of their eq. 9 fitness (default "
        f"{MEAN if quantile is None else format(quantile, 'g')}; with K 5, 0 is "
        "the worst walk and 0.25 the second-worst), or by their mean with 'mean'",
    )
    parser.add_argument(
        "--command-noise",
        type=non_negative,
        default=None,
        metavar="RAD_S",
        help="the agent's dither of every walking velocity command, uniform within +-RAD_S, seeded "
        f"per walk (default {CALIBRATED_COMMAND_NOISE:g}, calibrated to the real server's run-to-run "
        "spread; 0 with --robust-walks 1 walks and scores exactly as the paper)",
    )
    parser.add_argument(
        "--drift-penalty",
        type=non_negative,
        default=None,
        metavar="W",
        help="take W metres off a walk's distance for each metre it drifted sideways from the line it "
        "started on, so that the search prefers straight walks (default 0: eq. 9)",
    )


def add_run_arguments(parser: argparse.ArgumentParser, population: int = 100, hand_over: bool = False) -> None:
    """Flags of the population searches (GA, GALA, the comparison): the GA numbers they share,
    then every search command's (``add_walk_run_arguments``); ``population`` is the command's own
    default, for its help."""
    parser.add_argument("--population", type=positive_int, default=None, help=f"population size (default {population})")
    parser.add_argument(
        "--elitism",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="carry the best individual into the next generation (default on)",
    )
    add_walk_run_arguments(parser, hand_over=hand_over)


def add_walk_run_arguments(
    parser: argparse.ArgumentParser, quantile: float | None = ScoringConfig().quantile, hand_over: bool = False
) -> None:
    """Flags of every search command: the family and box, the episodes, scoring and checks, the
    seed, where episodes run, the run folder and the workers; ``quantile``: the command's default
    ``--robust-quantile``, for its help; ``hand_over``: whether it hands over a fastest walk."""
    parser.add_argument(
        "--family",
        choices=list(FAMILIES),
        default=None,
        help="the gait family searched (default tfs, the paper's 7 genes): "
        + "; ".join(f"{f.name}: {f.about}" for f in FAMILIES.values()),
    )
    parser.add_argument(
        "--bounds",
        choices=sorted({box for f in FAMILIES.values() for box in f.boxes}),
        default=None,
        help="the gene box searched: robot (from the NAO's joint limits, speed cap and control "
        "cycle; the default) or legacy (tfs only: the narrower box of earlier versions)",
    )
    add_episode_arguments(parser)
    add_scoring_arguments(parser, quantile)
    add_check_arguments(parser, hand_over)
    parser.add_argument(
        "--seed", type=int, default=None, help="fixes every random choice of the run (default: a random seed, recorded)"
    )
    add_server_arguments(parser)
    parser.add_argument(
        "--workers", type=positive_int, default=None, help="worker processes (default: one per core; one per --server)"
    )
    dask = parser.add_mutually_exclusive_group()
    dask.add_argument(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:8786",
        help="send episodes to this Dask scheduler (needs pip install '.[dask]')",
    )
    dask.add_argument(
        "--dask-local",
        type=positive_int,
        default=None,
        metavar="N",
        help="start a local Dask cluster of N workers (needs pip install '.[dask]')",
    )
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--out", type=Path, default=None, help="new run folder (default runs/<command>-<time>)")
    where.add_argument(
        "--resume",
        type=existing_run,
        default=None,
        metavar="DIR",
        help="continue the run in DIR: finished episodes are not run again",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--skip-bad-lines",
        action="store_true",
        help="with --resume: move lines of the episode log that cannot be used to "
        "episodes.jsonl.rejected (and say how many) instead of stopping",
    )


def add_server_arguments(parser: argparse.ArgumentParser, *, repeatable: bool = True) -> None:
    """Where episodes run: ``--real N`` (real rcssserver3d servers started here) or ``--server``
    (servers run elsewhere); neither: the embedded stub."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--real",
        type=positive_int,
        default=None,
        metavar="N",
        help="start N real rcssserver3d servers (from $RCSSSERVER3D, else rcssserver3d on PATH) "
        "in a sync profile on free ports, one worker each, and stop them at the end"
        if repeatable
        else "start a real rcssserver3d (N must be 1) and stop it at the end",
    )
    where.add_argument(
        "--server",
        type=server_address,
        action="append" if repeatable else "store",
        default=None,
        metavar="HOST:AGENT_PORT:MONITOR_PORT",
        help="evaluate on this running rcssserver3d instead of the embedded stub"
        + ("; repeat for more servers (one worker per server)" if repeatable else ""),
    )


#: The help of the refinement's leaders' walks, in the main job and here.
LEAD_WALKS_HELP = (
    "a refined gait that would be its run's best walks on to N walks in all first, and is scored by all of "
    "them, so that a walk that falls once in 30 is seldom the best "
    f"(default {REFINE_DEFAULTS['refine_lead_walks']}; 0: none; more than --robust-walks)"
)


def lead_walks(text: str) -> int:
    """``--lead-walks``'s value: 0 or a whole number of walks above 1."""
    value = count(text)
    if value == 1:
        raise argparse.ArgumentTypeError("1 is not more walks than a gait's first: give 0 (none) or at least 2")
    return value
