"""A run's session: its folder made or reopened with its settings, seed and workers, the evaluator
(the embedded stub's worker pool, real servers or Dask) with the stub's kernels warmed up, and the
search body run under a progress bar with the ways it can end turned into exit statuses.
"""

from __future__ import annotations

import argparse
import os
import secrets
import signal
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from gait import DEFAULT_FAMILY, GaitFamily, family_named
from optimizer import settings as table
from optimizer.episode import (
    ServerAddress,
    start_problem_on_real_server,
)
from optimizer.episode.course import Course
from optimizer.episode.objectives import OBJECTIVES
from optimizer.episode.real_server import RealServerError, find_rcssserver3d
from optimizer.evaluation.pool import (
    EpisodeRunnerFactory,
    EvaluationError,
    Evaluator,
    ProcessPoolEvaluator,
)
from optimizer.run.driver import BarProgress, Driver, ResumeMismatch
from optimizer.run.folder import RunFolder, RunFolderError, new_run_path
from optimizer.run.run_settings import (
    course_of,
    episode_config,
    manifest_settings,
    resolve_settings,
    scoring_config,
    steers,
)
from optimizer.settings import Settings

#: Exit status of an interrupted run (the shell's convention for SIGINT).
EXIT_INTERRUPTED = 130


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
    #: the course every walk walks (``EpisodeConfig.on_course``; its start and time limit are
    #: ``start`` and ``walk_time``), None for walks scored by eq. 9
    course: Course | None = None
    #: a course walker steers by the server's pose where it sends one (``EpisodeConfig.true_pose``)
    true_pose: bool = True


