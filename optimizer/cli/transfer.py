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
import csv
import json
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from gait import GaitFamily, GaitFileError, family_named, load_gait
from optimizer.cli.common import (
    LEGACY_START,
    EvaluationSetup,
    EvaluatorMaker,
    add_server_arguments,
    check_start_for_real_server,
    existing_run,
    pool_evaluator,
    real_server_command,
    run_family,
    stability_config,
)
from optimizer.episode import DEFAULT_START, Start, start_problem_on_real_server
from optimizer.evaluation.pool import EpisodeTask, EvaluationError
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.folder import RunFolder, write_json
from optimizer.run.robust import jittered_starts
from optimizer.run.stability import distance_spread
from optimizer.run.walk_card import CardError, CardWalk, WalkCard, read_card, side_name, write_card
from optimizer.seeds import stable_seed
from protocol.cli_values import non_negative, number, positive_int


@dataclass
class ReportedGait:
    """A gait a run reported, under every name it was reported as, and what the run measured of
    it: its check's walks where it was checked, else the one walk that found it. ``files``: the
    run folder's gait files that may hold it (``gait_file_names``; ``gait_files`` keeps those that do)."""

    genes: tuple[float, ...]
    names: list[str]
    run_distances: list[float]
    run_falls: int
    walks: list[EpisodeRecord] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    #: the genes' family where it is not the run's (the main job's refined walk: tfs-start)
    family: str | None = None

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


#: Where the commands write a reported gait's gait file (``optimizer.cli.gala.write_outputs``,
#: ``optimizer.cli.ga``): a Table I row's best in ``best_gait-pc<rate>.json`` and, for the row of
#: the highest fitness, in ``best_gait.json`` too; the GALA run's fastest stable walk in
#: ``fastest_gait.json``; a GA run's best in ``best_gait.json``. A comparison writes none.
BEST_GAIT = "best_gait.json"
FASTEST_GAIT = "fastest_gait.json"


#: How far a start is moved where nothing else varies a stand-in's walks: within the real
#: server's beam noise (x, y m; heading deg), what the checks of runs before the dither used.
BEAM_NOISE = (0.05, 0.05, 10.0)


def row_gait_file(crossover: float) -> str:
    return f"best_gait-pc{crossover:g}.json"


def reported_gaits(results: Mapping[str, Any]) -> list[ReportedGait]:
    """The gaits of a GALA, refinement, GA or comparison run's ``results.json``, one entry per distinct gait,
    in the order the run reports them (Table I rows, then the fastest walk), each with the gait
    files it may be in (``best_gait.json`` is every row's candidate: which row it holds is seen
    by its genes, ``gait_files``)."""
    found: list[tuple[str, Sequence[float], Mapping[str, Any] | None, Mapping[str, Any] | None, list[str]]] = []
    families: dict[tuple[float, ...], str] = {}
    if "rows" in results or "fastest_episode" in results:  # GALA (rows, then the fastest); a refinement
        for row in results.get("rows", ()):
            found.append(
                (
                    f"Table I pc {row['crossover']:g}",
                    row["best_genes"],
                    row.get("check"),
                    row.get("best_episode"),
                    [row_gait_file(row["crossover"]), BEST_GAIT],
                )
            )
        fastest = results.get("fastest_episode")
        if fastest is not None:
            found.append(("fastest", fastest["genes"], results.get("fastest_check"), fastest, [FASTEST_GAIT]))
            if fastest.get("family") is not None:
                families[tuple(float(g) for g in fastest["genes"])] = fastest["family"]
    elif "reported" in results:  # a comparison: each method's best on each seed
        for gait in results["reported"]:
            found.append((gait["name"], gait["genes"], gait.get("check"), gait.get("walk"), []))
    elif "best_genes" in results:  # GA
        found.append(("GA best", results["best_genes"], results.get("check"), results.get("best_episode"), [BEST_GAIT]))
    gaits: dict[tuple[float, ...], ReportedGait] = {}
    for name, genes, check, walk, files in found:
        key = tuple(float(g) for g in genes)
        if key in gaits:
            gaits[key].names.append(name)
            gaits[key].files.extend(f for f in files if f not in gaits[key].files)
            continue
        distances, falls = _measured(check, walk)
        gaits[key] = ReportedGait(key, [name], distances, falls, files=list(files), family=families.get(key))
    return list(gaits.values())


def gait_files(folder: Path, gait: ReportedGait) -> list[Path]:
    """Those of the gait's candidate files in ``folder`` that hold its genes: a file missing
    (a run still writing its first row) or holding another gait (``best_gait.json`` of another
    row, a file left from before a resume) gets no card of this gait."""
    held = []
    for name in gait.files:
        path = folder / name
        try:
            genes = tuple(float(g) for g in load_gait(path).as_array())
        except GaitFileError:
            continue
        if genes == gait.genes:
            held.append(path)
    return held


