"""How faithfully the stand-in walks, against a real rcssserver3d: the measuring part.

A search on the stand-in is only as good as the stand-in's agreement with the real server at
walking speed, so this module walks a named set of gaits on both with the *same* agent and episode
code (``optimizer.episode.EpisodeRunner``, from the same start) and compares what the judge saw:
distance, fall, the time of the fall, sideways drift, heading change and the torso track.

A 15-s walk is a chaotic process. The real server is not deterministic (a few per cent run to
run; some gaits fall sometimes, and one gait's walks may turn +21, -20 and -10 deg), and a dither of
its velocity commands far below anything physical (``EpisodeConfig.command_noise``, 0.001 rad/s)
moves where a walk ends and how far it turns as much on either server (docs/history/notebook-2026.md). So each
server's figures for a gait are over its walks (``Draws``), never one walk: ``real_repeats`` walks
on the real server, ``stand_in_repeats`` on the stand-in (deterministic without a dither, so one
walk then). Walk k gets seed k of the dither on both servers: paired draws from each one's spread.

Over a set it reports (``summarize``): the Spearman rank correlation of the mean distances, how
often fall or no fall agrees (a server's verdict is the majority of its walks), the median and
worst |1 - stand-in/real mean distance| over the gaits that walk >= 3 m on the real server without
a fall, and how far the turns are apart (each server's median |heading change|, as a factor, with
a few degrees of slack so that two straight walks compare as equal). ``python -m bench.bench_fidelity``
is the command; the gait sets live in ``bench/fidelity_gaits/`` (made by
``bench/make_fidelity_gaits.py``).
"""

from __future__ import annotations

import csv
import json
import math
import statistics
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from scipy import stats  # type: ignore[import-untyped]

from gait import GENE_NAMES, TFS, Gait, TFSParams
from optimizer.compare.statistics import holm
from optimizer.episode import (
    DEFAULT_START,
    EpisodeConfig,
    EpisodeRunner,
    Start,
    TracePoint,
)
from optimizer.episode.scoring import heading_change, sideways_drift
from optimizer.run.folder import write_json

#: Where the stored gait sets are: beside this module, data of the benchmark.
GAIT_SET_DIR = Path(__file__).resolve().parent / "fidelity_gaits"
#: The stored sets; ``all`` is their union.
SET_NAMES: tuple[str, ...] = ("training", "held_aside")
GAIT_SET_FORMAT = "fidelity-gaits/1"
#: The fast real walk of the fidelity sets (``line-10``): 13.26 m in 15 s on rcssserver3d 0.7.3 (no fall in 10 walks);
#: the stand-in should walk it >= 11 m without a fall.
FAST_REAL: tuple[float, ...] = (14.95, 16.83, 37.56, 24.10, 69.99, 0.2346, 22.44)


# ----- gait sets -----


@dataclass(frozen=True)
class FidelityGait:
    """One gait of a set: its name, the family it was drawn from (line, neighbour, random, found,
    turning) and how it was made, so a set can be read and remade."""

    name: str
    family: str
    genes: tuple[float, ...]
    how: str = ""
    #: what the generator measured when it screened the gait (one real walk), for the record
    screen: Mapping[str, Any] = field(default_factory=dict)

    @property
    def params(self) -> TFSParams:
        return TFSParams.from_array(np.asarray(self.genes))

    @property
    def gait(self) -> Gait:
        """The set's gaits are of the paper's TFS family."""
        return TFS.gait(self.genes)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "family": self.family,
            "how": self.how,
            "params": dict(zip(GENE_NAMES, self.genes)),
            "screen": dict(self.screen),
        }

    @classmethod
    def from_dict(cls, item: Mapping[str, Any]) -> FidelityGait:
        params = item["params"]
        genes = tuple(float(params[name]) for name in GENE_NAMES)
        TFSParams(*genes)  # a set holding a gait that breaks eq. 5 is refused on load
        return cls(
            str(item["name"]), str(item["family"]), genes, str(item.get("how", "")), dict(item.get("screen", {}))
        )


def load_gait_set(path: Path) -> list[FidelityGait]:
    """The gaits of one stored set file."""
    document = json.loads(Path(path).read_text())
    if document.get("format") != GAIT_SET_FORMAT:
        raise ValueError(f"{path}: not a {GAIT_SET_FORMAT} file (format {document.get('format')!r})")
    return [FidelityGait.from_dict(item) for item in document["gaits"]]


