"""``python -m optimizer.transfer RUN_DIR --real N``: will the gaits a run reported walk on a real server?

Walks every gait the run reported (each Table I row's best, ``best_gait.json``, ``fastest_gait.json``;
a GA run's best) ``--repeats`` times on real rcssserver3d servers (``--real N`` started here, or
``--server`` run elsewhere; with neither, on the embedded stand-in, which re-checks a run made
elsewhere) from starts moved within the run's check jitter, and sets what the run measured
beside what was measured now:

    python -m optimizer.transfer runs/gala-20261201-101500 --real 2
    python -m optimizer.transfer runs/gala-20261201-101500 --server 127.0.0.1:3100:3200 --repeats 20

Writes into the run folder: ``transfer.csv`` (one row per gait: the run's figures, the new walks'
falls, shortest, mean and longest distance), ``transfer.md`` (the same as a table),
``transfer.png`` (the run's distance against the new one, each with its spread) and
``transfer.json`` (every walk). The run itself is not changed.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from gait import GENE_NAMES
from optimizer.cli.common import (
    LEGACY_START,
    EvaluationSetup,
    EvaluatorMaker,
    add_server_arguments,
    check_start_for_real_server,
    existing_run,
    pool_evaluator,
    real_server_command,
    stability_config,
)
from optimizer.episode import DEFAULT_START, Start, start_problem_on_real_server
from optimizer.evaluation.pool import EpisodeTask, EvaluationError, stable_seed
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.folder import RunFolder, write_json
from optimizer.run.stability import distance_spread, jittered_starts
from optimizer.search.config import StabilityConfig
from protocol.cli_values import non_negative, number, positive_int


@dataclass
class ReportedGait:
    """A gait a run reported, under every name it was reported as, and what the run measured of
    it: its check's walks where it was checked, else the one walk that found it."""

    genes: tuple[float, ...]
    names: list[str]
    run_distances: list[float]
    run_falls: int
    walks: list[EpisodeRecord] = field(default_factory=list)

    @property
    def name(self) -> str:
        return " = ".join(self.names)

    def new_distances(self) -> list[float]:
        return [w.distance for w in self.walks if w.ran]

    def new_falls(self) -> int:
        return sum(1 for w in self.walks if w.ran and w.fell)


def _measured(check: Mapping[str, Any] | None, walk: Mapping[str, Any] | None) -> tuple[list[float], int]:
    if check is not None and check.get("walks"):
        ran = [w for w in check["walks"] if w["status"] == "ok"]
        return [float(w["distance"]) for w in ran], sum(1 for w in ran if w["fell"])
    if walk is not None:
        return [float(walk["distance"])], int(bool(walk["fell"]))
    return [], 0


def reported_gaits(results: Mapping[str, Any]) -> list[ReportedGait]:
    """The gaits of a GALA, GA or comparison run's ``results.json``, one entry per distinct gait,
    in the order the run reports them (Table I rows, then the fastest walk)."""
    found: list[tuple[str, Sequence[float], Mapping[str, Any] | None, Mapping[str, Any] | None]] = []
    if "rows" in results:  # GALA
        for row in results["rows"]:
            found.append(
                (f"Table I pc {row['crossover']:g}", row["best_genes"], row.get("check"), row.get("best_episode"))
            )
        fastest = results.get("fastest_episode")
        if fastest is not None:
            found.append(("fastest", fastest["genes"], results.get("fastest_check"), fastest))
    elif "reported" in results:  # a comparison: each method's best on each seed
        for gait in results["reported"]:
            found.append((gait["name"], gait["genes"], gait.get("check"), gait.get("walk")))
    elif "best_genes" in results:  # GA
        found.append(("GA best", results["best_genes"], results.get("check"), results.get("best_episode")))
    gaits: dict[tuple[float, ...], ReportedGait] = {}
    for name, genes, check, walk in found:
        key = tuple(float(g) for g in genes)
        if key in gaits:
            gaits[key].names.append(name)
            continue
        distances, falls = _measured(check, walk)
        gaits[key] = ReportedGait(key, [name], distances, falls)
    return list(gaits.values())


def run_server_kind(folder: RunFolder) -> str:
    """Where the run walked its episodes, as its manifest recorded it."""
    runtime = folder.manifest.get("runtime", {})
    return "real server" if runtime.get("real") or runtime.get("servers") else "stand-in"


COLUMNS = (
    "gait",
    "run_walks",
    "run_falls",
    "run_min_m",
    "run_mean_m",
    "run_max_m",
    "walks",
    "falls",
    "min_m",
    "mean_m",
    "max_m",
    "mean_ratio",
) + tuple(f"gene_{n}" for n in GENE_NAMES)


def _row(gait: ReportedGait) -> dict[str, Any]:
    run = distance_spread(gait.run_distances) or (None, None, None)
    new = distance_spread(gait.new_distances()) or (None, None, None)
    ratio = None if new[2] is None or not run[2] else new[2] / run[2]
    return {
        "gait": gait.name,
        "run_walks": len(gait.run_distances),
        "run_falls": gait.run_falls,
        "run_min_m": run[0],
        "run_mean_m": run[2],
        "run_max_m": run[1],
        "walks": len(gait.new_distances()),
        "falls": gait.new_falls(),
        "min_m": new[0],
        "mean_m": new[2],
        "max_m": new[1],
        "mean_ratio": ratio,
        **{f"gene_{n}": g for n, g in zip(GENE_NAMES, gait.genes)},
    }


