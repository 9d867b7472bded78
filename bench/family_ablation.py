"""What each tfs-plus addition buys: a found tfs-plus walk, and the same walk with one addition
taken out at a time, on the stand-in and on a real rcssserver3d.

Cases: the walk as found; without the ankle pitch (``c_a = P = 0``); without the sway (``S = 0``);
without the arm swing (``R = 0``); without all three (the TFS walk underneath). Each case walks
``--repeats`` times on each server from starts moved within the beam noise (+-5 cm, +-10 deg; the
same starts on both), the stand-in with the calibrated command dither (walk k with seed k), the
real server undithered (its own spread). Prints, per case and server: falls, mean distance and
speed, the shortest walk, median |sideways drift| and |heading change|.

    python -m bench.family_ablation GAIT.json [--repeats 10] [--no-real]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from bench.fidelity import real_server_or_none
from gait import TFS_PLUS, Gait, GaitFileError, load_gait
from optimizer.episode import CALIBRATED_COMMAND_NOISE, DEFAULT_START, EpisodeConfig, EpisodeRunner
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs
from optimizer.run.robust import jittered_starts
from protocol.cli_values import positive_int

#: The additions' genes, by what they do.
ADDITIONS: dict[str, tuple[str, ...]] = {"ankle": ("c_a", "P"), "sway": ("S",), "arms": ("R",)}
BEAM_NOISE = (0.05, 0.05, 10.0)


def cases(gait: Gait) -> dict[str, Gait]:
    """The walk, without each addition, and without all of them."""
    names = gait.family.gene_names

    def without(genes: tuple[str, ...]) -> Gait:
        return gait.family.gait([0.0 if n in genes else g for n, g in zip(names, gait.genes)])

    out = {"as found": gait}
    out.update({f"without {what}": without(genes) for what, genes in ADDITIONS.items()})
    out["TFS underneath"] = without(tuple(g for genes in ADDITIONS.values() for g in genes))
    return out


def walk(runner: EpisodeRunner, gait: Gait, starts: list, dither: bool) -> list:
    return [runner.evaluate(gait, seed=k if dither else None, start=s, trace=True) for k, s in enumerate(starts)]


def line(case: str, server: str, walks: list, walk_time: float) -> str:
    ran = [w for w in walks if w.status == "ok"]
    if not ran:
        return f"| {case} | {server} | none ran | | | | |"
    distances = [w.distance for w in ran]
    mean = statistics.fmean(distances)
    drift = statistics.median(abs(w.drift) for w in ran if w.drift is not None)
    turn = statistics.median(abs(w.heading_change) for w in ran if w.heading_change is not None)
    return (
        f"| {case} | {server} | {sum(w.fell for w in ran)}/{len(ran)} | {mean:.2f} ({mean / walk_time:.3f} m/s) "
        f"| {min(distances):.2f} | {drift:.2f} | {turn:.1f} |"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m bench.family_ablation",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("gait", type=Path, help="a tfs-plus gait file")
    p.add_argument("--repeats", type=positive_int, default=10)
    p.add_argument("--no-real", action="store_true", help="the stand-in only")
    args = p.parse_args(argv)
    try:
        gait = load_gait(args.gait)
    except GaitFileError as exc:
        p.error(str(exc))
    if gait.family is not TFS_PLUS:
        p.error(f"{args.gait}: a {gait.family.name} gait; this compares tfs-plus additions")
    real = None if args.no_real else real_server_or_none()
    if not args.no_real and real is None:
        return 1
    quiet_agent_logs()
    starts = jittered_starts(DEFAULT_START, BEAM_NOISE, args.repeats, seed=1)
    walk_time = EpisodeConfig().walk_time
    print("| case | server | falls | distance, mean (speed) | shortest | drift, median (m) | turn, median (deg) |")
    print("|---|---|---:|---:|---:|---:|---:|")
    stand_in = EpisodeConfig(command_noise=CALIBRATED_COMMAND_NOISE, family=gait.family.name)
    rows: dict[str, list[str]] = {}
    with EpisodeRunner(stand_in) as runner:
        for case, variant in cases(gait).items():
            rows[case] = [line(case, "stand-in", walk(runner, variant, starts, dither=True), walk_time)]
    if real is not None:
        with EpisodeRunner(EpisodeConfig(family=gait.family.name), RealServerProcess(real)) as runner:
            for case, variant in cases(gait).items():
                rows[case].append(line(case, "real", walk(runner, variant, starts, dither=False), walk_time))
    for lines in rows.values():
        print("\n".join(lines), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