def save_gait_set(path: Path, name: str, gaits: Sequence[FidelityGait], about: Mapping[str, Any]) -> None:
    """Store a set with what made it (``about``: the generator's command, seed, sources)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, {"format": GAIT_SET_FORMAT, "set": name, **about, "gaits": [g.to_dict() for g in gaits]})


def gait_set(name: str, directory: Path = GAIT_SET_DIR) -> list[FidelityGait]:
    """A stored set by name (``training``, ``held_aside``, or ``all``: both, training first)."""
    if name == "all":
        return [gait for part in SET_NAMES for gait in gait_set(part, directory)]
    if name not in SET_NAMES:
        raise ValueError(f"unknown gait set {name!r}: one of {', '.join(SET_NAMES + ('all',))}")
    return load_gait_set(directory / f"{name}.json")


# ----- one walk -----


@dataclass(frozen=True)
class Walk:
    """One episode as the judge saw it; ``status`` other than "ok" means it could not be run."""

    distance: float
    fell: bool
    time: float
    drift: float
    heading_change: float
    status: str = "ok"
    track: tuple[TracePoint, ...] = ()

    @property
    def fall_time(self) -> float | None:
        return self.time if self.fell else None

    @classmethod
    def from_episode(
        cls, distance: float, fell: bool, time: float, status: str, track: Sequence[TracePoint], heading_deg: float
    ) -> Walk:
        return cls(
            distance, fell, time, sideways_drift(track, heading_deg), heading_change(track), status, tuple(track)
        )

    def to_dict(self, with_track: bool = True) -> dict[str, Any]:
        out: dict[str, Any] = {
            "distance": self.distance,
            "fell": self.fell,
            "time": self.time,
            "drift": self.drift,
            "heading_change": self.heading_change,
            "status": self.status,
        }
        if with_track:
            # (game_time, x, y, z, up_z, heading): 4 decimals keep a 15-s track to ~20 kB
            out["track"] = [list(p.rounded()) for p in self.track]
        return out


# ----- statistics (pure: the tests check them on data with known answers) -----


def spearman(xs: Sequence[float], ys: Sequence[float]) -> float:
    """Spearman rank correlation; NaN where it is undefined (fewer than 3 pairs, or one side constant)."""
    if len(xs) != len(ys):
        raise ValueError(f"spearman needs pairs, got {len(xs)} and {len(ys)} values")
    if len(xs) < 3 or len(set(xs)) < 2 or len(set(ys)) < 2:
        return math.nan
    return float(stats.spearmanr(xs, ys).statistic)


def agreement(a: Sequence[bool], b: Sequence[bool]) -> float:
    """The fraction of pairs that agree (NaN for none)."""
    if len(a) != len(b):
        raise ValueError(f"agreement needs pairs, got {len(a)} and {len(b)} values")
    return sum(x == y for x, y in zip(a, b)) / len(a) if a else math.nan


def ratio_error(stand_in: float, real: float) -> float:
    """|1 - stand-in/real|: 0 for the same distance, 0.1 for 10% apart either way of real."""
    if real == 0:
        raise ValueError("ratio_error of a real distance of 0")
    return abs(1.0 - stand_in / real)


def turn_factor(stand_in: float, real: float, slack: float) -> float:
    """How many times apart two heading changes are (>= 1), by magnitude, each taken as at least
    ``slack`` degrees: a walk turning 1 deg and one turning 3 deg are both straight, not 3x apart,
    while 2 deg against 40 deg is 8x."""
    if slack <= 0:
        raise ValueError(f"slack must be > 0 deg, got {slack}")
    s, r = max(abs(stand_in), slack), max(abs(real), slack)
    return max(s / r, r / s)


def fell_in_majority(falls: int, walks: int) -> bool:
    """The real server's verdict on a gait: it fell in more than half of its walks."""
    return 2 * falls > walks


# ----- one gait on both servers -----


@dataclass(frozen=True)
class FidelityTargets:
    """Issue 15's targets for the stand-in, and the thresholds the figures are taken at."""

    spearman: float = 0.9
    fall_agreement: float = 0.9
    median_ratio_error: float = 0.10
    worst_ratio_error: float = 0.25
    turn_factor: float = 2.0
    #: the ratio figures are over gaits that walk at least this far on the real server without a fall
    walking_distance: float = 3.0
    #: heading changes are compared with this much slack (deg), see ``turn_factor``
    turn_slack: float = 5.0


