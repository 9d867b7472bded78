"""What the optimizer's commands share: argument types, the run flags, settings and resume
checks, and running a search session with its evaluator, log and progress bar.

Settings are what decides a run's episodes (search numbers, walk time, agent mode) and are stored
in the manifest; ``--resume`` takes them from there and refuses a flag that contradicts them.
How the run is executed (workers, servers, progress) is not a setting and may change on resume.
"""

from __future__ import annotations

import argparse
import functools
import os
import secrets
import signal
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gait import DEFAULT_FAMILY, FAMILIES, GaitFamily, family_named, save_gait
from optimizer.episode import (
    CALIBRATED_COMMAND_NOISE,
    DEFAULT_START,
    EpisodeConfig,
    ServerAddress,
    start_problem_on_real_server,
)
from optimizer.episode.real_server import RealServerError, find_rcssserver3d
from optimizer.evaluation.pool import (
    EpisodeRunnerFactory,
    EvaluationError,
    Evaluator,
    ProcessPoolEvaluator,
)
from optimizer.run.driver import BarProgress, Driver, ResumeMismatch
from optimizer.run.folder import RunFolder, RunFolderError, new_run_path
from optimizer.run.robust import ScoredGait
from optimizer.run.stability import Fastest, StabilityReport, scored_summary
from optimizer.run.walk_card import REAL_SERVER, STAND_IN, CardWalk, WalkCard, write_card
from optimizer.search.config import ScoringConfig, StabilityConfig
from protocol.cli_values import (
    count,
    non_negative,
    number,
    positive_float,
    positive_int,
    probability,
)

#: Exit status of an interrupted run (the shell's convention for SIGINT).
EXIT_INTERRUPTED = 130


# --- argument types: each names what is wrong; argparse adds the flag -----------------------------


def server_address(text: str) -> ServerAddress:
    """``HOST:AGENT_PORT:MONITOR_PORT`` of a running rcssserver3d."""
    try:
        return ServerAddress.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def quantile_or_mean(text: str) -> float | str:
    """A quantile within [0, 1], or ``mean``."""
    return MEAN if text == MEAN else probability(text)


#: How the settings store "score by the mean" (None would read as "not given").
MEAN = "mean"


def stored_quantile(value: float | str | None) -> float | None:
    """A quantile setting as ``ScoringConfig`` takes it: the stored ``MEAN`` (the one text a quantile
    setting holds, ``quantile_or_mean``) is None, the mean."""
    return None if isinstance(value, str) else value


def existing_run(text: str) -> RunFolder:
    try:
        return RunFolder.open(Path(text))
    except RunFolderError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


# --- flags ----------------------------------------------------------------------------------------


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


#: Defaults of the check settings the commands store.
CHECK_DEFAULTS: dict[str, Any] = {
    "check_repeats": StabilityConfig().repeats,
    "check_jitter": list(StabilityConfig().jitter),
}

#: Defaults of the settings of a command that hands over a fastest walk (``fastest_walk``).
HAND_OVER_DEFAULTS: dict[str, Any] = {
    "check_confirm": StabilityConfig().confirm,
    "hand_over_walks": StabilityConfig().hand_over,
}

#: Defaults of the scoring settings the commands store.
SCORING_DEFAULTS: dict[str, Any] = {
    "robust_walks": ScoringConfig().walks,
    "robust_top": ScoringConfig().top,
    "robust_quantile": ScoringConfig().quantile,
    "command_noise": CALIBRATED_COMMAND_NOISE,
    "drift_penalty": 0.0,
}

#: What a run made before robust scoring stored nothing about: one undithered walk a gait, and
#: checks from starts moved within the real server's beam noise.
_LEGACY_SCORING: dict[str, Any] = {"robust_walks": 1, "robust_quantile": MEAN, "command_noise": 0.0}
_LEGACY_JITTER = (0.05, 0.05, 10.0)