def write_csv(gaits: Sequence[ReportedGait], path: Path) -> None:
    with path.open("w", newline="") as out:
        writer = csv.DictWriter(out, COLUMNS)
        writer.writeheader()
        for gait in gaits:
            writer.writerow({k: ("" if v is None else v) for k, v in _row(gait).items()})


def write_markdown(gaits: Sequence[ReportedGait], path: Path, run_kind: str, target: str) -> None:
    def metres(value: float | None) -> str:
        return "-" if value is None else f"{value:.2f}"

    lines = [
        f"| gait | run ({run_kind}): falls | run: distance (m) | transfer ({target}): falls "
        "| transfer: distance (m) | mean ratio |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for gait in gaits:
        row = _row(gait)
        lines.append(
            f"| {gait.name} | {row['run_falls']}/{row['run_walks']} | {metres(row['run_mean_m'])} "
            f"({metres(row['run_min_m'])}-{metres(row['run_max_m'])}) | {row['falls']}/{row['walks']} | "
            f"{metres(row['mean_m'])} ({metres(row['min_m'])}-{metres(row['max_m'])}) | "
            f"{'-' if row['mean_ratio'] is None else format(row['mean_ratio'], '.2f')} |"
        )
    path.write_text("\n".join(lines) + "\n\nDistances: mean (shortest-longest) over the walks; a fall ends a walk.\n")


def plot(gaits: Sequence[ReportedGait], path: Path, run_kind: str, target: str) -> None:
    """The run's distance against the new one, each gait's spread as error bars; a gait that fell
    in any new walk is drawn in red."""
    fig = Figure(figsize=(6.4, 5.6), layout="constrained")
    ax = fig.add_subplot()
    top = 1.0
    for gait in gaits:
        row = _row(gait)
        if row["run_mean_m"] is None or row["mean_m"] is None:
            continue
        x, y = row["run_mean_m"], row["mean_m"]
        # max(0, ...): a mean of equal distances can land a rounding error outside them
        ax.errorbar(
            [x],
            [y],
            xerr=[[max(0.0, x - row["run_min_m"])], [max(0.0, row["run_max_m"] - x)]],
            yerr=[[max(0.0, y - row["min_m"])], [max(0.0, row["max_m"] - y)]],
            fmt="o",
            capsize=3,
            color="tab:red" if row["falls"] else "tab:blue",
        )
        ax.annotate(gait.name, (x, y), textcoords="offset points", xytext=(5, 5), fontsize="small")
        top = max(top, row["run_max_m"], row["max_m"])
    ax.plot([0, top * 1.05], [0, top * 1.05], linestyle="--", color="grey", label="same distance")
    ax.set_xlabel(f"distance in the run, on the {run_kind} (m)")
    ax.set_ylabel(f"distance on the {target} (m)")
    ax.set_title("Transfer: red = fell at least once")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.savefig(path, dpi=110)


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


def _start(parser: argparse.ArgumentParser, args: argparse.Namespace, run_start: Start, real: bool) -> Start:
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
    settings = folder.manifest["settings"]
    real = bool(args.real or args.server)
    start = _start(parser, args, tuple(settings.get("start", LEGACY_START)), real)
    jitter = tuple(args.jitter) if args.jitter is not None else stability_config(settings).jitter
    if not any(jitter) and not real:
        jitter = StabilityConfig().jitter  # the stand-in is deterministic: unmoved walks would be one walk
    seed = folder.manifest["seed"] if args.seed is None else args.seed
    servers = tuple(args.server or ())
    real_command = real_server_command(parser) if args.real else None
    workers = args.real or len(servers) or 1
    setup = EvaluationSetup(
        settings["walk_time"], start, settings["agent_mode"], servers, workers, seed, real_command=real_command
    )
    target = "real server" if real else "stand-in"
    tasks = {}
    for number_, gait in enumerate(gaits):
        starts = jittered_starts(start, jitter, args.repeats, stable_seed(seed, f"transfer/{number_}"))
        for j, point in enumerate(starts):
            key = f"transfer/g{number_}/r{j:02d}"
            tasks[key] = (gait, EpisodeTask(key, gait.genes, stable_seed(seed, key), point, WalkKind.CHECK))
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
    for gait in gaits:
        gait.walks.sort(key=lambda w: w.key)
    run_kind = run_server_kind(folder)
    write_csv(gaits, folder.path / "transfer.csv")
    write_markdown(gaits, folder.path / "transfer.md", run_kind, target)
    plot(gaits, folder.path / "transfer.png", run_kind, target)
    write_json(
        folder.path / "transfer.json",
        {
            "target": target,
            "run_server": run_kind,
            "start": list(start),
            "jitter": list(jitter),
            "seed": seed,
            "repeats": args.repeats,
            "real_command": real_command,
            "servers": [str(s) for s in servers],
            "gaits": [{**_row(g), "genes": list(g.genes), "walks": [w.to_json() for w in g.walks]} for g in gaits],
        },
    )
    print((folder.path / "transfer.md").read_text() + f"written to {folder.path}/transfer.{{csv,md,png,json}}")
    return 0
