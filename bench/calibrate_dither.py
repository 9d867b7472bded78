"""Calibrate the agent's command dither to the real server's own run-to-run spread.

The stand-in is deterministic: a gait walks the same way every time from the same start. A real
rcssserver3d is not: the same gait walks a few per cent differently run to run, mostly by what the
server walked before. The optimizer scores a gait by several dithered walks on the stand-in
(``EpisodeConfig.command_noise``, a seeded uniform draw in +-noise rad/s on every walking velocity
command), so the dither should make the stand-in's walk-to-walk spread match the real server's.
This benchmark measures which amplitude does:

1. The gait set: the fast real walk (``FAST_REAL``, 13.3 m in 15 s), then the fidelity gaits
   (``training``, then ``held_aside``), a gait given twice kept once (``FAST_REAL`` is
   ``line-10``); ``--gaits N`` keeps the first N. Each is walked once undithered on the stand-in
   and kept when that walk goes >= ``--min-distance`` m (default 2): a gait that falls at once has
   no spread worth matching (its distance is where it fell, centimetres), and a stand-in screen
   leaves the real walks out of the choice.
2. The real server: every kept gait ``--repeats`` times undithered from the default start, on two
   real servers at once, one worker process each. The walks go in passes (each pass walks every
   gait once, in an order shuffled per pass, ``--seed``), dealt to the servers in turn, so every
   walk comes after other gaits' walks: each server has a history, as in
   ``python -m optimizer.transfer RUN --real 2`` (which walks a gait's repeats one after another,
   each to whichever server is free). Before that each fresh server walks the first kept
   gait ``--probe-walks`` times in a row (not counted in the spread): are two fresh servers' first
   walks identical, and does a server's walk change after walking the same gait?
3. The stand-in: every kept gait ``--repeats`` times at each dither amplitude (``--amplitudes``),
   walk k with seed k, in ``--workers`` processes.
4. Per amplitude: the median over the gaits of log10(stand-in std / real std of the distance) (each
   std, over a gait's walks with ddof 1, taken as at least 1 mm, ``STD_FLOOR``, so two constant
   sides compare as equal and one constant side as far apart as the other's spread), the fraction
   of gaits within 2x, the same median for the heading change, the falls on each server and the
   mean |stand-in - real| fall fraction per gait. It recommends the tested amplitude whose median
   log ratio is nearest 0 (ties: more gaits within 2x), and where the median crosses 0 between two
   amplitudes, the crossing interpolated in log amplitude.

The velocity commands go to either server at 4 decimals (``protocol.commands``; the direct
stand-in rounds alike), so a dither below 1e-4 rad/s moves a command only where it carries it over
a rounding boundary, about amplitude / 2e-4 of the commands: a sparse set of 1e-4 rad/s kicks
(1e-8 rad/s: about one in a 15-s walk of 22 joints) rather than a smaller perturbation.

    python -m bench.calibrate_dither --out runs/calib/calib.json
    python -m bench.calibrate_dither --gaits 4 --repeats 4 --amplitudes 0 1e-3 --out /tmp/calib.json
    python -m bench.calibrate_dither --real-from runs/calib/calib.json --amplitudes 1e-8 --out /tmp/more.json
    python -m bench.calibrate_dither --from-json runs/calib/calib.json   # figures again, no walking

Exit status 0 whatever the figures (they are a measurement), 1 when no real server is found.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import random
import statistics
import sys
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from bench.fidelity import (
    FAST_REAL,
    SET_NAMES,
    FidelityGait,
    Walk,
    gait_set,
    real_server_or_none,
    walk_gaits,
)
from optimizer.episode import EpisodeConfig, EpisodeRunner
from optimizer.episode.runner import quiet_agent_logs
from optimizer.run.folder import write_json
from protocol.cli_values import count, non_negative, positive_float, positive_int

AMPLITUDES = (0.0, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3)
#: a std below this (m) counts as this: the distances are read to ~0.1 mm, and a gait that walks
#: the same every time on both servers should compare as a match, not as 0/0
STD_FLOOR = 1e-3
#: the same for the heading change (deg)
TURN_STD_FLOOR = 0.1
WITHIN = math.log10(2.0)


# ----- the gait set -----


def calibration_gaits() -> list[FidelityGait]:
    """The fast real walk, then the training and held-aside fidelity gaits, each distinct gait once
    (the fast walk keeps the name of the set's copy of it)."""
    stored = [g for name in SET_NAMES for g in gait_set(name)]
    fast_twin = next((g for g in stored if _same(g.genes, FAST_REAL)), None)
    fast_name = "fast" if fast_twin is None else f"fast={fast_twin.name}"
    out = [FidelityGait(fast_name, "fast", tuple(FAST_REAL), "FAST_REAL: 13.3 m real walk")]
    for gait in stored:
        if not any(_same(gait.genes, kept.genes) for kept in out):
            out.append(gait)
    return out


def _same(a: Sequence[float], b: Sequence[float]) -> bool:
    return all(abs(x - y) <= 1e-9 * max(1.0, abs(y)) for x, y in zip(a, b))


# ----- walking (worker processes: module-level functions, so "spawn" finds them) -----


def _walk_dict(walk: Walk) -> dict[str, Any]:
    return walk.to_dict(with_track=False)


def stand_in_job(amplitude: float, gaits: list[FidelityGait], repeats: int, walk_time: float) -> list[list[dict]]:
    """``repeats`` walks of each gait on an embedded stand-in at dither ``amplitude``, walk k with seed k."""
    quiet_agent_logs()
    config = EpisodeConfig(walk_time=walk_time, command_noise=amplitude)
    with EpisodeRunner(config, trace=True) as runner:
        walks = walk_gaits(runner, gaits, repeats)
    return [[_walk_dict(w) for w in per_gait] for per_gait in walks]


def real_job(command: str, label: str, tasks: list[tuple[str, str, tuple[float, ...]]], walk_time: float) -> list[dict]:
    """One real server, started here, walks ``tasks`` (kind, gait name, genes) in order, undithered;
    each walk is returned with its place in the server's history and the server's pid (a new pid
    means the runner restarted the server: its history begins again)."""
    from optimizer.episode.real_server import RealServerProcess

    quiet_agent_logs()
    server = RealServerProcess(command)
    out: list[dict] = []
    previous = None
    with EpisodeRunner(EpisodeConfig(walk_time=walk_time), server, trace=True) as runner:
        for order, (kind, name, genes) in enumerate(tasks):
            started = time.monotonic()
            result = runner.evaluate(genes)
            walk = Walk.from_episode(
                result.distance, result.fell, result.time, result.status, runner.last_trace or (), runner.config.heading
            )
            out.append(
                {
                    "kind": kind,
                    "gait": name,
                    "server": label,
                    "order": order,
                    "after": previous,
                    "pid": server.pid,
                    "wall": round(time.monotonic() - started, 3),
                    **_walk_dict(walk),
                }
            )
            previous = name
            what = f"fell at {walk.time:.2f} s" if walk.fell else "stood"
            print(
                f"  real {label} #{order:3d} {kind:<5} {name:<22} {walk.distance:7.3f} m, {what}, "
                f"turned {walk.heading_change:+.1f} deg",
                file=sys.stderr,
                flush=True,
            )
    return out


def _quiet_stdout() -> None:
    """A worker's stdout (pybullet's banners, written by C code) goes nowhere: the report owns
    stdout; progress goes to stderr."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.close(devnull)


def _pool(workers: int) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(
        max_workers=workers, mp_context=multiprocessing.get_context("spawn"), initializer=_quiet_stdout
    )


def walk_stand_in(
    gaits: Sequence[FidelityGait], amplitudes: Sequence[float], repeats: int, walk_time: float, workers: int
) -> dict[float, list[list[dict]]]:
    """Per amplitude, per gait, the stand-in's walks; jobs of a few gaits spread over the workers."""
    chunk = max(1, math.ceil(len(gaits) / (2 * workers)))
    jobs = {}
    started = time.monotonic()
    with _pool(workers) as pool:
        for amplitude in amplitudes:
            for first in range(0, len(gaits), chunk):
                part = list(gaits[first : first + chunk])
                jobs[(amplitude, first)] = pool.submit(stand_in_job, amplitude, part, repeats, walk_time)
        out: dict[float, list[list[dict]]] = {a: [] for a in amplitudes}
        for (amplitude, _first), job in jobs.items():
            out[amplitude].extend(job.result())
            done = len(out[amplitude])
            if done == len(gaits):
                print(
                    f"  stand-in: dither {amplitude:g} rad/s done ({len(gaits)} gaits x {repeats}; "
                    f"{time.monotonic() - started:.0f} s)",
                    file=sys.stderr,
                    flush=True,
                )
    return out


def real_schedule(
    gaits: Sequence[FidelityGait], repeats: int, probe_walks: int, servers: int, seed: int
) -> list[list[tuple[str, str, tuple[float, ...]]]]:
    """Each server's list of walks: ``probe_walks`` of the first gait on the fresh server, then the
    passes (every gait once per pass, shuffled per pass) dealt to the servers in turn."""
    rng = random.Random(seed)
    lists: list[list[tuple[str, str, tuple[float, ...]]]] = [
        [("probe", gaits[0].name, gaits[0].genes)] * probe_walks for _ in range(servers)
    ]
    dealt = 0
    for _ in range(repeats):
        order = list(gaits)
        rng.shuffle(order)
        for gait in order:
            lists[dealt % servers].append(("main", gait.name, gait.genes))
            dealt += 1
    return lists


def walk_real(
    command: str, gaits: Sequence[FidelityGait], repeats: int, probe_walks: int, walk_time: float, seed: int
) -> list[dict]:
    schedule = real_schedule(gaits, repeats, probe_walks, 2, seed)
    with _pool(2) as pool:
        jobs = [pool.submit(real_job, command, label, tasks, walk_time) for label, tasks in zip("AB", schedule)]
        return [walk for job in jobs for walk in job.result()]


# ----- figures (pure) -----


def std(values: Sequence[float]) -> float:
    return statistics.stdev(values) if len(values) >= 2 else 0.0


def log_ratio(stand_in: float, real: float, floor: float) -> float:
    """log10 of stand-in over real, each taken as at least ``floor``."""
    return math.log10(max(stand_in, floor) / max(real, floor))


def side_figures(walks: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    ran = [w for w in walks if w["status"] == "ok"]
    distances = [w["distance"] for w in ran]
    turns = [w["heading_change"] for w in ran]
    return {
        "walks": len(ran),
        "falls": sum(bool(w["fell"]) for w in ran),
        "mean_m": statistics.fmean(distances) if ran else math.nan,
        "std_m": std(distances),
        "min_m": min(distances, default=math.nan),
        "max_m": max(distances, default=math.nan),
        "turn_mean_deg": statistics.fmean(turns) if ran else math.nan,
        "turn_std_deg": std(turns),
        "drift_std_m": std([w["drift"] for w in ran]),
        #: how many different walks: distances apart by more than 1 mm count as different
        "distinct": len({round(d, 3) for d in distances}),
    }


def gait_rows(
    names: Sequence[str], stand_in: Sequence[Sequence[Mapping[str, Any]]], real: Mapping[str, Sequence[Mapping]]
) -> list[dict[str, Any]]:
    rows = []
    for name, walks in zip(names, stand_in):
        s, r = side_figures(walks), side_figures(real[name])
        rows.append(
            {
                "gait": name,
                "stand": s,
                "real": r,
                "log_ratio": log_ratio(s["std_m"], r["std_m"], STD_FLOOR),
                "turn_log_ratio": log_ratio(s["turn_std_deg"], r["turn_std_deg"], TURN_STD_FLOOR),
                "fall_fraction_diff": (s["falls"] / s["walks"] if s["walks"] else math.nan)
                - (r["falls"] / r["walks"] if r["walks"] else math.nan),
            }
        )
    return rows


def median_interval(values: Sequence[float], level: float = 0.9, draws: int = 2000, seed: int = 0) -> list[float]:
    """A bootstrap interval of the median over resampled gaits (the walks of a gait held fixed):
    how much the median would move with another set of gaits like these."""
    rng = random.Random(seed)
    medians = sorted(statistics.median(rng.choices(values, k=len(values))) for _ in range(draws))
    tail = (1.0 - level) / 2.0
    return [medians[int(tail * (draws - 1))], medians[int((1.0 - tail) * (draws - 1))]]


def amplitude_summary(amplitude: float, rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    ratios = [row["log_ratio"] for row in rows]
    return {
        "amplitude": amplitude,
        "gaits": len(rows),
        "median_log_ratio": statistics.median(ratios),
        "median_log_ratio_90": median_interval(ratios),
        "within_2x": sum(abs(x) <= WITHIN + 1e-12 for x in ratios) / len(rows),
        "median_turn_log_ratio": statistics.median(row["turn_log_ratio"] for row in rows),
        "median_stand_std_m": statistics.median(row["stand"]["std_m"] for row in rows),
        "median_real_std_m": statistics.median(row["real"]["std_m"] for row in rows),
        "stand_falls": sum(row["stand"]["falls"] for row in rows),
        "real_falls": sum(row["real"]["falls"] for row in rows),
        "walks": sum(row["stand"]["walks"] for row in rows),
        "real_walks": sum(row["real"]["walks"] for row in rows),
        "mean_abs_fall_fraction_diff": statistics.fmean(abs(row["fall_fraction_diff"]) for row in rows),
    }


def recommend(summaries: Sequence[Mapping[str, Any]]) -> tuple[float, float | None]:
    """The tested amplitude whose median log ratio is nearest 0 (ties: more gaits within 2x), and
    the zero crossing of the median interpolated in log10 amplitude between two dithered
    amplitudes that bracket it (None when none do)."""
    best = min(summaries, key=lambda s: (round(abs(s["median_log_ratio"]), 6), -s["within_2x"]))
    crossing = None
    dithered = sorted((s for s in summaries if s["amplitude"] > 0), key=lambda s: s["amplitude"])
    for low, high in zip(dithered, dithered[1:]):
        a, b = low["median_log_ratio"], high["median_log_ratio"]
        if a <= 0 <= b and b > a:
            la, lb = math.log10(low["amplitude"]), math.log10(high["amplitude"])
            crossing = 10 ** (la + (lb - la) * (0 - a) / (b - a))
            break
    return best["amplitude"], crossing


def probe_figures(real_walks: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The fresh servers' first walks (the same gait on each): distances per server, in order."""
    probes: dict[str, list[float]] = {}
    for walk in real_walks:
        if walk["kind"] == "probe" and walk["status"] == "ok":
            probes.setdefault(walk["server"], []).append(walk["distance"])
    return probes


# ----- output -----


def _f(value: float, digits: int = 3) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def report(document: Mapping[str, Any]) -> str:
    summaries, names = document["summaries"], document["kept"]
    lines = [
        f"gaits: {len(document['gaits'])} in the set, {len(names)} kept (undithered stand-in walk >= "
        f"{document['min_distance']:g} m); {document['repeats']} walks of each on the real servers and at each "
        "stand-in amplitude",
        "",
        "fresh servers' first walks of " + (names[0] if names else "-") + " (m, in order):",
    ]
    for server, distances in sorted(document["probe"].items()):
        lines.append(f"  server {server}: " + ", ".join(f"{d:.4f}" for d in distances))
    lines += [
        "",
        "per amplitude: median over gaits of log10(stand-in std / real std of distance), gaits within 2x, "
        "the same median for the heading change, median std (m), falls, mean |fall fraction difference|",
        f"{'dither rad/s':>12} {'med log':>8} {'90% (gaits)':>13} {'in 2x':>6} {'turn log':>8} {'std s/r m':>13} "
        f"{'falls s/r':>10} {'|dfall|':>7}",
    ]
    for s in summaries:
        lines.append(
            f"{s['amplitude']:>12g} {s['median_log_ratio']:>+8.2f} "
            f"{s['median_log_ratio_90'][0]:>+6.2f}..{s['median_log_ratio_90'][1]:<+5.2f} {s['within_2x']:>6.2f} "
            f"{s['median_turn_log_ratio']:>+8.2f} {s['median_stand_std_m']:>6.3f}/{s['median_real_std_m']:<6.3f} "
            f"{s['stand_falls']:>4}/{s['real_falls']:<5} {s['mean_abs_fall_fraction_diff']:>7.3f}"
        )
    best = document["recommended"]
    lines += ["", f"per gait at the recommended dither {best:g} rad/s:"]
    lines.append(
        f"{'gait':<22} {'stand m':>7} {'std':>6} {'falls':>5} {'real m':>7} {'std':>6} {'falls':>5} "
        f"{'log':>6} {'turn std s/r':>13} {'distinct s/r':>12}"
    )
    for row in document["per_gait"][repr(best)]:
        s, r = row["stand"], row["real"]
        lines.append(
            f"{row['gait']:<22} {_f(s['mean_m'], 2):>7} {_f(s['std_m']):>6} {s['falls']:>2}/{s['walks']:<2} "
            f"{_f(r['mean_m'], 2):>7} {_f(r['std_m']):>6} {r['falls']:>2}/{r['walks']:<2} "
            f"{row['log_ratio']:>+6.2f} {_f(s['turn_std_deg'], 1):>6}/{_f(r['turn_std_deg'], 1):<6} "
            f"{s['distinct']:>6}/{r['distinct']:<5}"
        )
    crossing = document["crossing"]
    alike = _inside(summaries, next(s for s in summaries if s["amplitude"] == best))
    lines += [
        "",
        f"recommended dither: {best:g} rad/s (median log10 ratio nearest 0 among those tested)"
        + ("" if crossing is None else f"; the median crosses 0 at ~{crossing:.2g} rad/s (log interpolation)"),
        "amplitudes whose 90% interval holds the recommended one's median (these gaits do not tell them apart): "
        + ", ".join(f"{a:g}" for a in alike),
    ]
    return "\n".join(lines)


def _inside(summaries: Sequence[Mapping[str, Any]], chosen: Mapping[str, Any]) -> list[float]:
    """The amplitudes whose median's 90% interval holds ``chosen``'s median."""
    m = chosen["median_log_ratio"]
    return [s["amplitude"] for s in summaries if s["median_log_ratio_90"][0] <= m <= s["median_log_ratio_90"][1]]


def figures(document: dict[str, Any]) -> dict[str, Any]:
    """Take the figures from the walks of ``document`` (in place; returned)."""
    names = document["kept"]
    real: dict[str, list[dict]] = {name: [] for name in names}
    for walk in document["real_walks"]:
        if walk["kind"] == "main":
            real[walk["gait"]].append(walk)
    per_gait, summaries = {}, []
    for key, walks in document["stand_in_walks"].items():
        rows = gait_rows(names, walks, real)
        per_gait[key] = rows
        summaries.append(amplitude_summary(float(key), rows))
    summaries.sort(key=lambda s: s["amplitude"])
    best, crossing = recommend(summaries)
    document.update(
        summaries=summaries,
        per_gait=per_gait,
        recommended=best,
        crossing=crossing,
        probe=probe_figures(document["real_walks"]),
    )
    return document


# ----- command -----


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m bench.calibrate_dither",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--gaits", type=positive_int, default=None, metavar="N", help="only the first N gaits of the set")
    p.add_argument("--repeats", type=positive_int, default=10, metavar="R", help="walks per gait and side (default 10)")
    p.add_argument(
        "--amplitudes",
        type=non_negative,
        nargs="+",
        default=list(AMPLITUDES),
        metavar="RAD_S",
        help="stand-in dither amplitudes (default " + " ".join(f"{a:g}" for a in AMPLITUDES) + ")",
    )
    p.add_argument(
        "--min-distance",
        type=float,
        default=2.0,
        metavar="M",
        help="keep a gait when its undithered stand-in walk goes at least this far (default 2)",
    )
    p.add_argument(
        "--probe-walks",
        type=count,
        default=3,
        metavar="N",
        help="walks of the first gait on each fresh server (default 3)",
    )
    p.add_argument("--workers", type=positive_int, default=2, help="stand-in worker processes (default 2)")
    p.add_argument("--walk-time", type=positive_float, default=15.0, metavar="S")
    p.add_argument("--seed", type=int, default=0, help="seed of the real passes' gait orders (default 0)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE", help="write everything as JSON here")
    p.add_argument(
        "--real-from",
        type=Path,
        default=None,
        metavar="FILE",
        help="take the gaits, their screen and real walks from a stored run and walk only the stand-in, at "
        "--amplitudes; the stored stand-in walks at other amplitudes are kept",
    )
    p.add_argument(
        "--from-json", type=Path, default=None, metavar="FILE", help="walk nothing: figures from a stored run"
    )
    return p


def walk(args: argparse.Namespace, command_line: str) -> dict[str, Any] | None:
    """Screen, walk the real servers (or take their walks from ``--real-from``), walk the
    stand-in; the document with its figures, None when no real server is found."""
    amplitudes = sorted(set(args.amplitudes))
    seconds: dict[str, float] = {}
    if args.real_from is not None:
        stored = json.loads(args.real_from.read_text())
        gaits = [FidelityGait.from_dict(item) for item in stored["gaits"]]
        screen = [[item["screen_walk"]] for item in stored["gaits"]]
        kept = [g for g in gaits if g.name in stored["kept"]]
        real_walks, command = stored["real_walks"], stored["real_command"]
        earlier = {k: v for k, v in stored["stand_in_walks"].items() if float(k) not in amplitudes}
        settings = {k: stored[k] for k in ("repeats", "walk_time", "min_distance", "seed")}
        if (args.repeats, args.walk_time) != (settings["repeats"], settings["walk_time"]):
            print(f"note: the stored run walked {settings['repeats']} x {settings['walk_time']:g} s", file=sys.stderr)
        seconds["real"] = 0.0
        print(f"calibrate: {len(kept)} gaits and their real walks from {args.real_from}", file=sys.stderr)
    else:
        command = real_server_or_none()
        if command is None:
            return None
        gaits = calibration_gaits()[: args.gaits]
        print(f"calibrate: screening {len(gaits)} gaits on the stand-in (one undithered walk)", file=sys.stderr)
        screen = walk_stand_in(gaits, [0.0], 1, args.walk_time, args.workers)[0.0]
        kept = [g for g, walks in zip(gaits, screen) if walks[0]["distance"] >= args.min_distance]
        print(
            f"calibrate: {len(kept)} kept; real server ({command}): {args.repeats} walks each on 2 servers",
            file=sys.stderr,
        )
        phase = time.monotonic()
        real_walks = walk_real(command, kept, args.repeats, args.probe_walks, args.walk_time, args.seed)
        seconds["real"] = time.monotonic() - phase
        earlier = {}
        settings = {"repeats": args.repeats, "walk_time": args.walk_time, "min_distance": args.min_distance}
        settings["seed"] = args.seed
    print(f"calibrate: stand-in at {len(amplitudes)} amplitudes", file=sys.stderr)
    phase = time.monotonic()
    stand_in = walk_stand_in(kept, amplitudes, args.repeats, args.walk_time, args.workers)
    seconds["stand_in"] = time.monotonic() - phase
    document = {
        "format": "dither-calibration/1",
        "command_line": command_line,
        "real_command": command,
        "real_from": None if args.real_from is None else str(args.real_from),
        **settings,
        "std_floor_m": STD_FLOOR,
        "turn_std_floor_deg": TURN_STD_FLOOR,
        "gaits": [{**g.to_dict(), "screen_walk": walks[0]} for g, walks in zip(gaits, screen)],
        "kept": [g.name for g in kept],
        "real_walks": real_walks,
        "stand_in_walks": {**earlier, **{repr(a): stand_in[a] for a in amplitudes}},
        "seconds": seconds,
    }
    return figures(document)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    started = time.monotonic()
    quiet_agent_logs()
    if args.from_json is not None:
        document = figures(json.loads(args.from_json.read_text()))
    else:
        document = walk(args, " ".join(["python -m bench.calibrate_dither", *(sys.argv[1:] if argv is None else argv)]))
        if document is None:
            return 1
        document["seconds"]["total"] = time.monotonic() - started
    if not document["kept"]:
        print("no gait kept: nothing to compare", file=sys.stderr)
        return 0
    print(report(document))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        write_json(args.out, document)
    print(f"({time.monotonic() - started:.0f} s" + ("" if args.out is None else f"; written to {args.out}") + ")")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
