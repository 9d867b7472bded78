"""``python -m optimizer.episode``: walk one gait once and print how it scored (paper eq. 9).

    python -m optimizer.episode                          # the shipped gait, on the embedded stub
    python -m optimizer.episode --gait runs/gala-.../best_gait.json --server 127.0.0.1:3100:3200
    python -m optimizer.episode --json                   # one JSON object: distance, fell, time, fitness, ...
    python -m optimizer.episode --start -5 2 10          # start at x -5, y 2, heading 10 deg

Exit status 0 when the episode ran (whatever the gait did), 1 when it could not be run.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from gait import DEFAULT_GAIT_PATH, GaitFileError, TFSParams, load_gait
from optimizer.command_line import EPISODE_DEFAULTS, add_episode_arguments, episode_config, server_address
from optimizer.episode import EpisodeRunner


def gait_file(text: str) -> TFSParams:
    try:
        return load_gait(text)
    except GaitFileError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m optimizer.episode", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--gait", type=gait_file, default=None, metavar="FILE",
                   help=f"gait file to walk (default: the shipped gait, {DEFAULT_GAIT_PATH.name})")
    p.add_argument("--server", type=server_address, default=None, metavar="HOST:AGENT_PORT:MONITOR_PORT",
                   help="a running rcssserver3d (default: start the embedded stub)")
    add_episode_arguments(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the embedded stub (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    params = args.gait or load_gait(DEFAULT_GAIT_PATH)
    config = episode_config(args.walk_time or EPISODE_DEFAULTS["walk_time"], args.start or EPISODE_DEFAULTS["start"],
                            args.agent_mode or EPISODE_DEFAULTS["agent_mode"])
    with EpisodeRunner(config, args.server, seed=args.seed) as runner:
        result = runner.evaluate(params)
    if args.json:
        print(json.dumps(result.to_dict()))
    elif result.status == "ok":
        print(f"distance {result.distance:.3f} m in {result.time:.2f} s walked "
              f"({'fell' if result.fell else 'did not fall'}); fitness {result.fitness:.4f}; "
              f"mean speed {result.mean_speed:.3f} m/s")
    if result.status != "ok":
        print(f"error: the episode could not be run: {result.reason}", file=sys.stderr)
        return 1
    return 0