def stability_config(settings: Mapping[str, Any]) -> StabilityConfig:
    """The run's check; a run made before checks existed has none, one made before confirming walks
    hands over on its candidates' checks alone, one made before hand-over walks on its confirmed ones."""
    return StabilityConfig(
        repeats=settings.get("check_repeats", 0),
        jitter=tuple(settings.get("check_jitter", _LEGACY_JITTER)),
        confirm=settings.get("check_confirm", 0),
        hand_over=settings.get("hand_over_walks", 0),
    )


def scoring_config(settings: Mapping[str, Any]) -> ScoringConfig:
    """The run's scoring; a run made before robust scoring scored by one walk."""
    quantile = settings.get("robust_quantile", _LEGACY_SCORING["robust_quantile"])
    return ScoringConfig(
        walks=settings.get("robust_walks", _LEGACY_SCORING["robust_walks"]),
        top=settings.get("robust_top", ScoringConfig().top),
        quantile=stored_quantile(quantile),
        jitter=stability_config(settings).jitter,
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


#: The family and gene box a new run searches; a run folder without the settings searched the TFS
#: family, in the legacy box.
BOUNDS_DEFAULTS: dict[str, Any] = {"family": DEFAULT_FAMILY, "bounds": "robot"}


def run_family(settings: Mapping[str, Any]) -> str:
    """The run's gait family (a run from before families: the paper's TFS)."""
    return str(settings.get("family", DEFAULT_FAMILY))


def search_box(
    settings: Mapping[str, Any], family: GaitFamily | None = None
) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
    """The run's gene bounds and the repair that keeps a chromosome inside them: of the run's own
    family, or of ``family`` (the refinement's), in the run's named box."""
    family = family_named(run_family(settings)) if family is None else family
    bounds = family.boxes[settings.get("bounds", "legacy")]
    return bounds, functools.partial(family.repair, bounds=bounds)


def in_box(genes: Sequence[float], bounds: np.ndarray) -> bool:
    """Whether ``genes`` lie inside ``bounds`` (edges included): a search starts only from inside
    its box, since the box's repair would move the start before its first walk."""
    values = np.asarray(genes, dtype=float)
    return bool(np.all(values >= bounds[:, 0]) and np.all(values <= bounds[:, 1]))


#: Defaults of the episode settings every command stores.
EPISODE_DEFAULTS: dict[str, Any] = {"walk_time": 15.0, "start": list(DEFAULT_START), "agent_mode": "inprocess"}
#: Where runs made before ``--start`` existed started.
LEGACY_START: tuple[float, float, float] = (0.0, 0.0, 0.0)


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


def real_server_command(parser: argparse.ArgumentParser) -> str:
    """The real server's command for ``--real``, or a refusal naming where it was looked for."""
    try:
        return find_rcssserver3d()
    except RealServerError as exc:
        parser.error(f"--real: {exc}")


def check_start_for_real_server(parser: argparse.ArgumentParser, start: Sequence[float], flag: str) -> None:
    """Refuse a start a real server's referee would not leave alone."""
    problem = start_problem_on_real_server((start[0], start[1], start[2]))
    if problem is not None:
        parser.error(f"{flag} with --start {' '.join(f'{v:g}' for v in start)}: {problem}")


def episode_config(
    walk_time: float,
    start: Sequence[float],
    agent_mode: str,
    command_noise: float = 0.0,
    family: str = DEFAULT_FAMILY,
    drift_penalty: float = 0.0,
) -> EpisodeConfig:
    x, y, heading = start
    return EpisodeConfig(
        walk_time=walk_time,
        start=(x, y),
        heading=heading,
        agent_mode=agent_mode,
        command_noise=command_noise,
        family=family,
        drift_penalty=drift_penalty,
    )


def _flag(name: str, value: Any) -> str:
    if isinstance(value, bool):
        return f"--{name.replace('_', '-')}" if value else f"--no-{name.replace('_', '-')}"
    shown = " ".join(map(str, value)) if isinstance(value, (list, tuple)) else value
    return f"--{name.replace('_', '-')} {shown}"


def resolve_settings(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    defaults: Mapping[str, Any],
    stored: Mapping[str, Any] | None,
) -> dict[str, Any]:
    """The run's settings: the stored ones on ``--resume`` (a given flag that contradicts one is
    refused), else each given flag or its default. Lists are compared and stored as lists."""
    given = {name: getattr(args, name) for name in defaults if getattr(args, name) is not None}
    given = {k: list(v) if isinstance(v, tuple) else v for k, v in given.items()}
    if stored is None:
        return {**defaults, **given}
    for name, value in given.items():
        if name not in stored:
            parser.error(f"--resume: the run has no setting {name!r}; it was made by another version")
        if value != stored[name]:
            parser.error(f"--resume: {_flag(name, value)} conflicts with the run's {_flag(name, stored[name])}")
    return dict(stored)


# --- the session ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class EvaluationSetup:
    """What an evaluator is made from (everything but the search)."""

    walk_time: float
    start: tuple[float, float, float]
    agent_mode: str
    servers: tuple[ServerAddress, ...]
    workers: int
    seed: int
    scheduler: str | None = None
    dask_local: int | None = None
    #: the real server's command when each worker starts one of its own (``--real``)
    real_command: str | None = None
    #: the agent's command dither of every walk (rad/s; ``EpisodeConfig.command_noise``)
    command_noise: float = 0.0
    #: the gait family the search's genes belong to
    family: str = DEFAULT_FAMILY
    #: fitness per metre of sideways drift (``EpisodeConfig.drift_penalty``)
    drift_penalty: float = 0.0


def pool_evaluator(setup: EvaluationSetup) -> Evaluator:
    """The local evaluator: one worker process per core (or per server), each with one runner;
    or, with ``--scheduler`` / ``--dask-local``, a Dask cluster (``optimizer.evaluation.dask_cluster``)."""
    config = episode_config(
        setup.walk_time, setup.start, setup.agent_mode, setup.command_noise, setup.family, setup.drift_penalty
    )
    if setup.scheduler is not None or setup.dask_local is not None:
        try:
            from optimizer.evaluation.dask_cluster import DaskEvaluator
        except ImportError as exc:
            raise EvaluationError(f"Dask is not installed ({exc}); pip install '.[dask]'") from None
        return DaskEvaluator(
            config,
            setup.seed,
            scheduler=setup.scheduler,
            local_workers=setup.dask_local,
            real=setup.real_command is not None,
        )
    # an episode may take the runner's timeout twice (it restarts and retries once) plus a restart
    timeout = 2 * config.episode_timeout + 30.0
    if not setup.servers and setup.real_command is None:
        # the embedded stand-in's kernels compiled once here, in two processes on a fresh clone,
        # rather than by every worker at once; the workers load them from numba's cache
        from optimizer.episode import rounding
        from server_stub import kernels

        kernels.warm_up(kernels.WALK, eager=False)
        rounding.warm_up()
    return ProcessPoolEvaluator(
        EpisodeRunnerFactory(config, setup.servers, setup.seed, setup.real_command), setup.workers, task_timeout=timeout
    )


EvaluatorMaker = Callable[[EvaluationSetup], Evaluator]


@dataclass
class Run:
    """A prepared run: its folder, settings and seed, and how to evaluate."""

    command: str
    folder: RunFolder
    settings: dict[str, Any]
    seed: int
    setup: EvaluationSetup
    resumed: bool

    @property
    def family(self) -> GaitFamily:
        """The gait family the run searches."""
        return family_named(self.setup.family)


def apply_preset(args: argparse.Namespace, values: Mapping[str, Any]) -> None:
    """A preset (a budget) stands for the flags it sets; a flag given on the command line wins."""
    for name, value in values.items():
        if getattr(args, name) is None:
            setattr(args, name, value)


def prepare_run(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    command: str,
    defaults: Mapping[str, Any],
    argv: Sequence[str],
) -> Run:
    """Resolve settings, seed and workers, and create or reopen the run folder. Every refusal goes
    through ``parser.error`` (exit status 2, the flag named)."""
    folder: RunFolder | None = args.resume
    stored = None
    if folder is not None:
        if folder.manifest.get("command") != command:
            parser.error(f"--resume: {folder.path} is a {folder.manifest.get('command')} run, not a {command} run")
        stored = folder.manifest["settings"]
        if args.seed is not None and args.seed != folder.manifest["seed"]:
            parser.error(f"--resume: --seed {args.seed} conflicts with the run's --seed {folder.manifest['seed']}")
    settings = resolve_settings(
        parser, args, {**defaults, **EPISODE_DEFAULTS, **SCORING_DEFAULTS, **CHECK_DEFAULTS, **BOUNDS_DEFAULTS}, stored
    )
    family = family_named(run_family(settings))
    if settings.get("bounds", "legacy") not in family.boxes:
        parser.error(f"--bounds {settings['bounds']}: the {family.name} family has the boxes {', '.join(family.boxes)}")
    lead, walks = settings.get("refine_lead_walks", 0), scoring_config(settings).walks
    if lead and lead <= walks:
        parser.error(
            f"lead walks {lead}: a leader walks on past its --robust-walks {walks}, "
            "so give more than that, or 0 for none"
        )
    servers = tuple(args.server or ())
    if servers and args.workers is not None and args.workers != len(servers):
        parser.error(
            f"--workers {args.workers} conflicts with {len(servers)} --server address(es): one worker per server"
        )
    if servers and (args.scheduler or args.dask_local):
        parser.error(
            "--server conflicts with --scheduler/--dask-local: on Dask, name each worker's "
            "server in its environment (GALA_SERVER=HOST:AGENT_PORT:MONITOR_PORT)"
        )
    if args.real is not None:
        if args.workers is not None and args.workers != args.real:
            parser.error(f"--workers {args.workers} conflicts with --real {args.real}: one worker per server")
        if args.scheduler:
            parser.error(
                "--real conflicts with --scheduler: on a cluster, have each Dask worker start its own "
                "real server (GALA_REAL_SERVER=1 in its environment)"
            )
        if args.dask_local is not None and args.dask_local != args.real:
            parser.error(f"--dask-local {args.dask_local} conflicts with --real {args.real}: one server per worker")
    real_command = real_server_command(parser) if args.real is not None else None
    start = tuple(settings.get("start", LEGACY_START))
    if servers or real_command is not None:
        check_start_for_real_server(parser, start, "--real" if real_command else "--server")
    workers = args.dask_local or args.real or len(servers) or args.workers or os.cpu_count() or 1
    runtime = {
        "workers": workers,
        "servers": [str(s) for s in servers],
        "real": None if real_command is None else {"servers": args.real, "command": real_command},
        "dask": args.scheduler or (f"local:{args.dask_local}" if args.dask_local else None),
    }
    if folder is None:
        seed = args.seed if args.seed is not None else secrets.randbits(32)
        out = args.out or new_run_path(command)
        try:
            folder = RunFolder.create(out, command, settings, seed, argv, runtime)
        except RunFolderError as exc:
            parser.error(f"--out: {exc}")
    else:
        seed = folder.manifest["seed"]
        try:  # a damaged log: one line naming the file, the line and the problem, no traceback
            for note in folder.check_log(skip_bad_lines=args.skip_bad_lines):
                print(f"warning: {note}", file=sys.stderr)
        except RunFolderError as exc:
            parser.exit(1, f"{parser.prog}: error: {exc}\n")
        folder.note_resume(argv, runtime)
    setup = EvaluationSetup(
        settings["walk_time"],
        start,
        settings["agent_mode"],
        servers,
        workers,
        seed,
        args.scheduler,
        args.dask_local,
        real_command,
        settings.get("command_noise", _LEGACY_SCORING["command_noise"]),
        run_family(settings),
        settings.get("drift_penalty", 0.0),
    )
    return Run(command, folder, settings, seed, setup, resumed=stored is not None)


def _interrupt(*_: object) -> None:
    raise KeyboardInterrupt


def run_session(
    run: Run,
    planned_episodes: int,
    body: Callable[[Driver], str],
    *,
    make_evaluator: EvaluatorMaker = pool_evaluator,
    quiet: bool = False,
) -> int:
    """Open the log and the evaluator, run ``body`` with a driver and print the summary it returns
    (after the progress bar is gone), and turn the ways a run can end into exit statuses:
    0 done, 1 cannot evaluate or cannot resume, 130 interrupted (resumable)."""
    say = (lambda text: None) if quiet else (lambda text: print(text, file=sys.stderr))
    log = run.folder.open_log()
    for warning in log.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    logged = list(log.records.values())
    say(
        f"{run.command}: run folder {run.folder.path} (seed {run.seed}, {run.setup.workers} worker(s)"
        + (f", {len(logged)} episodes already logged)" if run.resumed else ")")
    )
    # the best score so far comes back as the search is replayed from the log
    progress = BarProgress(planned_episodes, len(logged), quiet=quiet)
    evaluator: Evaluator | None = None
    # SIGTERM (a scheduler's or a service manager's stop) ends the run as Ctrl-C does: resumable,
    # workers and the servers they started stopped
    previous = (
        signal.signal(signal.SIGTERM, _interrupt) if threading.current_thread() is threading.main_thread() else None
    )
    try:
        evaluator = make_evaluator(run.setup)
        driver = Driver(evaluator, log, run.seed, progress, scoring_config(run.settings), run.setup.start)
        summary = body(driver)
    except KeyboardInterrupt:
        progress.close()
        print(
            f"\ninterrupted; continue with: python -m optimizer.{run.command} --resume {run.folder.path}",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    except (EvaluationError, ResumeMismatch) as exc:
        progress.close()
        print(f"error: {exc}", file=sys.stderr)
        return 1
    finally:
        if evaluator is not None:
            evaluator.close()
        log.close()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    progress.close(finished=True)
    print(summary)
    return 0


# --- result files shared by the commands ----------------------------------------------------------


def best_gait(driver: Driver, key: str | None) -> ScoredGait | None:
    """The scored gait of a search's best (``KeyedSearch.best_key``): its walks' distance and
    speed go into the tables. None when the search has no best (every episode failed)."""
    return None if key is None else driver.scored.get(key)


def write_gait(
    run: Run, path: Path, genes: Sequence[float] | np.ndarray, notes: str, family: str | None = None
) -> None:
    """A gait the run found, as a gait file of its family (the run's, unless ``family`` names
    another) that the agent takes with ``--gait``."""
    save_gait((run.family if family is None else family_named(family)).gait(genes), path, notes)


def walked_on(setup: EvaluationSetup) -> str:
    """The walk-card side of a run's own walks: the real server's when it walked on one."""
    return REAL_SERVER if setup.real_command is not None or setup.servers else STAND_IN


def card_of(run: Run, name: str, check: StabilityReport) -> WalkCard:
    """The walk card of a checked gait: its check walks, on the server the run walked on."""
    walks = tuple(map(CardWalk.from_record, check.repeats))
    family = check.gait.family or run.setup.family
    return WalkCard(
        name, check.gait.genes, run.setup.walk_time, run.setup.start[2], {walked_on(run.setup): walks}, family
    )


def hand_over(run: Run, fastest: Fastest | None, what: str) -> dict[str, Any]:
    """Write the run's fastest walk as fastest_gait.json (notes: ``what`` and its verdict) with its
    walk card beside it; returns its entries of results.json."""
    if fastest is not None:
        path = run.folder.path / "fastest_gait.json"
        write_gait(run, path, fastest.gait.genes, f"{what}: {fastest.describe()}", fastest.gait.family)
        if fastest.check is not None:
            write_card(card_of(run, "fastest walk", fastest.check), path)
    return {
        "fastest_episode": None if fastest is None else fastest.gait.walks[0].to_json(),
        "fastest_score": None if fastest is None else scored_summary(fastest.gait),
        "fastest_check": None if fastest is None or fastest.check is None else fastest.check.to_dict(),
    }
