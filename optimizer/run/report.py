"""Result files people use: Table I as CSV and Markdown, convergence plots as PNG (paper Fig. 4-7).

Distance and speed are columns the caller fills (from fitness = 10 x and the 15 s episode, and
only when the robot did not fall): this module turns numbers into files and knows no physics.
Plots are drawn on a bare ``matplotlib.figure.Figure`` (Agg canvas), never through pyplot, so
no display and no global backend state are involved, even when called from worker processes.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import astuple, dataclass, fields
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from optimizer.search.ga import GenerationStats
from optimizer.search.gala import GALAResult


@dataclass(frozen=True)
class TableRow:
    """One row of Table I, plus the gait it stands for and its stability check (None where the
    caller has no figure): ``distance_m`` is the mean of the walks its search scored it by;
    ``repeat_falls`` of ``repeats`` check walks fell; they went ``repeat_min_distance_m`` to
    ``repeat_max_distance_m``, ``repeat_mean_distance_m`` on average. ``holds`` is the verdict:
    no check walk fell. The check's mean is the figure to trust on a real server, where one walk
    can be a lucky one, and a row whose gait falls says so rather than showing a distance alone."""

    crossover_rate: float
    optimal_mutation_rate: float
    best_fitness: float
    distance_m: float | None = None
    speed_mps: float | None = None
    repeats: int | None = None
    repeat_falls: int | None = None
    repeat_min_distance_m: float | None = None
    repeat_mean_distance_m: float | None = None
    repeat_max_distance_m: float | None = None
    holds: bool | None = None

    @classmethod
    def from_gala(
        cls,
        result: GALAResult,
        distance_m: float | None = None,
        speed_mps: float | None = None,
        repeats: int | None = None,
        repeat_falls: int | None = None,
        spread: tuple[float, float, float] | None = None,
        holds: bool | None = None,
    ) -> TableRow:
        """``spread``: the check's (shortest, longest, mean) distance."""
        shortest, longest, mean = spread or (None, None, None)
        return cls(
            result.crossover,
            result.optimal_mutation,
            result.best_fitness,
            distance_m,
            speed_mps,
            repeats,
            repeat_falls,
            shortest,
            mean,
            longest,
            holds,
        )


COLUMNS = tuple(f.name for f in fields(TableRow))
_COUNTS = frozenset({"repeats", "repeat_falls"})
_FLAGS = frozenset({"holds"})
_HEADINGS = (
    "Crossover rate",
    "Optimal mutation rate",
    "Best fitness",
    "Distance (m)",
    "Speed (m/s)",
    "Falls in repeats",
    "Shortest repeat (m)",
    "Mean repeat (m)",
    "Longest repeat (m)",
    "Holds",
)


def _cell(name: str, value: float | None) -> str:
    if value is None:
        return ""
    if name in _FLAGS:
        return "yes" if value else "no"
    return str(int(value)) if name in _COUNTS else repr(float(value))


def write_table_csv(rows: Sequence[TableRow], path: Path) -> None:
    """Numbers are written with ``repr`` so that reading the file back gives the same floats, the
    counts as integers; an empty cell is a figure the caller did not have."""
    with Path(path).open("w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(COLUMNS)
        for row in rows:
            writer.writerow([_cell(name, value) for name, value in zip(COLUMNS, astuple(row))])


def _value(name: str, text: str) -> Any:  # the column decides: a count, a figure or none
    if text == "":
        return None
    if name in _FLAGS:
        return text == "yes"
    return int(text) if name in _COUNTS else float(text)


def read_table_csv(path: Path) -> list[TableRow]:
    """Read a table written by ``write_table_csv`` (e.g. to add the rows of a resumed sweep)."""
    with Path(path).open(newline="") as src:
        reader = csv.DictReader(src)
        if tuple(reader.fieldnames or ()) != COLUMNS:
            raise ValueError(f"{path}: expected columns {COLUMNS}, got {reader.fieldnames}")
        return [TableRow(*(_value(c, line[c]) for c in COLUMNS)) for line in reader]


def _markdown_cells(row: TableRow) -> list[str]:
    def number(fmt: str, value: float | None) -> str:
        return "-" if value is None else fmt.format(value)

    falls = "-" if row.repeats is None or row.repeat_falls is None else f"{row.repeat_falls}/{row.repeats}"
    return [
        number("{:.2f}", row.crossover_rate),
        number("{:.2f}", row.optimal_mutation_rate),
        number("{:.4f}", row.best_fitness),
        number("{:.2f}", row.distance_m),
        number("{:.3f}", row.speed_mps),
        falls,
        number("{:.2f}", row.repeat_min_distance_m),
        number("{:.2f}", row.repeat_mean_distance_m),
        number("{:.2f}", row.repeat_max_distance_m),
        "-" if row.holds is None else ("yes" if row.holds else "**FALLS**"),
    ]


def write_table_markdown(rows: Sequence[TableRow], path: Path, note: str | None = None) -> None:
    """Table I as the paper prints it (rates to 2 decimals, fitness to 4), then the gait's walks and
    its check ("1/10": one of ten check walks fell) and the verdict (**FALLS** where a check walk
    fell); a dash for no figure. ``note``: a paragraph after the table (what a course run's figures mean)."""
    lines = ["| " + " | ".join(_HEADINGS) + " |", "|" + "---:|" * len(_HEADINGS)]
    lines.extend("| " + " | ".join(_markdown_cells(row)) + " |" for row in rows)
    if note is not None:
        lines += ["", note]
    Path(path).write_text("\n".join(lines) + "\n")


def plot_ga_convergence(history: Sequence[GenerationStats], path: Path, title: str = "GA convergence") -> None:
    """Best and mean fitness per generation (paper Fig. 4, 5, 7)."""
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.add_subplot()
    generations = [s.generation for s in history]
    ax.plot(generations, [s.best for s in history], marker="o", label="best")
    ax.plot(generations, [s.mean for s in history], marker=".", linestyle="--", label="mean")
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness (eq. 9: 10 x)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=110)


def plot_gala_convergence(result: GALAResult, path: Path, title: str | None = None) -> None:
    """Best fitness per iteration against the running baseline, and each action's probability per
    iteration (paper Fig. 6): one can see which mutation rate the automaton settles on and when."""
    fig = Figure(figsize=(7.0, 6.4), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    log = result.iteration_log
    iterations = [r.iteration for r in log]
    top.plot(iterations, [r.best_fitness for r in log], marker=".", label="best of iteration")
    top.plot(
        iterations,
        [math.nan if r.baseline is None else r.baseline for r in log],
        linestyle="--",
        label="average of preceding bests",
    )
    top.set_ylabel("fitness")
    top.grid(alpha=0.3)
    top.legend()
    for k, rate in enumerate(result.mutation_rates):
        bottom.plot(iterations, [r.probabilities[k] for r in log], label=f"pm={rate:g}")
    bottom.set_xlabel("iteration")
    bottom.set_ylabel("action probability")
    bottom.set_ylim(0.0, 1.0)
    bottom.grid(alpha=0.3)
    bottom.legend(ncol=5, fontsize="small")
    fig.suptitle(title or f"GALA, crossover rate {result.crossover:g}: optimal mutation {result.optimal_mutation:g}")
    fig.savefig(path, dpi=110)
