"""``python -m optimizer.episode``: walk one gait and print how it scored (paper eq. 9).

    python -m optimizer.episode                          # the shipped gait, on the embedded stub
    python -m optimizer.episode --gait runs/gala-.../best_gait.json --server 127.0.0.1:3100:3200
    python -m optimizer.episode --real 1 --repeat 10     # on a real rcssserver3d started (and stopped) here
    python -m optimizer.episode --json                   # one JSON object: distance, fell, time, fitness, ...
    python -m optimizer.episode --start -7 2 10          # start at x -7, y 2, heading 10 deg
    python -m optimizer.episode --repeat 10 --jitter 0.05 0.05 2 --seed 1
                                                         # 10 walks, each start moved by up to 5 cm and 2 deg
    python -m optimizer.episode --embedded-stub socket   # the embedded stub as a process, over TCP
    python -m optimizer.episode --type 4 --real 1        # robot type 4 (toes) on a real server
    python -m optimizer.episode --gait gait/walks/omni.json --course optimizer/courses/omni_course.json --json
                                                         # walk a course (an omni gait): time, legs, poses reached
    python -m optimizer.episode --gait gait/walks/omni.json --course optimizer/courses/omni_course.json --no-true-pose
                                                         # ... steering by the robot's own pose estimate

The embedded stub runs inside this process (``--embedded-stub inprocess``, the default: no sockets,
no text, the same results as over TCP, faster); ``--embedded-stub socket`` runs it as a
``python -m server_stub`` process the agent talks to over TCP, as to any other server.

The stub is deterministic, so repeated walks from one start are the same walk; ``--jitter`` moves
each start by a seeded random amount, which is how a gait's stability shows on it (a real server
varies by itself). With ``--json`` each walk prints one JSON object on its own line.

Exit status 0 when every episode ran (whatever the gait did), 1 when one could not be run.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import replace

from gait import DEFAULT_GAIT_PATH, Gait, GaitFileError, Steerable, load_gait
from optimizer.cli.arguments import add_episode_arguments, add_server_arguments, one_server
from optimizer.episode import EpisodeConfig, EpisodeResult, Start
from optimizer.episode.course import Course, CourseError
from optimizer.episode.real_server import RealServerError, RealServerProcess
from optimizer.episode.servers import ManagedServer, ServerAddress
from optimizer.run.repeats import describe, summary, walk_from
from optimizer.run.robust import jittered_starts
from optimizer.run.run_settings import episode_config
from optimizer.settings import Settings
from protocol.cli_values import non_negative, number, positive_int
from protocol.nao import ROBOT_TYPES

#: An episode's defaults: a search's.
EPISODE = Settings.new("gala").episode


def gait_file(text: str) -> Gait:
    try:
        return load_gait(text)
    except GaitFileError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def course_file(text: str) -> Course:
    try:
        return Course.load(text)
    except CourseError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m optimizer.episode", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--gait",
        type=gait_file,
        default=None,
        metavar="FILE",
        help=f"gait file to walk, of any family (default: the shipped TFS gait, {DEFAULT_GAIT_PATH.name})",
    )
    add_server_arguments(p, repeatable=False)
    add_episode_arguments(p)
    p.add_argument(
        "--repeat", type=positive_int, default=1, metavar="N", help="walk N times, a fresh agent each time (default 1)"
    )
    p.add_argument(
        "--jitter",
        type=non_negative,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("DX", "DY", "DEG"),
        help="move each walk's start by a random amount within +-DX, +-DY (m) and +-DEG "
        "(heading), drawn from --seed (default 0 0 0)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the embedded stub and of the --jitter draws (default 0)"
    )
    p.add_argument(
        "--embedded-stub",
        choices=("inprocess", "socket"),
        default="inprocess",
        help="the embedded stub in this process with no sockets (inprocess, the default; the same results) "
        "or as a process over TCP (socket); ignored with --server or --real",
    )
    p.add_argument(
        "--type",
        dest="robot_type",
        type=int,
        choices=ROBOT_TYPES,
        default=0,
        help="heterogeneous robot type to walk (default 0, nao.rsg; 4 has toes)",
    )
    p.add_argument(
        "--course",
        type=course_file,
        default=None,
        metavar="FILE",
        help="walk this course (a course/1 file) with a steerable gait and score it by its time, not eq. 9",
    )
    p.add_argument(
        "--command",
        nargs=3,
        type=number,
        default=None,
        metavar=("FWD", "LEFT", "TURN"),
        help="walk this one command (m/s ahead, m/s to the left, deg/s turning left) with a steerable gait, "
        "scored by eq. 9 along the start heading; --json with the traced track shows the achieved velocity",
    )
    p.add_argument(
        "--no-true-pose",
        dest="true_pose",
        action="store_false",
        help="on a course, steer by the robot's own estimate from vision and odometry even where the server "
        "sends mypos",
    )
    p.add_argument("--json", action="store_true", help="print JSON (one object per walk) instead of text")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    gait = args.gait or load_gait(DEFAULT_GAIT_PATH)
    for flag, given in (("--course", args.course), ("--command", args.command)):
        if given is not None and not isinstance(gait.walker(), Steerable):
            parser.error(f"{flag} needs a steerable gait (the omni family), not a {gait.family.name} gait")
    if args.course is not None and args.command is not None:
        parser.error("--course walks to poses by its own commands: leave out --command")
    if args.course is not None and (args.start or args.walk_time):
        parser.error("--course sets the start and the time limit: leave out --start and --walk-time")
    start = list(args.course.start) if args.course is not None else args.start or list(EPISODE.start)
    server = one_server(parser, args, start, "this command")
    base = episode_config(args.walk_time or EPISODE.walk_time, start, args.agent_mode or EPISODE.agent_mode)
    base = replace(
        base,
        embedded_stub=args.embedded_stub,
        robot_type=args.robot_type,
        true_pose=args.true_pose,
        command=None if args.command is None else tuple(args.command),
    )
    if args.course is not None:
        base = base.on_course(args.course)
    points = jittered_starts((*base.start, base.heading), args.jitter, args.repeat, args.seed)
    if isinstance(server, RealServerProcess):
        try:  # started before the first walk, so that a server that cannot start is said once, at once
            server.ensure_running()
        except RealServerError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
    results = _walk(gait, base, server, points, args)
    if len(results) > 1 and not args.json:
        print(summary(results))
    return 0 if all(r.status == "ok" for r in results) else 1


def _walk(
    gait: Gait,
    base: EpisodeConfig,
    server: ServerAddress | ManagedServer | None,
    points: Sequence[Start],
    args: argparse.Namespace,
) -> list[EpisodeResult]:
    """Walk ``gait`` from each start, printing each walk as it ends (text or ``--json``)."""

    def report(point: Start, result: EpisodeResult) -> None:
        x, y, heading = point
        where = f"start {x:.4f} {y:.4f} {heading:.4f}: " if len(points) > 1 else ""
        if args.json:
            print(json.dumps({**result.to_dict(), "start": [x, y, heading]}), flush=True)
        elif result.status == "ok":
            print(where + describe(result), flush=True)
        if result.status != "ok":
            print(f"error: {where}the episode could not be run: {result.reason}", file=sys.stderr)

    return walk_from(gait, base, server, points, args.seed, report)
