"""What ``python -m optimizer.transfer`` reads and writes: the gaits a run reported, their walks on
another server, and the tables, plot, JSON and walk cards that set them beside the run's own.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from gait import GaitFamily, GaitFileError, family_named, load_gait
from optimizer.episode import Start
from optimizer.episode.course import Course
from optimizer.evaluation.pool import EpisodeTask
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.folder import RunFolder, write_json
from optimizer.run.robust import jittered_starts
from optimizer.run.stability import distance_spread
from optimizer.run.walk_card import CardError, CardWalk, WalkCard, read_card, side_name, write_card
from optimizer.seeds import stable_seed


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


#: Where the commands write a reported gait's gait file (``optimizer.job.write_outputs``,
#: ``optimizer.job_ga``): a Table I row's best in ``best_gait-pc<rate>.json`` and, for the row of
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
    folder: Path,
    gaits: Sequence[ReportedGait],
    side: str,
    walk_time: float,
    heading: float,
    family: str,
    course: Course | None = None,
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
                card = WalkCard(gait.name, gait.genes, walk_time, heading, family=gait.family or family, course=course)
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


def transfer_tasks(
    gaits: Sequence[ReportedGait], start: Start, jitter: Sequence[float], repeats: int, seed: int
) -> dict[str, tuple[ReportedGait, EpisodeTask]]:
    """Each gait's walks, keyed ``transfer/g<gait>/r<walk>``, from starts moved within ``jitter``,
    each seeded from the run's seed and its key."""
    tasks = {}
    for number_, gait in enumerate(gaits):
        starts = jittered_starts(start, jitter, repeats, stable_seed(seed, f"transfer/{number_}"))
        for j, point in enumerate(starts):
            key = f"transfer/g{number_}/r{j:02d}"
            task = EpisodeTask(
                key, gait.genes, stable_seed(seed, key), point, WalkKind.CHECK, trace=True, family=gait.family
            )
            tasks[key] = (gait, task)
    return tasks


def write_transfer_json(path: Path, gaits: Sequence[ReportedGait], measured: Mapping[str, Any]) -> None:
    """transfer.json: how the walks were made (``measured``) and every gait's walks."""
    write_json(
        path,
        {
            **measured,
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


def write_report(
    folder: Path,
    gaits: Sequence[ReportedGait],
    measured: Mapping[str, Any],
    family: GaitFamily,
    real: bool,
    walk_time: float,
    course: Course | None = None,
) -> tuple[list[Path], list[str]]:
    """Every file of a transfer: its table (CSV and Markdown), plot and JSON, and the new walks as a
    side of each gait's walk card; returns the cards written and notes on the gaits that got none."""
    for gait in gaits:
        gait.walks.sort(key=lambda w: w.key)
    run_kind, target = measured["run_server"], measured["target"]
    write_csv(gaits, folder / "transfer.csv", family)
    write_markdown(gaits, folder / "transfer.md", run_kind, target)
    plot(gaits, folder / "transfer.png", run_kind, target)
    write_transfer_json(folder / "transfer.json", gaits, measured)
    return update_cards(folder, gaits, side_name(real), walk_time, measured["start"][2], family.name, course)
