"""``python -m optimizer.transfer RUN_DIR --real N``: will the gaits a run reported walk on a real server?

Walks every gait the run reported (each Table I row's best, ``best_gait.json``, ``fastest_gait.json``;
a GA run's best) ``--repeats`` times on real rcssserver3d servers (``--real N`` started here, or
``--server`` run elsewhere; with neither, on the embedded stand-in, which re-checks a run made
elsewhere) as the run's check walked them: from starts moved within its check jitter and, on
the stand-in, each with its own draw of the run's command dither (a real server has its own
spread; a run older than the dither, checked from unmoved starts, is walked from starts moved
within the real server's beam noise, else the deterministic stand-in would walk one walk ten
times); and sets what the run measured beside what was measured now:

    python -m optimizer.transfer runs/gala-20261201-101500 --real 2
    python -m optimizer.transfer runs/gala-20261201-101500 --server 127.0.0.1:3100:3200 --repeats 20

Writes into the run folder: ``transfer.csv`` (one row per gait: the run's figures, the new walks'
falls, shortest, mean and longest distance), ``transfer.md`` (the same as a table),
``transfer.png`` (the run's distance against the new one, each with its spread) and
``transfer.json`` (every walk). The run itself is not changed, but for the walk cards
(``optimizer.run.walk_card``): every reported gait's gait file gets the new walks as the card's
"real server" side (or "stand-in" side, when walked on the stand-in) beside it, the card's other
side kept; a gait file without a card gets one with just the new side. A gait with no gait file
in the folder (a comparison's) gets no card.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from gait import family_named
from optimizer.cli.arguments import add_server_arguments
from optimizer.episode import DEFAULT_START, Start, start_problem_on_real_server
from optimizer.evaluation.pool import EvaluationError
from optimizer.run.folder import RunFolder
from optimizer.run.run_settings import course_of, manifest_settings
from optimizer.run.run_settings import jitter as jitter_of
from optimizer.run.session import (
    EvaluationSetup,
    EvaluatorMaker,
    check_start_for_real_server,
    pool_evaluator,
    real_server_command,
)
from optimizer.run.transfer_report import (
    BEAM_NOISE,
    reported_gaits,
    run_server_kind,
    transfer_tasks,
    write_report,
)
from optimizer.settings import existing_run
from protocol.cli_values import non_negative, number, positive_int


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m optimizer.transfer", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "run",
        type=existing_run,
        metavar="RUN_DIR",
        help="a run folder of optimizer.gala, optimizer.ga or optimizer.compare",
    )
    add_server_arguments(p)
    p.add_argument("--repeats", type=positive_int, default=10, metavar="R", help="walks per gait (default 10)")
    p.add_argument(
        "--jitter",
        type=non_negative,
        nargs=3,
        default=None,
        metavar=("DX", "DY", "DEG"),
        help="how far each walk's start is moved (default: the run's check jitter)",
    )
    p.add_argument(
        "--start",
        type=number,
        nargs=3,
        default=None,
        metavar=("X", "Y", "DEG"),
        help="where the walks start (default: the run's start, or {:g} {:g} {:g} where a real "
        "server's referee would move a robot from it)".format(*DEFAULT_START),
    )
    p.add_argument("--seed", type=int, default=None, help="seed of the moved starts (default: the run's)")
    return p


def _start(
    parser: argparse.ArgumentParser, args: argparse.Namespace, run_start: Start, real: bool, course: bool = False
) -> Start:
    if course:  # a course's poses lie where they lie: its walks start at its start or nowhere
        if real:
            check_start_for_real_server(parser, run_start, "--real" if args.real else "--server")
        return run_start
    if args.start is not None:
        start: Start = (args.start[0], args.start[1], args.start[2])
        if real:
            check_start_for_real_server(parser, start, "--real" if args.real else "--server")
        return start
    # the distance is measured from where the walk begins, so a start moved off the centre line
    # walks the same gait; runs made before the default start moved began at (0, 0)
    return DEFAULT_START if real and start_problem_on_real_server(run_start) else run_start


def main(argv: Sequence[str] | None = None, *, make_evaluator: EvaluatorMaker = pool_evaluator) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    folder: RunFolder = args.run
    try:
        results = json.loads((folder.path / "results.json").read_text())
    except (OSError, ValueError) as exc:
        parser.error(f"RUN_DIR: {folder.path} has no readable results.json yet ({exc})")
    gaits = reported_gaits(results)
    if not gaits:
        parser.error(f"RUN_DIR: {folder.path} reports no gait yet")
    try:  # a run made by an older version: the settings it was made with, every one named
        settings = manifest_settings(folder.manifest)
    except ValueError as exc:
        parser.error(f"RUN_DIR: {exc}")
    episode = settings.episode
    real = bool(args.real or args.server)
    x, y, heading = episode.start
    course = course_of(settings)
    if course is not None and args.start is not None:
        parser.error("--start: the run walks a course, whose own start every walk starts from")
    start = _start(parser, args, (x, y, heading), real, course is not None)
    jitter = tuple(args.jitter) if args.jitter is not None else jitter_of(settings)
    # the dither stands in for the real server's spread, so only the stand-in's walks get it
    command_noise = 0.0 if real else settings.scoring.command_noise
    if not any(jitter) and not real and command_noise == 0:
        jitter = BEAM_NOISE  # the stand-in is deterministic: unmoved, undithered walks would be one walk
    seed = folder.manifest["seed"] if args.seed is None else args.seed
    servers = tuple(args.server or ())
    real_command = real_server_command(parser) if args.real else None
    workers = args.real or len(servers) or 1
    setup = EvaluationSetup(
        episode.walk_time,
        start,
        episode.agent_mode,
        servers,
        workers,
        seed,
        real_command=real_command,
        command_noise=command_noise,
        family=episode.family,
        course=course,
        true_pose=episode.true_pose,
    )
    target = "real server" if real else "stand-in"
    tasks = transfer_tasks(gaits, start, jitter, args.repeats, seed)
    print(
        f"transfer: {len(gaits)} gait(s) x {args.repeats} walks on the {target} ({workers} worker(s))", file=sys.stderr
    )
    evaluator = None
    try:
        evaluator = make_evaluator(setup)
        for outcome in evaluator.evaluate([task for _, task in tasks.values()]):
            tasks[outcome.task.key][0].walks.append(outcome.to_record())
    except EvaluationError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("\ninterrupted; nothing was written", file=sys.stderr)
        return 130
    finally:
        if evaluator is not None:
            evaluator.close()
    measured = {
        "target": target,
        "run_server": run_server_kind(folder),
        "start": list(start),
        "jitter": list(jitter),
        "command_noise": command_noise,
        "seed": seed,
        "repeats": args.repeats,
        "real_command": real_command,
        "servers": [str(s) for s in servers],
    }
    family = family_named(setup.family)
    cards, notes = write_report(folder.path, gaits, measured, family, real, episode.walk_time, course)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    written = "".join(f"\nwalk card ({target} side): {p.stem}.card.{{json,md,png}}" for p in cards)
    print((folder.path / "transfer.md").read_text() + f"written to {folder.path}/transfer.{{csv,md,png,json}}{written}")
    return 0