@dataclass(frozen=True)
class Draws:
    """One gait's walks on one server (walks that could not be run are kept, and left out of every
    figure): a server is judged by these, never by one walk."""

    walks: tuple[Walk, ...]

    @property
    def ran(self) -> tuple[Walk, ...]:
        return tuple(w for w in self.walks if w.status == "ok")

    @property
    def falls(self) -> int:
        return sum(w.fell for w in self.ran)

    @property
    def fell(self) -> bool:
        """The verdict: it fell in the majority of its walks."""
        return fell_in_majority(self.falls, len(self.ran))

    def mean(self, attribute: str) -> float:
        return statistics.fmean(getattr(w, attribute) for w in self.ran)

    @property
    def turn(self) -> float:
        """How far it typically turns: the median |heading change| (deg). Not the mean of the signed
        changes, which calls walks turning +21, -20 and -10 deg straight."""
        return statistics.median(abs(w.heading_change) for w in self.ran)

    def fields(self, prefix: str) -> dict[str, Any]:
        """This side's CSV fields (``prefix`` "stand" or "real"), None where no walk ran."""
        ran = self.ran
        fall_times = [w.time for w in ran if w.fell]
        return {
            f"{prefix}_walks": len(ran),
            f"{prefix}_falls": self.falls,
            f"{prefix}_fell": self.fell if ran else None,
            f"{prefix}_min_m": min((w.distance for w in ran), default=None),
            f"{prefix}_mean_m": self.mean("distance") if ran else None,
            f"{prefix}_max_m": max((w.distance for w in ran), default=None),
            f"{prefix}_fall_time_s": statistics.fmean(fall_times) if fall_times else None,
            f"{prefix}_drift_m": self.mean("drift") if ran else None,
            f"{prefix}_turn_deg": self.turn if ran else None,
        }


@dataclass(frozen=True)
class GaitComparison:
    """One gait's walks on the stand-in beside its walks on the real server."""

    gait: FidelityGait
    stand_in: Draws
    real: Draws

    @property
    def comparable(self) -> bool:
        return bool(self.stand_in.ran) and bool(self.real.ran)

    def walks_on_real(self, targets: FidelityTargets) -> bool:
        """It walks >= ``walking_distance`` on the real server (mean) and never fell there."""
        return self.comparable and self.real.falls == 0 and self.real.mean("distance") >= targets.walking_distance

    def ratio(self) -> float | None:
        if not self.comparable:
            return None
        real = self.real.mean("distance")
        return self.stand_in.mean("distance") / real if real else None

    def turn_factor(self, targets: FidelityTargets) -> float | None:
        return turn_factor(self.stand_in.turn, self.real.turn, targets.turn_slack) if self.comparable else None

    def row(self, targets: FidelityTargets) -> dict[str, Any]:
        """The CSV row: each server's walks (count, falls, spread, turn), the ratios, the genes."""
        ratio = self.ratio()
        out: dict[str, Any] = {
            "gait": self.gait.name,
            "family": self.gait.family,
            **self.stand_in.fields("stand"),
            **self.real.fields("real"),
            "ratio": ratio,
            "ratio_error": None if ratio is None else abs(1.0 - ratio),
            "walks_on_real": self.walks_on_real(targets),
            "turn_factor": self.turn_factor(targets),
        }
        out.update({f"gene_{n}": g for n, g in zip(GENE_NAMES, self.gait.genes)})
        return out


_SIDE_FIELDS = ("walks", "falls", "fell", "min_m", "mean_m", "max_m", "fall_time_s", "drift_m", "turn_deg")
CSV_COLUMNS: tuple[str, ...] = (
    ("gait", "family")
    + tuple(f"{side}_{name}" for side in ("stand", "real") for name in _SIDE_FIELDS)
    + ("ratio", "ratio_error", "walks_on_real", "turn_factor")
    + tuple(f"gene_{n}" for n in GENE_NAMES)
)


def turn_test(stand_in: Draws, real: Draws) -> float | None:
    """Two-sided Mann-Whitney p value of the two servers' |heading change| over their walks: could
    the turns be draws of one spread? None with fewer than 3 walks on a side."""
    a, b = [abs(w.heading_change) for w in stand_in.ran], [abs(w.heading_change) for w in real.ran]
    if len(a) < 3 or len(b) < 3:
        return None
    return float(stats.mannwhitneyu(a, b, alternative="two-sided").pvalue)