def pool_evaluator(setup: EvaluationSetup) -> Evaluator:
    """The local evaluator: one worker process per core (or per server), each with one runner;
    or, with ``--scheduler`` / ``--dask-local``, a Dask cluster (``optimizer.evaluation.dask_cluster``)."""
    config = episode_config(
        setup.walk_time,
        setup.start,
        setup.agent_mode,
        setup.command_noise,
        setup.family,
        setup.drift_penalty,
        setup.course,
        setup.true_pose,
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
    settings: Settings
    seed: int
    setup: EvaluationSetup
    resumed: bool

    @property
    def family(self) -> GaitFamily:
        """The gait family the run searches."""
        return family_named(self.setup.family)


def prepare_run(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    command: str,
    argv: Sequence[str],
    defaults: Mapping[str, Any] | None = None,
) -> Run:
    """Resolve settings (from ``defaults``, else the table's for ``command``), seed and workers, and
    create or reopen the run folder. Every refusal goes through ``parser.error`` (exit status 2, the
    flag named)."""
    folder: RunFolder | None = args.resume
    stored = None
    if folder is not None:
        if folder.manifest.get("command") != command:
            parser.error(f"--resume: {folder.path} is a {folder.manifest.get('command')} run, not a {command} run")
        try:  # a run made by an older version: the settings it was made with, every one named
            stored = manifest_settings(folder.manifest).stored()
        except ValueError as exc:
            parser.error(f"--resume: {exc}")
        if args.seed is not None and args.seed != folder.manifest["seed"]:
            parser.error(f"--resume: --seed {args.seed} conflicts with the run's --seed {folder.manifest['seed']}")
    take_course(parser, args)
    resolved = resolve_settings(parser, args, table.defaults(command) if defaults is None else defaults, stored)
    settings = Settings.from_stored(resolved, command)
    check_objective(parser, settings)
    family = family_named(settings.episode.family)
    if settings.episode.bounds not in family.boxes:
        parser.error(
            f"--bounds {settings.episode.bounds}: the {family.name} family has the boxes {', '.join(family.boxes)}"
        )
    lead, walks = settings.refinement.lead_walks, settings.scoring.walks
    if "refine_lead_walks" in settings.keys and lead and lead <= walks:
        parser.error(
            f"lead walks {lead}: a leader walks on past its --robust-walks {walks}, "
            "so give more than that, or 0 for none"
        )
    servers = tuple(args.server or ())
    check_where(parser, args, servers)
    real_command = real_server_command(parser) if args.real is not None else None
    start = settings.episode.start
    if servers or real_command is not None:
        check_start_for_real_server(parser, start, "--real" if real_command else "--server")
    workers = args.dask_local or args.real or len(servers) or args.workers or os.cpu_count() or 1
    runtime = {
        "workers": workers,
        "servers": [str(s) for s in servers],
        "real": None if real_command is None else {"servers": args.real, "command": real_command},
        "dask": args.scheduler or (f"local:{args.dask_local}" if args.dask_local else None),
    }
    folder, seed = open_folder(parser, args, folder, command, settings, argv, runtime)
    episode, scoring = settings.episode, settings.scoring
    setup = EvaluationSetup(
        episode.walk_time,
        (start[0], start[1], start[2]),
        episode.agent_mode,
        servers,
        workers,
        seed,
        args.scheduler,
        args.dask_local,
        real_command,
        scoring.command_noise,
        episode.family,
        scoring.drift_penalty,
        course_of(settings),
        episode.true_pose,
    )
    return Run(command, folder, settings, seed, setup, resumed=stored is not None)


def take_course(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``--course`` given: it stands for ``--objective course`` (unless the objective is given, which
    ``check_objective`` then judges), and its start and time limit for ``--start`` and ``--walk-time``
    (stored as those settings, so that everything reading the run's start reads the course's)."""
    if args.course is None:
        return
    if args.objective is None:
        args.objective = "course"
    for name, flag in (("start", "--start"), ("walk_time", "--walk-time")):
        if getattr(args, name) is not None:
            parser.error(f"--course sets the start and the time limit of every walk: leave out {flag}")
    if args.resume is None:  # a resumed run has them stored; a course given then is compared as itself
        course = Course.from_document(args.course)
        args.start, args.walk_time = list(course.start), course.time_limit


def check_objective(parser: argparse.ArgumentParser, settings: Settings) -> None:
    """Refuse an objective and a course that do not go together: a course objective needs a course,
    a steerable family (the refinement's too) and no drift penalty (a course walk is scored by its
    time); a course or ``--no-true-pose`` needs the course objective."""
    scoring, episode = settings.scoring, settings.episode
    if OBJECTIVES[scoring.objective].needs_course:
        if scoring.course is None:
            parser.error(f"--objective {scoring.objective}: give the course to walk, --course FILE")
        if scoring.drift_penalty:
            parser.error(
                f"--drift-penalty {scoring.drift_penalty:g}: a course walk is scored by its time, not by its "
                "straightness; leave it at 0"
            )
        families = [("--family", episode.family)]
        refined = settings.refinement
        if "refine_family" in settings.keys and refined.budget and refined.family is not None:
            names = [refined.family] if isinstance(refined.family, str) else list(refined.family)
            families += [("--refine-family", name) for name in names]
        for flag, name in families:
            if not steers(family_named(name)):
                parser.error(
                    f"{flag} {name}: a course is walked by a steerable family (gait.Steerable: one that takes a "
                    f"command), which {name} is not"
                )
    else:
        if scoring.course is not None:
            parser.error(f"--course: a course is walked with --objective course, not --objective {scoring.objective}")
        if not episode.true_pose:
            parser.error("--no-true-pose: only a course walker steers by its pose; give --course FILE")


def check_where(parser: argparse.ArgumentParser, args: argparse.Namespace, servers: tuple[ServerAddress, ...]) -> None:
    """Refuse flags of where episodes run that contradict each other: one worker per server, and
    Dask workers name or start their own servers."""
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


def open_folder(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    folder: RunFolder | None,
    command: str,
    settings: Settings,
    argv: Sequence[str],
    runtime: dict[str, Any],
) -> tuple[RunFolder, int]:
    """A new run folder with its manifest and seed, or the resumed one with its log checked."""
    if folder is None:
        seed = args.seed if args.seed is not None else secrets.randbits(32)
        out = args.out or new_run_path(command)
        try:
            folder = RunFolder.create(out, command, settings.stored(), seed, argv, runtime, table.SETTINGS_VERSION)
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
    return folder, seed


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
