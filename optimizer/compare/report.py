"""The comparison's files: per-seed runs, per-method summaries and pairwise tests as CSV and
Markdown, and the convergence plot (best distance so far against episodes, median and quartile
band per method)."""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from optimizer.compare.statistics import MethodSummary, PairTest
from optimizer.episode.course import Course


@dataclass(frozen=True)
class RunOutcome:
    """One method on one seed: its best candidate (score in metres: the one walk's distance, or
    the robust score's), that gait's stability check, and the best distance so far after each
    episode it spent."""

    method: str
    seed_index: int
    best_key: str
    best_genes: tuple[float, ...]
    best_distance: float
    check_walks: int
    check_falls: int
    check_mean: float | None
    success: bool
    curve: tuple[float, ...]
    #: the check as ``StabilityReport.to_dict()`` gives it (None: checks off)
    check: Mapping[str, Any] | None = None
    #: the walks that scored the best (distance m, fell): one, or ``--robust``'s K
    best_walks: tuple[tuple[float, bool], ...] = ()

    def row(self) -> dict[str, Any]:
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name not in ("curve", "best_genes", "check", "best_walks")
        }

    def scoring_walk(self) -> dict[str, Any]:
        """What the best's search walks measured, as ``optimizer.transfer`` reads a reported walk
        when there is no check: their mean distance, and a fall when any of them fell. Not the
        score: a robust quantile is no distance walked, and a best whose one walk fell must not be
        reported as standing."""
        if not self.best_walks:  # an outcome without its walks: the score is all there is
            return {"distance": self.best_distance, "fell": False}
        distances = [d for d, _ in self.best_walks]
        return {
            "distance": sum(distances) / len(distances),
            "fell": any(fell for _, fell in self.best_walks),
            "walks": [{"distance": d, "fell": fell} for d, fell in self.best_walks],
        }


def _write_csv(rows: Sequence[Mapping[str, Any]], path: Path) -> None:
    with path.open("w", newline="") as out:
        writer = csv.DictWriter(out, list(rows[0]) if rows else [])
        writer.writeheader()
        writer.writerows({k: ("" if v is None else v) for k, v in row.items()} for row in rows)


def write_tables(
    runs: Sequence[RunOutcome],
    summaries: Sequence[MethodSummary],
    pairs: Sequence[PairTest],
    folder: Path,
    success_distance: float,
    budget_episodes: int,
    course: Course | None = None,
) -> None:
    """runs.csv, summary.csv, pairs.csv and comparison.md (on a ``course``, its figures say what they are)."""
    _write_csv([r.row() for r in runs], folder / "runs.csv")
    _write_csv([asdict(s) for s in summaries], folder / "summary.csv")
    _write_csv([{**asdict(p), "significant": p.significant()} for p in pairs], folder / "pairs.csv")
    if course is None:
        head = (
            f"Final best distance (m) in 15 s over seeds, {budget_episodes} search episodes per run; success: "
            f"the best walks >= {success_distance:g} m and did not fall in its stability check."
        )
    else:
        head = (
            f"A course ({len(course.poses)} poses, {course.size:.2f} m, at most {course.time_limit:g} s): final best "
            f"score / 10 over seeds, {budget_episodes} search episodes per run; it is the metres of course done by "
            f"a walk that did not finish, and {course.size:.2f} x (2 - time / {course.time_limit:g} s) by one that "
            f"did (above {course.size:.2f}). Success: the best's scoring walks finished and it did not fall in its "
            "stability check."
        )
    lines = [
        head,
        "",
        "| method | seeds | median | IQR | best | success |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for s in sorted(summaries, key=lambda s: -s.median):
        lines.append(
            f"| {s.method} | {s.seeds} | {s.median:.2f} | {s.q1:.2f}-{s.q3:.2f} | {s.best:.2f} | {s.success:.0%} |"
        )
    lines += [
        "",
        "Pairwise two-sided Mann-Whitney U, Holm-corrected; effect: rank-biserial r (> 0: the first walks farther).",
        "",
        "| a | b | U | p | p (Holm) | r | |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for p in pairs:
        lines.append(
            f"| {p.a} | {p.b} | {p.u:g} | {p.p:.3g} | {p.p_holm:.3g} | {p.effect:+.2f} | "
            f"{'significant' if p.significant() else ''} |"
        )
    (folder / "comparison.md").write_text("\n".join(lines) + "\n")


def plot_convergence(runs: Sequence[RunOutcome], path: Path) -> None:
    """Median best-so-far per method against episodes, with the interquartile band."""
    fig = Figure(figsize=(7.2, 4.8), layout="constrained")
    ax = fig.add_subplot()
    methods = list(dict.fromkeys(r.method for r in runs))
    for method in methods:
        curves = [r.curve for r in runs if r.method == method and r.curve]
        length = min(len(c) for c in curves)
        values = np.array([c[:length] for c in curves])
        q1, median, q3 = np.percentile(values, [25, 50, 75], axis=0)
        episodes = np.arange(1, length + 1)
        (line,) = ax.plot(episodes, median, label=f"{method} ({len(curves)} seeds)")
        ax.fill_between(episodes, q1, q3, color=line.get_color(), alpha=0.2)
    ax.set_xlabel("episodes")
    ax.set_ylabel("best distance so far (m in 15 s)")
    ax.set_title("Convergence: median and interquartile band over seeds")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    fig.savefig(path, dpi=110)