def self_turn_factor(real: Draws, slack: float) -> float | None:
    """The real server against itself: the turn of its even-numbered walks against that of its
    odd-numbered ones, as a ``turn_factor``; how far apart two samples of one spread come out, a
    floor for the stand-in's factor (halves are smaller samples, so it is a generous floor).
    None with fewer than 2 walks."""
    ran = real.ran
    if len(ran) < 2:
        return None
    return turn_factor(Draws(ran[0::2]).turn, Draws(ran[1::2]).turn, slack)


# ----- over a set -----


@dataclass(frozen=True)
class FidelitySummary:
    """The set's figures; a figure over no gait is None (Spearman NaN when undefined)."""

    gaits: int
    spearman: float
    fall_agreement: float
    #: gaits that walk >= ``walking_distance`` on the real server without a fall: the ratio figures' base
    walking_gaits: int
    median_ratio_error: float | None
    worst_ratio_error: float | None
    #: turns (median |heading change|) over the walking gaits (whose real heading means a walk, not a fall)
    median_turn_factor: float | None
    worst_turn_factor: float | None
    #: fraction of the real walks that fell, over all gaits (how noisy the verdicts are)
    real_fall_fraction: float
    #: the walking gaits' turns tested stand-in against real (``turn_test``, >= 3 walks a side), and
    #: how many of them differ at 5% after Holm's correction for testing them all
    turn_gaits_tested: int = 0
    turn_gaits_differing: int | None = None
    #: ``self_turn_factor`` over the walking gaits: the real server's own disagreement
    real_self_median_turn_factor: float | None = None
    real_self_worst_turn_factor: float | None = None
    #: median |heading change| over every walk of the walking gaits, on each server: a bias in
    #: turning (feet twisting too easily) shows here, where one gait's chaos averages out
    stand_pooled_turn: float | None = None
    real_pooled_turn: float | None = None

    def misses(self, targets: FidelityTargets) -> list[str]:
        """Each target the figures do not meet, said with its figure (empty when all are met)."""
        checks = [
            ("Spearman", self.spearman, ">=", targets.spearman),
            ("fall agreement", self.fall_agreement, ">=", targets.fall_agreement),
            ("median |1-ratio|", self.median_ratio_error, "<=", targets.median_ratio_error),
            ("worst |1-ratio|", self.worst_ratio_error, "<=", targets.worst_ratio_error),
            ("worst heading-change factor", self.worst_turn_factor, "<=", targets.turn_factor),
        ]
        out = []
        for name, value, sense, goal in checks:
            met = value is not None and not math.isnan(value) and (value >= goal if sense == ">=" else value <= goal)
            if not met:
                out.append(f"{name} {_fmt(value)} (target {sense} {goal:g})")
        return out

    def to_dict(self) -> dict[str, Any]:
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in self.__dict__.items()}


def summarize(comparisons: Sequence[GaitComparison], targets: FidelityTargets = FidelityTargets()) -> FidelitySummary:
    """The set's figures over the gaits that could be compared (see the module docstring)."""
    rows = [c for c in comparisons if c.comparable]
    walking = [c for c in rows if c.walks_on_real(targets)]
    errors = [ratio_error(c.stand_in.mean("distance"), c.real.mean("distance")) for c in walking]
    turns = [turn_factor(c.stand_in.turn, c.real.turn, targets.turn_slack) for c in walking]
    real_walks = sum(len(c.real.ran) for c in rows)
    tests = [p for p in (turn_test(c.stand_in, c.real) for c in walking) if p is not None]
    floors = [f for f in (self_turn_factor(c.real, targets.turn_slack) for c in walking) if f is not None]
    return FidelitySummary(
        gaits=len(rows),
        spearman=spearman([c.stand_in.mean("distance") for c in rows], [c.real.mean("distance") for c in rows]),
        fall_agreement=agreement([c.stand_in.fell for c in rows], [c.real.fell for c in rows]),
        walking_gaits=len(walking),
        median_ratio_error=statistics.median(errors) if errors else None,
        worst_ratio_error=max(errors, default=None),
        median_turn_factor=statistics.median(turns) if turns else None,
        worst_turn_factor=max(turns, default=None),
        real_fall_fraction=sum(c.real.falls for c in rows) / real_walks if real_walks else math.nan,
        turn_gaits_tested=len(tests),
        turn_gaits_differing=sum(p < 0.05 for p in holm(tests)) if tests else None,
        real_self_median_turn_factor=statistics.median(floors) if floors else None,
        real_self_worst_turn_factor=max(floors, default=None),
        stand_pooled_turn=_pooled_turn([c.stand_in for c in walking]),
        real_pooled_turn=_pooled_turn([c.real for c in walking]),
    )


