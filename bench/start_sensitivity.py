"""Is it the gait or its start? A TFS walk with one gene moved at a time, walked alone and walked
begun by the unmoved walk (``gait.tfs_start``: the unmoved gait for 1 s, a 1 s blend, then the moved
one), on the stand-in or on a real rcssserver3d.

Moves are fractions of the gene's box (default -2% .. +2%). One walk per case from the default
start, the stand-in with the calibrated command dither (seed 1000), the real server undithered.
Prints, per gene, each move's distance (m) and, after an ``F``, the seconds it walked before it fell.

    python -m bench.start_sensitivity GAIT.json [--moves -0.02 -0.01 0.01 0.02] [--real]
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from bench.fidelity import real_server_or_none
from gait import TFS, TFS_START, Gait, GaitFileError, load_gait
from optimizer.episode import CALIBRATED_COMMAND_NOISE, EpisodeConfig, EpisodeResult, EpisodeRunner
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs

MOVES = (-0.02, -0.01, -0.005, -0.002, 0.002, 0.005, 0.01, 0.02)


def moved(gait: Gait, gene: int, fraction: float) -> Gait:
    """``gait`` with one gene moved by ``fraction`` of its box, repaired into the family's rules."""
    low, high = TFS.bounds[gene]
    genes = gait.as_array()
    genes[gene] += fraction * (high - low)
    return TFS.gait(TFS.repair(genes, TFS.bounds))


def shown(result: EpisodeResult) -> str:
    return f"{result.distance:.1f}" + (f"F{result.time:.1f}" if result.fell else "")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m bench.start_sensitivity",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("gait", help="a TFS gait file")
    p.add_argument("--moves", type=float, nargs="+", default=list(MOVES), help="fractions of each gene's box")
    p.add_argument("--real", action="store_true", help="on a real rcssserver3d ($RCSSSERVER3D)")
    args = p.parse_args(argv)
    try:
        gait = TFS.from_gait(load_gait(args.gait))
    except (GaitFileError, ValueError) as exc:
        p.error(f"GAIT: {exc}")
    quiet_agent_logs()
    server = None
    config = replace(EpisodeConfig(), command_noise=CALIBRATED_COMMAND_NOISE)
    if args.real:
        command = real_server_or_none()
        if command is None:
            return 1
        server, config = RealServerProcess(command), EpisodeConfig()
    with EpisodeRunner(config, server) as runner:
        side = "real server" if args.real else "stand-in"
        print(f"{side}: {gait.describe()}: {shown(runner.evaluate(gait, seed=1000))}")
        print("moves (fraction of the box): " + " ".join(f"{m:+g}" for m in args.moves))
        for gene, name in enumerate(TFS.gene_names):
            alone = [shown(runner.evaluate(moved(gait, gene, m), seed=1000)) for m in args.moves]
            begun = [
                shown(runner.evaluate(TFS_START.gait(moved(gait, gene, m).genes + gait.genes), seed=1000))
                for m in args.moves
            ]
            print(f"{name:>3} alone:          {' '.join(alone)}")
            print(f"{'':>3} begun by the walk: {' '.join(begun)}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
