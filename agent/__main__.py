"""``python -m agent``: one NAO that walks with a gait file's gait (any family) against rcssserver3d or the stub.

With ``--goto X Y DEG`` (repeated) and an omni gait it walks to those poses in order and stands on
the last, steering by the server's ``mypos``/``myorien`` where sent, else by its own estimate.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from agent.config import AgentConfig
from agent.errors import AgentError
from agent.nao_agent import NaoAgent
from gait import GaitFileError, Steerable, load_gait
from protocol.cli_values import checked, non_negative, number, port, positive_float, whole
from protocol.nao import ROBOT_TYPES


def _unum(text: str) -> int:
    value = whole(text)
    return checked(value, 0 <= value <= 11, f"unum must be 0-11 (0 = next free), got {value}")


def _team(text: str) -> str:
    ok = 0 < len(text) <= 15 and all(c.isalnum() or c in "_-" for c in text)
    return checked(text, ok, f"team name must be 1-15 letters, digits, '_' or '-', got {text!r}")


def _rebeam_cycle(text: str) -> int | None:
    if text == "none":
        return None
    value = whole(text)
    last = AgentConfig.settle_cycles - 1
    return checked(value, 0 <= value <= last, f"must be a settle cycle 0-{last} or 'none', got {value}")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m agent", description=__doc__)
    p.add_argument("--host", default="127.0.0.1", help="server address (default 127.0.0.1)")
    p.add_argument("--port", type=port, default=3100, help="agent port (default 3100)")
    p.add_argument("--team", type=_team, default="GALA", help="team name (default GALA)")
    p.add_argument("--unum", type=_unum, default=1, help="uniform number, 0 = next free (default 1)")
    p.add_argument("--gait", type=Path, help="gait parameter file (default: the shipped gait)")
    p.add_argument(
        "--beam",
        nargs=3,
        type=number,
        metavar=("X", "Y", "DEG"),
        default=(0.0, 0.0, 0.0),
        help="beam pose before kick-off (default 0 0 0)",
    )
    p.add_argument("--sync", action="store_true", help="server runs in sync mode: end every reply with (syn)")
    p.add_argument("--duration", type=positive_float, help="seconds of walking after the gait starts, then exit")
    p.add_argument("--type", dest="robot_type", type=int, choices=ROBOT_TYPES, default=0, help="robot type 0-4")
    p.add_argument("--start-now", action="store_true", help="walk right after settling, without waiting for PlayOn")
    p.add_argument(
        "--rebeam-cycle",
        type=_rebeam_cycle,
        default=AgentConfig.rebeam_cycle,
        metavar="N|none",
        help=f"settle cycle at which the beam is repeated, or none (default {AgentConfig.rebeam_cycle})",
    )
    p.add_argument("--timeout", type=positive_float, default=10.0, help="seconds to wait for the server (default 10)")
    p.add_argument(
        "--command-noise",
        type=non_negative,
        default=0.0,
        metavar="RAD_S",
        help="dither every joint velocity command while walking by a uniform draw in +-RAD_S (default 0: none)",
    )
    p.add_argument("--noise-seed", type=whole, default=0, help="seed of the command dither (default 0)")
    p.add_argument(
        "--goto",
        nargs=3,
        type=number,
        action="append",
        default=[],
        metavar=("X", "Y", "DEG"),
        help="walk to this pose (field frame, m and deg); repeat for poses in order (needs an omni gait)",
    )
    p.add_argument(
        "--command",
        nargs=3,
        type=number,
        default=None,
        metavar=("FWD", "LEFT", "TURN"),
        help="walk this one command (m/s ahead, m/s to the left, deg/s turning left) with an omni gait",
    )
    p.add_argument(
        "--no-true-pose",
        dest="true_pose",
        action="store_false",
        help="steer by the robot's own estimate from vision and odometry even where the server sends mypos",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="log the handshake and gait start")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="agent %(levelname)s: %(message)s",
        stream=sys.stderr,
    )
    try:
        gait = load_gait(args.gait) if args.gait is not None else load_gait()  # a bad file refused before connecting
    except GaitFileError as exc:
        print(f"agent: error: {exc}", file=sys.stderr)
        return 2
    if args.goto and args.command:
        print("agent: error: --goto and --command both say what to walk: give one", file=sys.stderr)
        return 2
    if (args.goto or args.command) and not isinstance(gait.walker(), Steerable):
        print(
            f"agent: error: --goto and --command need a steerable gait (the omni family); "
            f"{args.gait or 'the default gait'} is a {gait.family.name} gait",
            file=sys.stderr,
        )
        return 2
    config = AgentConfig(
        host=args.host,
        port=args.port,
        team=args.team,
        unum=args.unum,
        gait=args.gait,
        beam=tuple(args.beam),
        sync=args.sync,
        duration=args.duration,
        robot_type=args.robot_type,
        start_now=args.start_now,
        rebeam_cycle=args.rebeam_cycle,
        timeout=args.timeout,
        command_noise=args.command_noise,
        noise_seed=args.noise_seed,
        goals=tuple(tuple(goal) for goal in args.goto),
        true_pose=args.true_pose,
        walk_command=None if args.command is None else tuple(args.command),
    )
    try:
        report = NaoAgent(config).run()
    except AgentError as exc:
        print(f"agent: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("agent: interrupted", file=sys.stderr)
        return 130
    logging.getLogger("agent").info(
        "done: %d cycles, %.2f s walked, %s",
        report.cycles,
        report.walk_time,
        f"fell after {report.fell_at:.2f} s" if report.fell else "no fall detected",
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
