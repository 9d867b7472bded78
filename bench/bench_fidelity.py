"""How faithfully the stand-in walks, against a real rcssserver3d.

Walks a stored gait set (``bench/fidelity_gaits/``) ``--stand-in-repeats`` times each on the
embedded stand-in and ``--real-repeats`` times each on a real server started here (found through
``RCSSSERVER3D``, then ``rcssserver3d`` on PATH; sync profile; stopped with ``(killsim)``, then
SIGKILL), with the same agent and episode code from the same start, and prints per gait and over
the set: Spearman rank correlation of the distances, fall agreement, median and worst
|1 - stand-in/real distance| over the gaits walking >= 3 m on the real server without a fall, and
how far the turns are apart. Writes ``fidelity.csv``, ``fidelity.png`` (stand-in against real,
each server's spread as bars) and ``fidelity.json`` (every walk with its torso track) into ``--out``.

A walk is one draw of a chaotic process: ``--command-noise`` dithers the agent's velocity commands
(walk k of a gait gets seed k on both servers), so each server's figures are over draws from its
own spread, compared pair by pair of seeds:

    python -m bench.bench_fidelity --set all --real-repeats 5 --stand-in-repeats 5 --command-noise 0.001 --out /tmp/f
    python -m bench.bench_fidelity --set all --real-repeats 3 --out /tmp/fidelity   # one undithered stand-in walk
    python -m bench.bench_fidelity --set held_aside --gaits line-01,line-10 --real-repeats 1 --out /tmp/f
    python -m bench.bench_fidelity --from-json /tmp/fidelity/fidelity.json --out /tmp/again   # no walking

Exit status 0 whatever the figures (they are a measurement), 1 when no real server is found or a
gait named in ``--gaits`` is not in the set.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from bench.fidelity import (
    GAIT_SET_DIR,
    SET_NAMES,
    FidelityConfig,
    compare,
    gait_set,
    plot,
    print_progress,
    read_run,
    real_server_or_none,
    report,
    summarize,
    write_csv,
    write_tracks,
)
from optimizer.episode.runner import quiet_agent_logs
from protocol.cli_values import non_negative, positive_float, positive_int
from protocol.nao import ROBOT_TYPES


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m bench.bench_fidelity", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--set",
        choices=SET_NAMES + ("all",),
        default="training",
        dest="gait_set",
        help="which stored gait set (default training; held_aside is for the final word only)",
    )
    p.add_argument("--gaits", default=None, metavar="NAME,...", help="only these gaits of the set")
    p.add_argument(
        "--real-repeats",
        type=positive_int,
        default=FidelityConfig.real_repeats,
        metavar="R",
        help=f"walks per gait on the real server (default {FidelityConfig.real_repeats})",
    )
    p.add_argument(
        "--stand-in-repeats",
        type=positive_int,
        default=FidelityConfig.stand_in_repeats,
        metavar="R",
        help="walks per gait on the stand-in (default 1; more need --command-noise)",
    )
    p.add_argument(
        "--command-noise",
        type=non_negative,
        default=FidelityConfig.command_noise,
        metavar="RAD_S",
        help="dither the agent's velocity commands by up to this much on both servers, walk k with seed k (default 0)",
    )
    p.add_argument("--walk-time", type=positive_float, default=FidelityConfig.walk_time, metavar="S")
    p.add_argument(
        "--type",
        dest="robot_type",
        type=int,
        choices=ROBOT_TYPES,
        default=FidelityConfig.robot_type,
        help="heterogeneous robot type walked on both servers (default 0)",
    )
    p.add_argument("--gait-dir", type=Path, default=GAIT_SET_DIR, help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, required=True, metavar="DIR")
    p.add_argument(
        "--from-json",
        type=Path,
        default=None,
        metavar="FILE",
        help="walk nothing: take the figures again from a stored fidelity.json (its walks and tracks)",
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    started = time.monotonic()
    quiet_agent_logs()
    if args.from_json is not None:
        comparisons, stored = read_run(args.from_json)
        config = FidelityConfig(
            real_repeats=stored["real_repeats"],
            stand_in_repeats=stored.get("stand_in_repeats", 1),
            command_noise=stored.get("command_noise", 0.0),
            walk_time=stored["walk_time"],
            start=tuple(stored["start"]),
            robot_type=stored.get("robot_type", 0),
        )
        about = {k: stored[k] for k in ("set", "real_command", "command_line") if k in stored}
    else:
        command = real_server_or_none()
        if command is None:
            return 1
        gaits = gait_set(args.gait_set, args.gait_dir)
        if args.gaits:
            wanted = [name.strip() for name in args.gaits.split(",") if name.strip()]
            unknown = sorted(set(wanted) - {g.name for g in gaits})
            if unknown:
                print(f"error: not in the {args.gait_set} set: {', '.join(unknown)}", file=sys.stderr)
                return 1
            gaits = [g for g in gaits if g.name in wanted]
        try:
            config = FidelityConfig(
                real_repeats=args.real_repeats,
                stand_in_repeats=args.stand_in_repeats,
                command_noise=args.command_noise,
                walk_time=args.walk_time,
                robot_type=args.robot_type,
            )
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
        print(
            f"fidelity: {len(gaits)} gaits of set {args.gait_set}: {config.stand_in_repeats} walk(s) each on the "
            f"stand-in, {config.real_repeats} on the real server ({command}); dither {config.command_noise:g} rad/s",
            file=sys.stderr,
        )
        comparisons = compare(gaits, command, config, print_progress)
        about = {
            "set": args.gait_set,
            "real_command": command,
            "command_line": " ".join(["python -m bench.bench_fidelity", *(sys.argv[1:] if argv is None else argv)]),
        }
    summary = summarize(comparisons, config.targets)
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(comparisons, args.out / "fidelity.csv", config.targets)
    plot(comparisons, args.out / "fidelity.png", summary)
    write_tracks(comparisons, summary, config, args.out / "fidelity.json", about)
    print(report(comparisons, summary, config.targets))
    print(f"({time.monotonic() - started:.0f} s; written to {args.out}/fidelity.{{csv,png,json}})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