def _pooled_turn(sides: Sequence[Draws]) -> float | None:
    turns = [abs(w.heading_change) for side in sides for w in side.ran]
    return statistics.median(turns) if turns else None


# ----- running -----


def real_server_or_none() -> str | None:
    """The real server's command (``RCSSSERVER3D``, then PATH), or None after saying on stderr
    why there is none: the benchmark commands then exit 1 with that line, not a traceback."""
    from optimizer.episode.real_server import RealServerError, find_rcssserver3d

    try:
        return find_rcssserver3d()
    except RealServerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None


@dataclass(frozen=True)
class FidelityConfig:
    """How the benchmark walks: walks per gait on each server, the agent's dither, the walk's
    length and start."""

    real_repeats: int = 3
    #: The stand-in is deterministic: more than one walk of a gait needs a dither to differ.
    stand_in_repeats: int = 1
    #: ``EpisodeConfig.command_noise`` (rad/s) on both servers; walk k of a gait gets seed k.
    command_noise: float = 0.0
    walk_time: float = 15.0
    start: Start = DEFAULT_START
    targets: FidelityTargets = FidelityTargets()
    #: ``EpisodeConfig.robot_type`` on both servers.
    robot_type: int = 0

    def __post_init__(self) -> None:
        if self.real_repeats < 1 or self.stand_in_repeats < 1:
            raise ValueError(
                f"real_repeats and stand_in_repeats must be >= 1, got {self.real_repeats}, {self.stand_in_repeats}"
            )
        if self.stand_in_repeats > 1 and not self.command_noise > 0:
            raise ValueError(
                f"stand_in_repeats {self.stand_in_repeats} needs a command_noise > 0: without a dither the "
                "stand-in walks a gait the same way every time"
            )

    def episode_config(self) -> EpisodeConfig:
        return EpisodeConfig(
            walk_time=self.walk_time, command_noise=self.command_noise, robot_type=self.robot_type
        ).starting_at(self.start)


#: Called after each walk: (server label, gait, repeat number, the walk).
Progress = Callable[[str, FidelityGait, int, Walk], None]


def walk_gaits(
    runner: EpisodeRunner,
    gaits: Sequence[FidelityGait],
    repeats: int,
    progress: Progress | None = None,
    label: str = "",
) -> list[list[Walk]]:
    """Walk each gait ``repeats`` times on one runner (made with ``trace=True``), from its config's
    start; walk k with seed k (of the dither, where the config has one), so two servers draw alike."""
    if not runner.trace:
        raise ValueError("walk_gaits needs an EpisodeRunner made with trace=True")
    out: list[list[Walk]] = []
    for gait in gaits:
        walks = []
        for repeat in range(repeats):
            result = runner.evaluate(gait.gait, seed=repeat)
            walk = Walk.from_episode(
                result.distance, result.fell, result.time, result.status, runner.last_trace or (), runner.config.heading
            )
            walks.append(walk)
            if progress is not None:
                progress(label, gait, repeat, walk)
        out.append(walks)
    return out


def compare(
    gaits: Sequence[FidelityGait],
    real_command: str,
    config: FidelityConfig = FidelityConfig(),
    progress: Progress | None = None,
) -> list[GaitComparison]:
    """Walk ``gaits`` ``config.stand_in_repeats`` times each on the embedded stand-in, then
    ``config.real_repeats`` times each on a real server started here from ``real_command``
    (stopped with ``(killsim)``, then SIGKILL). One server is alive at a time, so neither slows the
    other's walks."""
    from optimizer.episode.real_server import RealServerProcess

    episode = config.episode_config()
    with EpisodeRunner(episode, trace=True) as runner:
        stand_in = walk_gaits(runner, gaits, config.stand_in_repeats, progress, "stand-in")
    with EpisodeRunner(episode, RealServerProcess(real_command), trace=True) as runner:
        real = walk_gaits(runner, gaits, config.real_repeats, progress, "real")
    return [GaitComparison(g, Draws(tuple(s)), Draws(tuple(r))) for g, s, r in zip(gaits, stand_in, real)]


