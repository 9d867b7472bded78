"""``python -m optimizer.calibrate GAIT --out FILE``: calibrate a steerable walk's commands.

A robot walks less than its steps plan (some 70-85% of it: its feet slip, its joints trail their
targets), and stepping sideways turns it. This walks the gait's commands (half and nine tenths
of its top speed, forward, backward, each side, each way round; ``--runs`` dithered walks of
``--seconds`` from standing each), measures what it walked over each walk's second half, and
moves the walk's calibration (``gait.omni``: a gain per axis, the turn per sideways speed) so
that it would have walked what it was commanded; ``--rounds`` times, as a gain measured at one
step length is not quite right at the next; then walks the calibrated gait's commands once more,
as its check. The steps at the top speeds do not change (the genes
``max_*`` cap the planned speeds), nor does any other gene:

    python -m optimizer.calibrate runs/refine-.../fastest_gait.json --out gait/walks/omni.json
    python -m optimizer.calibrate my_omni.json --out calibrated.json --real 1     # on a real server

Prints each round's commands and walked speeds and the worst miss; writes the calibrated gait file (its notes say
how it was calibrated, after the notes it had) and, with ``--json FILE``, every round's walks.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from gait import Gait, Steerable, load_gait, save_gait
from gait.gait_file import GaitFileError
from gait.omni import CALIBRATION_GENES
from optimizer.cli.arguments import add_server_arguments, one_server
from optimizer.episode.command_map import (
    MAP_START,
    CommandWalks,
    calibrated,
    calibration_commands,
    command_error,
    walk_commands,
)
from optimizer.episode.real_server import RealServerError
from optimizer.episode.runner import EpisodeRunner
from protocol.cli_values import positive_float, positive_int


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m optimizer.calibrate", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("gait", metavar="GAIT", help="gait file of a steerable family (omni) to calibrate")
    p.add_argument("--out", required=True, metavar="FILE", help="where to write the calibrated gait file")
    p.add_argument("--runs", type=positive_int, default=5, metavar="N", help="walks per command (default 5)")
    p.add_argument("--seconds", type=positive_float, default=5.0, metavar="S", help="seconds of each walk (default 5)")
    p.add_argument("--rounds", type=positive_int, default=2, metavar="N", help="calibration rounds (default 2)")
    p.add_argument("--json", metavar="FILE", help="also write every round's walks here as JSON")
    add_server_arguments(p, repeatable=False)
    return p


def _steerable_gait(parser: argparse.ArgumentParser, path: str) -> Gait:
    try:
        gait = load_gait(path)
    except GaitFileError as exc:
        parser.error(str(exc))
    if not isinstance(gait.walker(), Steerable):
        parser.error(f"{path}: a {gait.family.name} gait takes no command; calibrate a steerable one (omni)")
    return gait


def _report(round_: int | str, walks: Sequence[CommandWalks]) -> None:
    print(f"round {round_}: command -> walked over the second half (fwd m/s, left m/s, deg/s), falls")
    for walk in walks:
        got = "all fell" if walk.second_half is None else "  ".join(f"{v:7.3f}" for v in walk.second_half)
        wanted = "  ".join(f"{v:7.3f}" for v in walk.command)
        print(f"  {wanted}  ->  {got}   {walk.falls}/{walk.runs} fell", flush=True)
    print(f"  worst miss: {100 * command_error(walks):.1f}% of a command", flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    gait = _steerable_gait(parser, args.gait)
    if not Path(args.out).resolve().parent.is_dir():
        parser.error(f"--out {args.out}: its folder does not exist")
    server = one_server(parser, args, MAP_START, "calibration")
    rounds = []
    try:
        with EpisodeRunner(trace=True, server=server) as runner:
            for k in range(1, args.rounds + 2):
                walks = walk_commands(runner, gait, calibration_commands(gait), args.runs, args.seconds)
                _report(k if k <= args.rounds else "check", walks)
                rounds.append({"round": k, "gait": gait.params, "walks": [w.to_dict() for w in walks]})
                if k <= args.rounds:
                    gait = calibrated(gait, walks)
    except RealServerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    calibration = ", ".join(f"{name} {gait.params[name]:.4g}" for name in CALIBRATION_GENES)
    notes = str(json.loads(Path(args.gait).read_text()).get("notes", ""))
    command = f"python -m optimizer.calibrate {args.gait} --runs {args.runs} --rounds {args.rounds}"
    how = f"calibrated ({calibration}): {command}"
    save_gait(gait, args.out, f"{notes}; {how}" if notes else how)
    print(f"calibrated: {calibration}; written to {args.out}")
    if args.json:
        Path(args.json).write_text(json.dumps(rounds, indent=1) + "\n")
    return 0