def update_cards(
    folder: Path, gaits: Sequence[ReportedGait], side: str, walk_time: float, heading: float, family: str
) -> tuple[list[Path], list[str]]:
    """Put each gait's new walks on the card beside each of its gait files as ``side`` (the
    card's other sides kept), or start a card there; returns the gait files whose card was
    written, and notes for the user (a card that could not be read, or of other genes, is
    replaced)."""
    written: list[Path] = []
    notes: list[str] = []
    fileless: list[str] = []
    for gait in gaits:
        walks = [CardWalk.from_record(w) for w in gait.walks]
        paths = gait_files(folder, gait)
        if not paths:
            fileless.append(gait.name)
        for path in paths:
            try:
                card = read_card(path)
            except CardError as exc:
                notes.append(f"{exc}; replaced by a card of the new walks")
                card = None
            if card is not None and card.genes != gait.genes:
                notes.append(f"{path.name}: its card was of other genes; replaced by a card of the new walks")
                card = None
            if card is None:
                card = WalkCard(gait.name, gait.genes, walk_time, heading, family=gait.family or family)
            write_card(card.with_side(side, walks), path)
            written.append(path)
    if fileless:
        notes.append(
            f"no gait file in the run folder holds {len(fileless)} gait(s), so no walk card: {', '.join(fileless)}"
        )
    return written, notes


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
)  # then gene_<name> for each gene of the run's family


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
    }


def write_csv(gaits: Sequence[ReportedGait], path: Path, family: GaitFamily) -> None:
    """One row per gait; a gene column for each gene of the run's ``family`` and of any other family
    a gait is of (left empty for gaits without that gene)."""
    names = list(family.gene_names)
    for gait in gaits:
        if gait.family is not None:
            names += [n for n in family_named(gait.family).gene_names if n not in names]
    with path.open("w", newline="") as out:
        writer = csv.DictWriter(out, COLUMNS + tuple(f"gene_{n}" for n in names))
        writer.writeheader()
        for gait in gaits:
            own = family if gait.family is None else family_named(gait.family)
            row = {**_row(gait), **{f"gene_{n}": g for n, g in zip(own.gene_names, gait.genes)}}
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


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
    # the dither stands in for the real server's spread, so only the stand-in's walks get it
    command_noise = 0.0 if real else float(settings.get("command_noise", 0.0))
    if not any(jitter) and not real and command_noise == 0:
        jitter = BEAM_NOISE  # the stand-in is deterministic: unmoved, undithered walks would be one walk
    seed = folder.manifest["seed"] if args.seed is None else args.seed
    servers = tuple(args.server or ())
    real_command = real_server_command(parser) if args.real else None
    workers = args.real or len(servers) or 1
    setup = EvaluationSetup(
        settings["walk_time"],
        start,
        settings["agent_mode"],
        servers,
        workers,
        seed,
        real_command=real_command,
        command_noise=command_noise,
        family=run_family(settings),
    )
    target = "real server" if real else "stand-in"
    tasks = {}
    for number_, gait in enumerate(gaits):
        starts = jittered_starts(start, jitter, args.repeats, stable_seed(seed, f"transfer/{number_}"))
        for j, point in enumerate(starts):
            key = f"transfer/g{number_}/r{j:02d}"
            task = EpisodeTask(
                key, gait.genes, stable_seed(seed, key), point, WalkKind.CHECK, trace=True, family=gait.family
            )
            tasks[key] = (gait, task)
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
    write_csv(gaits, folder.path / "transfer.csv", family_named(setup.family))
    write_markdown(gaits, folder.path / "transfer.md", run_kind, target)
    plot(gaits, folder.path / "transfer.png", run_kind, target)
    write_json(
        folder.path / "transfer.json",
        {
            "target": target,
            "run_server": run_kind,
            "start": list(start),
            "jitter": list(jitter),
            "command_noise": command_noise,
            "seed": seed,
            "repeats": args.repeats,
            "real_command": real_command,
            "servers": [str(s) for s in servers],
            "gaits": [
                {
                    **_row(g),
                    "genes": list(g.genes),
                    **({} if g.family is None else {"family": g.family}),
                    "walks": [w.to_json() for w in g.walks],
                }
                for g in gaits
            ],
        },
    )
    cards, notes = update_cards(folder.path, gaits, side_name(real), settings["walk_time"], start[2], setup.family)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    written = "".join(f"\nwalk card ({target} side): {p.stem}.card.{{json,md,png}}" for p in cards)
    print((folder.path / "transfer.md").read_text() + f"written to {folder.path}/transfer.{{csv,md,png,json}}{written}")
    return 0