# ----- output -----


def _fmt(value: Any, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def write_csv(comparisons: Sequence[GaitComparison], path: Path, targets: FidelityTargets = FidelityTargets()) -> None:
    with Path(path).open("w", newline="") as out:
        writer = csv.DictWriter(out, CSV_COLUMNS)
        writer.writeheader()
        for c in comparisons:
            writer.writerow({k: ("" if v is None else v) for k, v in c.row(targets).items()})


def write_tracks(
    comparisons: Sequence[GaitComparison],
    summary: FidelitySummary,
    config: FidelityConfig,
    path: Path,
    about: Mapping[str, Any],
) -> None:
    """Everything: the settings, the figures, and per gait every walk with its torso track."""
    write_json(
        Path(path),
        {
            "format": "fidelity-run/2",
            **about,
            "real_repeats": config.real_repeats,
            "stand_in_repeats": config.stand_in_repeats,
            "command_noise": config.command_noise,
            "walk_time": config.walk_time,
            "start": list(config.start),
            "robot_type": config.robot_type,
            "targets": config.targets.__dict__,
            "summary": summary.to_dict(),
            "track_columns": ["game_time", "x", "y", "z", "up_z", "heading"],
            "gaits": [
                {
                    **c.gait.to_dict(),
                    "row": c.row(config.targets),
                    "stand_in": [w.to_dict() for w in c.stand_in.walks],
                    "real": [w.to_dict() for w in c.real.walks],
                }
                for c in comparisons
            ],
        },
    )


def read_run(path: Path) -> tuple[list[GaitComparison], dict[str, Any]]:
    """A stored run (``write_tracks``) back as comparisons, with its document: the figures can be
    taken again (other thresholds, a corrected statistic) without walking again. Drift and heading
    change are taken again from the tracks where a walk has one. A run of format 1 (one stand-in
    walk, stored on its own) reads as a run of one stand-in walk."""
    document = json.loads(Path(path).read_text())

    def walk(item: Mapping[str, Any]) -> Walk:
        track = [TracePoint(*point) for point in item.get("track", [])]
        if not track:
            return Walk(
                item["distance"], item["fell"], item["time"], item["drift"], item["heading_change"], item["status"]
            )
        return Walk.from_episode(
            item["distance"], item["fell"], item["time"], item["status"], track, float(document["start"][2])
        )

    def draws(items: Mapping[str, Any] | Sequence[Mapping[str, Any]]) -> Draws:
        return Draws(tuple(walk(w) for w in ([items] if isinstance(items, Mapping) else items)))

    return [
        GaitComparison(FidelityGait.from_dict(g), draws(g["stand_in"]), draws(g["real"])) for g in document["gaits"]
    ], document


def plot(comparisons: Sequence[GaitComparison], path: Path, summary: FidelitySummary) -> None:
    """Stand-in distance (x) against the real server's (y), each the mean of its walks with a bar
    from the shortest to the longest; colour by who fell, so a fall disagreement shows at a glance."""
    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    ax = fig.add_subplot()
    styles = {
        (False, False): ("tab:blue", "neither fell"),
        (True, True): ("tab:grey", "both fell"),
        (True, False): ("tab:red", "only the stand-in fell"),
        (False, True): ("tab:orange", "only real fell"),
    }
    labelled: set[tuple[bool, bool]] = set()
    top = 1.0
    for c in (c for c in comparisons if c.comparable):
        xs, ys = [w.distance for w in c.stand_in.ran], [w.distance for w in c.real.ran]
        x, y = c.stand_in.mean("distance"), c.real.mean("distance")
        key = (c.stand_in.fell, c.real.fell)
        colour, label = styles[key]
        ax.errorbar(
            [x],
            [y],
            xerr=[[max(0.0, x - min(xs))], [max(0.0, max(xs) - x)]],
            yerr=[[max(0.0, y - min(ys))], [max(0.0, max(ys) - y)]],
            fmt="o",
            capsize=3,
            color=colour,
            label=None if key in labelled else label,
        )
        labelled.add(key)
        top = max(top, max(xs), max(ys))
    ax.plot([0, top * 1.05], [0, top * 1.05], linestyle="--", color="grey", label="same distance")
    ax.set_xlabel("stand-in: distance in 15 s (m), mean and range of its walks")
    ax.set_ylabel("real rcssserver3d: distance (m), mean and range of its walks")
    ax.set_title(
        f"Fidelity: Spearman {_fmt(summary.spearman, 2)}, fall agreement "
        f"{_fmt(summary.fall_agreement, 2)}, {summary.gaits} gaits"
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize="small")
    fig.savefig(path, dpi=110)


def report(
    comparisons: Sequence[GaitComparison], summary: FidelitySummary, targets: FidelityTargets = FidelityTargets()
) -> str:
    """The per-gait table and the figures, as printed by the benchmark."""
    lines = [
        f"{'gait':<22} {'stand-in m':>10} {'range':>11} {'falls':>5} {'real m':>6} {'range':>11} {'falls':>5} "
        f"{'ratio':>6} {'turn s/r deg':>12} {'drift s/r m':>12}"
    ]
    for c in comparisons:
        r = c.row(targets)
        lines.append(
            f"{c.gait.name:<22} {_fmt(r['stand_mean_m'], 2):>10} {_spread(r, 'stand'):>11} "
            f"{r['stand_falls']}/{r['stand_walks']:<3} {_fmt(r['real_mean_m'], 2):>6} {_spread(r, 'real'):>11} "
            f"{r['real_falls']}/{r['real_walks']:<3} {_fmt(r['ratio'], 2):>6} "
            f"{_fmt(r['stand_turn_deg'], 0):>5}/{_fmt(r['real_turn_deg'], 0):<6} "
            f"{_fmt(r['stand_drift_m'], 2):>5}/{_fmt(r['real_drift_m'], 2):<6}"
        )
    s = summary
    lines += [
        "",
        f"gaits compared: {s.gaits}; real walks that fell: {_fmt(s.real_fall_fraction * 100, 0)}%",
        f"Spearman rank correlation of the distances: {_fmt(s.spearman)}",
        f"fall agreement (each server: fell in the majority of its walks): {_fmt(s.fall_agreement)}",
        f"over the {s.walking_gaits} gaits walking >= {targets.walking_distance:g} m on the real server "
        "without a fall:",
        f"  |1 - stand-in/real distance|: median {_fmt(s.median_ratio_error)}, worst {_fmt(s.worst_ratio_error)}",
        f"  turn (median |heading change|), times apart (slack {targets.turn_slack:g} deg): "
        f"median {_fmt(s.median_turn_factor, 2)}, "
        f"worst {_fmt(s.worst_turn_factor, 2)}",
    ]
    if s.real_self_worst_turn_factor is not None:
        lines.append(
            f"  the real server against itself (its even- against its odd-numbered walks): median "
            f"{_fmt(s.real_self_median_turn_factor, 2)}, worst {_fmt(s.real_self_worst_turn_factor, 2)}"
        )
    if s.stand_pooled_turn is not None:
        lines.append(
            f"  median |heading change| over all their walks: stand-in {_fmt(s.stand_pooled_turn, 1)} deg, "
            f"real {_fmt(s.real_pooled_turn, 1)} deg"
        )
    if s.turn_gaits_differing is not None:
        lines.append(
            f"  gaits whose turns differ between the servers (Mann-Whitney on |heading change|, Holm, 5%): "
            f"{s.turn_gaits_differing} of {s.turn_gaits_tested}"
        )
    misses = s.misses(targets)
    lines.append("targets: all met" if not misses else "targets missed: " + "; ".join(misses))
    return "\n".join(lines)


def _spread(row: Mapping[str, Any], side: str) -> str:
    return f"{_fmt(row[side + '_min_m'], 2)}-{_fmt(row[side + '_max_m'], 2)}"


def print_progress(label: str, gait: FidelityGait, repeat: int, walk: Walk) -> None:
    """A ``Progress`` that writes one line per walk to stderr."""
    what = f"fell at {walk.time:.2f} s" if walk.fell else "stood"
    if walk.status != "ok":
        what = f"could not be run ({walk.status})"
    print(
        f"  {label:<8} {gait.name:<22} #{repeat + 1}: {walk.distance:6.2f} m, {what}, turned "
        f"{walk.heading_change:+.0f} deg",
        file=sys.stderr,
        flush=True,
    )
