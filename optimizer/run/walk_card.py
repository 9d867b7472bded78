"""Walk cards: what a reported gait does when walked again, beside its gait file.

A run reports a gait by its score, the distance of one walk (eq. 9). That number hides how the
gait walks: whether it falls now and then, whether it drifts sideways or turns (a gait that walks
9 m in a curve can leave the field on a real pitch, and a real server's referee moves a robot that
does), and whether it walks the same on the real server as on the stand-in. A card answers these
from the gait's repeated walks (a stability check's, or ``optimizer.transfer``'s), per server:

    fastest_gait.json       the gait (``python -m agent --gait FILE``)
    fastest_gait.card.json  every walk of the card: the figures and the torso's track (what the
                            other two are drawn from; ``read_card``)
    fastest_gait.card.md    per server: walks, falls, speed, distance spread, sideways drift
                            and heading change
    fastest_gait.card.png   per server: the torso's track of each walk, seen from above in the
                            frame of its start (forward along x, left up); a fall ends in an x

A server's walks are a *side* of the card ("stand-in", "real server"); ``optimizer.transfer``
adds or replaces the side it walked on, keeping the other, so one card sets the two servers
side by side. Like ``optimizer.run.report``, this module draws on a bare ``Figure``, never pyplot.

A gait scored on a course (``optimizer.episode.course``) has a *course card*: it keeps the course,
its table counts the walks that finished, their times and the poses reached (a distance there is
metres of course done), and its picture draws the tracks on the field with the course's poses as
arrows inside their reach circles.
"""

from __future__ import annotations

import json
import math
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gait import DEFAULT_FAMILY, family_named
from optimizer.episode.course import Course, CourseError
from optimizer.episode.scoring import TRACK_FIELDS, TracePoint, heading_change, sideways_drift
from optimizer.evaluation.record import EpisodeRecord
from optimizer.run.folder import write_json

if TYPE_CHECKING:
    from matplotlib.figure import Figure

CARD_FORMAT = "walk-card/1"
#: The sides a card knows; any other name is allowed too (and is drawn after these).
STAND_IN = "stand-in"
REAL_SERVER = "real server"


class CardError(ValueError):
    """A card file that cannot be used; the message names what is wrong."""


def side_name(real: bool) -> str:
    """The side of walks made on a real server (``real``) or on the stand-in."""
    return REAL_SERVER if real else STAND_IN


@dataclass(frozen=True)
class CardWalk:
    """One walk of a card: the figures of its episode record, and its torso track
    (``TRACK_FIELDS`` per point, None for a walk logged without one, e.g. by an older run).

    ``ran`` is False for a walk the infrastructure lost: it is counted apart, never in the
    figures. ``heading`` is the walk's own start heading (deg) where its start was moved, the
    direction its distance and drift were measured along; None means the card's ``heading``."""

    distance: float
    fell: bool
    time: float
    drift: float | None = None
    heading_change: float | None = None
    track: tuple[tuple[float, ...], ...] | None = None
    heading: float | None = None
    ran: bool = True
    key: str = ""
    #: a course walk's outcome (``EpisodeRecord.finished``, ``.reached``); None for other walks
    finished: bool | None = None
    reached: int | None = None

    @classmethod
    def from_record(cls, record: EpisodeRecord) -> CardWalk:
        turn = record.heading_change
        if turn is None and record.track:  # a track without its figures: the judge's rule on it
            turn = heading_change(_points(record.track))
        return cls(
            distance=record.distance,
            fell=record.fell,
            time=record.time,
            drift=record.drift,
            heading_change=turn,
            track=record.track,
            heading=None if record.start is None else record.start[2],
            ran=record.ran,
            key=record.key,
            finished=record.finished,
            reached=record.reached,
        )

    def to_json(self) -> dict[str, Any]:
        document: dict[str, Any] = {
            "key": self.key,
            "ran": self.ran,
            "distance": self.distance,
            "fell": self.fell,
            "time": self.time,
            "drift": self.drift,
            "heading_change": self.heading_change,
            "heading": self.heading,
        }
        if self.finished is not None:
            document.update(finished=self.finished, reached=self.reached)
        document["track"] = None if self.track is None else [list(p) for p in self.track]
        return document

    @classmethod
    def from_json(cls, document: Any) -> CardWalk:
        if not isinstance(document, dict):
            raise CardError(f"a walk must be a JSON object, found {type(document).__name__}")
        try:
            track = document.get("track")
            return cls(
                distance=float(document["distance"]),
                fell=_boolean(document["fell"], "fell"),
                time=float(document["time"]),
                drift=_optional_float(document.get("drift")),
                heading_change=_optional_float(document.get("heading_change")),
                track=None if track is None else tuple(tuple(float(v) for v in p) for p in track),
                heading=_optional_float(document.get("heading")),
                ran=_boolean(document.get("ran", True), "ran"),
                key=str(document.get("key", "")),
                finished=None if document.get("finished") is None else _boolean(document["finished"], "finished"),
                reached=None if document.get("reached") is None else int(document["reached"]),
            )
        except CardError:
            raise
        except (KeyError, TypeError, ValueError) as exc:
            raise CardError(f"walk {document.get('key', '?')!r}: {type(exc).__name__}: {exc}") from None


@dataclass(frozen=True)
class WalkCard:
    """The walks of one gait, per server (``sides``, in the order they were added)."""

    name: str
    genes: tuple[float, ...]
    #: seconds a walk lasts unless it falls: a card's speed is its mean distance over this
    walk_time: float
    #: the walking direction (deg) the tracks are drawn in, for walks without their own
    heading: float
    sides: Mapping[str, tuple[CardWalk, ...]] = field(default_factory=dict)
    #: the gait family the genes belong to (``gait.FAMILIES``)
    family: str = DEFAULT_FAMILY
    #: the course the walks walked (a course card), None for walks scored by eq. 9
    course: Course | None = None

    @classmethod
    def from_records(
        cls,
        name: str,
        genes: Sequence[float],
        walk_time: float,
        heading: float,
        side: str,
        records: Iterable[EpisodeRecord],
        family: str = DEFAULT_FAMILY,
        course: Course | None = None,
    ) -> WalkCard:
        """A card of one side, from its walks' episode records (a check's repeats, a transfer's)."""
        walks = tuple(CardWalk.from_record(r) for r in records)
        genes_ = tuple(float(g) for g in genes)
        return cls(name, genes_, float(walk_time), float(heading), {side: walks}, family, course)

    def with_side(self, side: str, walks: Sequence[CardWalk]) -> WalkCard:
        """This card with ``side``'s walks replaced by ``walks`` (added last if it is new); the
        other sides are kept as they are, so walks on one server never disturb another's."""
        sides = dict(self.sides)
        sides[side] = tuple(walks)
        return WalkCard(self.name, self.genes, self.walk_time, self.heading, sides, self.family, self.course)

    def summary(self, side: str) -> dict[str, Any]:
        """The figures of one side (``KeyError`` for a side the card lacks), None where no walk
        gives one: ``walks`` that ran, of which ``falls`` fell, ``failed`` walks the
        infrastructure lost (in no other figure); ``speed`` (m/s) = the mean distance over the
        walk time; the distance's ``mean``/``min``/``max``; the median and worst |drift| (m)
        and |heading change| (deg) of the walks that have one (``drift_walks``/``turn_walks``
        of them: an older log has none); ``drawn``: the walks with a track."""
        walks = self.sides[side]
        ran = [w for w in walks if w.ran]
        distances = [w.distance for w in ran]
        drifts = [abs(w.drift) for w in ran if w.drift is not None]
        turns = [abs(w.heading_change) for w in ran if w.heading_change is not None]
        mean = statistics.fmean(distances) if distances else None
        if self.course is not None:
            return {**self._course_summary(ran), "failed": len(walks) - len(ran)}
        return {
            "walks": len(ran),
            "falls": sum(1 for w in ran if w.fell),
            "failed": len(walks) - len(ran),
            "speed": None if mean is None or self.walk_time <= 0 else mean / self.walk_time,
            "distance_mean": mean,
            "distance_min": min(distances, default=None),
            "distance_max": max(distances, default=None),
            "drift_walks": len(drifts),
            "drift_median": statistics.median(drifts) if drifts else None,
            "drift_worst": max(drifts, default=None),
            "turn_walks": len(turns),
            "turn_median": statistics.median(turns) if turns else None,
            "turn_worst": max(turns, default=None),
            "drawn": sum(1 for w in ran if w.track),
        }

    def _course_summary(self, ran: Sequence[CardWalk]) -> dict[str, Any]:
        """A course card's figures of the walks that ran: ``finished`` of them, their ``time_*`` (s;
        fastest and slowest), the mean of the poses ``reached`` (of ``poses``), and ``speed``: the
        mean of each walk's metres of course done over its own time."""
        times = [w.time for w in ran if w.finished]
        reached = [w.reached for w in ran if w.reached is not None]
        speeds = [w.distance / w.time for w in ran if w.time > 0]
        return {
            "walks": len(ran),
            "falls": sum(1 for w in ran if w.fell),
            "finished": len(times),
            "time_mean": statistics.fmean(times) if times else None,
            "time_min": min(times, default=None),
            "time_max": max(times, default=None),
            "poses": len(self.course.poses) if self.course is not None else 0,
            "reached_mean": statistics.fmean(reached) if reached else None,
            "speed": statistics.fmean(speeds) if speeds else None,
            "drawn": sum(1 for w in ran if w.track),
        }

    def to_json(self) -> dict[str, Any]:
        """The card file's object; ``summary`` is there for readers of the file and is recomputed
        from the walks when read back. A course card keeps its course (``course``)."""
        return {
            "format": CARD_FORMAT,
            "name": self.name,
            "family": self.family,
            "genes": list(self.genes),
            "walk_time": self.walk_time,
            "heading": self.heading,
            **({} if self.course is None else {"course": self.course.to_document()}),
            "summary": {side: self.summary(side) for side in self.sides},
            "sides": {side: [w.to_json() for w in walks] for side, walks in self.sides.items()},
        }

    @classmethod
    def from_json(cls, document: Any) -> WalkCard:
        """A card from its file's object; ``CardError`` says what is wrong with one that is not."""
        if not isinstance(document, dict) or document.get("format") != CARD_FORMAT:
            raise CardError(f'expected an object with "format": "{CARD_FORMAT}"')
        sides = document.get("sides")
        if not isinstance(sides, dict) or not all(isinstance(w, list) for w in sides.values()):
            raise CardError('"sides" must map each side to a list of walks')
        try:
            course = None if document.get("course") is None else Course.from_document(document["course"])
        except CourseError as exc:
            raise CardError(f'"course": {exc}') from None
        try:
            return cls(
                name=str(document["name"]),
                genes=tuple(float(g) for g in document["genes"]),
                walk_time=float(document["walk_time"]),
                heading=float(document["heading"]),
                sides={str(side): tuple(CardWalk.from_json(w) for w in walks) for side, walks in sides.items()},
                family=str(document.get("family", DEFAULT_FAMILY)),  # a card from before families: TFS
                course=course,
            )
        except CardError:
            raise
        except (KeyError, TypeError, ValueError) as exc:
            raise CardError(f"{type(exc).__name__}: {exc}") from None


def card_paths(gait_path: Path) -> tuple[Path, Path, Path]:
    """The card's (.card.json, .card.md, .card.png) beside ``gait_path``: ``fastest_gait.json``
    -> ``fastest_gait.card.json`` and so on, so a folder listing shows a gait and its card together."""
    gait_path = Path(gait_path)
    stem = gait_path.name.removesuffix(".json")
    return (
        gait_path.with_name(f"{stem}.card.json"),
        gait_path.with_name(f"{stem}.card.md"),
        gait_path.with_name(f"{stem}.card.png"),
    )


def write_card(card: WalkCard, gait_path: Path) -> None:
    """Write the card's three files beside ``gait_path``; the JSON last (and atomically), so a
    card read back always has its picture and table written from it or from a newer card."""
    json_path, md_path, png_path = card_paths(gait_path)
    plot_card(card, png_path)
    md_path.write_text(card_markdown(card, png_path.name))
    write_json(json_path, card.to_json())


def read_card(gait_path: Path) -> WalkCard | None:
    """The card beside ``gait_path``; None when it has none, ``CardError`` when it cannot be read."""
    json_path = card_paths(gait_path)[0]
    try:
        text = json_path.read_text()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise CardError(f"{json_path}: {exc.strerror}") from None
    try:
        document = json.loads(text)
    except ValueError as exc:
        raise CardError(f"{json_path}: not JSON ({exc})") from None
    try:
        return WalkCard.from_json(document)
    except CardError as exc:
        raise CardError(f"{json_path}: {exc}") from None


# --- the card as a table and a picture -----------------------------------------------------------


def _number(fmt: str, value: float | None) -> str:
    return "-" if value is None else format(value, fmt)


def _rows(summary: Mapping[str, Any]) -> list[str]:
    s = summary
    spread = (
        "-"
        if s["distance_mean"] is None
        else f"{s['distance_mean']:.2f} ({s['distance_min']:.2f}-{s['distance_max']:.2f})"
    )

    def median_worst(prefix: str, fmt: str) -> str:
        if s[f"{prefix}_median"] is None:
            return "-"
        text = f"{s[f'{prefix}_median']:{fmt}} / {s[f'{prefix}_worst']:{fmt}}"
        walks = s[f"{prefix}_walks"]
        return text if walks == s["walks"] else f"{text} (of {walks})"

    return [
        f"{s['walks']}" + (f" (+{s['failed']} could not be run)" if s["failed"] else ""),
        f"{s['falls']}/{s['walks']}",
        _number(".3f", s["speed"]),
        spread,
        median_worst("drift", ".2f"),
        median_worst("turn", ".1f"),
        f"{s['drawn']}/{s['walks']}",
    ]


_LABELS = (
    "walks",
    "falls",
    "speed (m/s)",
    "distance (m): mean (shortest-longest)",
    "sideways drift (m): median / worst",
    "heading change (deg): median / worst",
    "walks drawn",
)


def _course_rows(summary: Mapping[str, Any]) -> list[str]:
    s = summary
    times = "-" if s["time_mean"] is None else f"{s['time_mean']:.2f} ({s['time_min']:.2f}-{s['time_max']:.2f})"
    return [
        f"{s['walks']}" + (f" (+{s['failed']} could not be run)" if s["failed"] else ""),
        f"{s['falls']}/{s['walks']}",
        f"{s['finished']}/{s['walks']}",
        times,
        "-" if s["reached_mean"] is None else f"{s['reached_mean']:.1f} of {s['poses']}",
        _number(".3f", s["speed"]),
        f"{s['drawn']}/{s['walks']}",
    ]


_COURSE_LABELS = (
    "walks",
    "falls",
    "finished",
    "time of those finished (s): mean (fastest-slowest)",
    "poses reached: mean",
    "speed (m of course/s)",
    "walks drawn",
)


def card_markdown(card: WalkCard, picture: str | None = None) -> str:
    """The card as Markdown: the gait, then one column per side (server)."""
    genes = family_named(card.family).describe(card.genes)
    lines = [f"# Walk card: {card.name}", "", f"Genes ({card.family} family): {genes}.", ""]
    rows, labels = (_rows, _LABELS) if card.course is None else (_course_rows, _COURSE_LABELS)
    if not card.sides:
        lines.append("No walks yet.")
    else:
        sides = list(card.sides)
        cells = [rows(card.summary(side)) for side in sides]
        lines.append("| | " + " | ".join(sides) + " |")
        lines.append("|---|" + "---:|" * len(sides))
        for i, label in enumerate(labels):
            lines.append(f"| {label} | " + " | ".join(c[i] for c in cells) + " |")
    if card.course is None:
        lines += [
            "",
            f"A walk lasts {card.walk_time:g} s unless it falls; speed is the mean distance over {card.walk_time:g} s. "
            "Drift: how far the torso ended left or right of the line it started on; heading change: how far "
            "it turned while upright (worst = the largest of either sign). Walks that could not be run are "
            "in no figure.",
        ]
    else:
        course = card.course
        lines += [
            "",
            f"Each walk walks a course of {len(course.poses)} poses ({course.size:.2f} m of course) from "
            f"{_pose_text(course.start)}, reaching each within {course.reach[0]:g} m and {course.reach[1]:g} deg, "
            f"in order; it ends at the last pose, at a fall or after {course.time_limit:g} s. Speed: metres of "
            "course done over the walk's own time. Walks that could not be run are in no figure.",
        ]
    if picture is not None:
        lines += ["", f"![tracks of each walk]({picture})"]
    return "\n".join(lines) + "\n"


def _pose_text(pose: Sequence[float]) -> str:
    return f"({pose[0]:g}, {pose[1]:g}, {pose[2]:g} deg)"


def _points(track: Sequence[Sequence[float]]) -> list[TracePoint]:
    return [TracePoint(**dict(zip(TRACK_FIELDS, p))) for p in track]


def track_in_start_frame(track: Sequence[Sequence[float]], heading: float) -> tuple[list[float], list[float]]:
    """(forward, left) metres of each track point from the first, along and across ``heading``;
    the last point's (forward, left) is the walk's distance and drift as the judge scored them."""
    points = _points(track)
    if not points:
        return [], []
    first, h = points[0], math.radians(heading)
    forward = [(p.x - first.x) * math.cos(h) + (p.y - first.y) * math.sin(h) for p in points]
    left = [sideways_drift([first, p], heading) for p in points]
    return forward, left


def card_figure(card: WalkCard) -> Figure:
    """One panel per side, same axes: each walk's track from above in its start's frame (forward
    right, left up), blue for a walk that stood, red ending in an x for one that fell. A walk's
    line has the gid ``walk:<key>``, its fall's x ``fall:<key>``, so a test can find them."""
    from matplotlib.figure import Figure  # here: matplotlib costs every episode process ~0.8 s to import
    from matplotlib.lines import Line2D

    if card.course is not None:
        return course_card_figure(card, card.course)
    sides = list(card.sides) or [""]
    fig = Figure(figsize=(5.4 * len(sides), 4.4), layout="constrained")
    axes = fig.subplots(1, len(sides), sharex=True, sharey=True, squeeze=False)[0]
    reach, wide = 1.0, 0.25  # at least 1 m forward, +-0.25 m sideways: a straight walk looks straight
    for ax, side in zip(axes, sides):
        walks = card.sides.get(side, ())
        for walk in walks:
            if not walk.ran or not walk.track:
                continue
            forward, left = track_in_start_frame(walk.track, card.heading if walk.heading is None else walk.heading)
            colour = "tab:red" if walk.fell else "tab:blue"
            ax.plot(forward, left, color=colour, alpha=0.7, linewidth=1.2, gid=f"walk:{walk.key}")
            if walk.fell:
                ax.plot(
                    forward[-1],
                    left[-1],
                    marker="x",
                    markersize=9,
                    markeredgewidth=2,
                    color=colour,
                    gid=f"fall:{walk.key}",
                )
            reach = max(reach, max(forward))
            wide = max(wide, max(abs(v) for v in left))
        ax.axhline(0.0, color="grey", linestyle="--", linewidth=0.8)
        ax.plot([0.0], [0.0], marker="o", color="black", markersize=4)
        ax.grid(alpha=0.3)
        ax.set_xlabel("forward from the start (m)")
        if side:
            s = card.summary(side)
            ax.set_title(f"{side}: {s['falls']} of {s['walks']} fell, {_number('.2f', s['speed'])} m/s")
            missing = s["walks"] - s["drawn"]
            notes = ([f"{missing} walk(s) without a track, not drawn"] if missing else []) + (
                [f"{s['failed']} walk(s) could not be run"] if s["failed"] else []
            )
            if notes:
                ax.text(0.01, 0.02, "; ".join(notes), transform=ax.transAxes, fontsize="small", color="dimgrey")
        else:
            ax.set_title("no walks yet")
    axes[0].set_ylabel("sideways (m, left +)")
    axes[0].set_xlim(-0.05 * reach, 1.05 * reach)
    axes[0].set_ylim(-1.15 * wide, 1.15 * wide)
    axes[0].legend(
        handles=[
            Line2D([], [], color="tab:blue", label="walked to the end"),
            Line2D([], [], color="tab:red", marker="x", label="fell (x: where)"),
        ],
        loc="upper left",
        fontsize="small",
    )
    fig.suptitle(f"Walk card: {card.name}")
    return fig


def course_card_figure(card: WalkCard, course: Course) -> Figure:
    """A course card's picture: one panel per side, the field from above (x right, y up, metres):
    the course's poses as arrows along their headings inside their reach circles (gids ``pose:<i>``
    and ``reach:<i>``, 0 the first pose), its start (``start``), and each walk's torso track (blue:
    finished, grey: ran out of time, red ending in an x: fell; gids ``walk:<key>``, ``fall:<key>``)."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle

    sides = list(card.sides) or [""]
    fig = Figure(figsize=(5.4 * len(sides), 5.0), layout="constrained")
    axes = fig.subplots(1, len(sides), sharex=True, sharey=True, squeeze=False)[0]
    xs = [course.start[0], *(p[0] for p in course.poses)]
    ys = [course.start[1], *(p[1] for p in course.poses)]
    arrow = max(0.3, 2.0 * course.reach[0])
    for ax, side in zip(axes, sides):
        for i, (x, y, heading) in enumerate(course.poses):
            ax.add_patch(Circle((x, y), course.reach[0], fill=False, color="tab:green", alpha=0.8, gid=f"reach:{i}"))
            h = math.radians(heading)
            ax.annotate(
                "",
                xy=(x + arrow * math.cos(h), y + arrow * math.sin(h)),
                xytext=(x, y),
                arrowprops={"arrowstyle": "->", "color": "tab:green", "linewidth": 1.5},
                gid=f"pose:{i}",
            )
            ax.text(x, y, f" {i + 1}", color="tab:green", fontsize="small", va="bottom")
        sx, sy, sh = course.start
        ax.plot([sx], [sy], marker="o", color="black", markersize=5, gid="start")
        ax.annotate(
            "",
            xy=(sx + arrow * math.cos(math.radians(sh)), sy + arrow * math.sin(math.radians(sh))),
            xytext=(sx, sy),
            arrowprops={"arrowstyle": "->", "color": "black"},
        )
        for walk in card.sides.get(side, ()):
            if not walk.ran or not walk.track:
                continue
            points = _points(walk.track)
            px, py = [p.x for p in points], [p.y for p in points]
            xs += px
            ys += py
            colour = "tab:red" if walk.fell else ("tab:blue" if walk.finished else "tab:grey")
            ax.plot(px, py, color=colour, alpha=0.7, linewidth=1.2, gid=f"walk:{walk.key}")
            if walk.fell:
                ax.plot(
                    px[-1], py[-1], marker="x", markersize=9, markeredgewidth=2, color=colour, gid=f"fall:{walk.key}"
                )
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
        ax.set_xlabel("x (m)")
        if side:
            s = card.summary(side)
            time = "" if s["time_mean"] is None else f", {s['time_mean']:.1f} s mean"
            ax.set_title(f"{side}: {s['finished']} of {s['walks']} finished{time}, {s['falls']} fell")
            missing = s["walks"] - s["drawn"]
            if missing:
                ax.text(
                    0.01,
                    0.02,
                    f"{missing} walk(s) without a track, not drawn",
                    transform=ax.transAxes,
                    fontsize="small",
                    color="dimgrey",
                )
        else:
            ax.set_title("no walks yet")
    margin = course.reach[0] + arrow
    axes[0].set_xlim(min(xs) - margin, max(xs) + margin)
    axes[0].set_ylim(min(ys) - margin, max(ys) + margin)
    axes[0].set_ylabel("y (m)")
    axes[0].legend(
        handles=[
            Line2D(
                [], [], color="tab:green", marker="o", fillstyle="none", linestyle="", label="pose (arrow) and reach"
            ),
            Line2D([], [], color="tab:blue", label="finished"),
            Line2D([], [], color="tab:grey", label="out of time"),
            Line2D([], [], color="tab:red", marker="x", label="fell (x: where)"),
        ],
        loc="best",
        fontsize="small",
    )
    fig.suptitle(f"Walk card: {card.name} (course)")
    return fig


def plot_card(card: WalkCard, path: Path) -> None:
    """The card's picture (``card_figure``) as a PNG."""
    card_figure(card).savefig(path, dpi=110)


def _optional_float(value: Any) -> float | None:
    return None if value is None else float(value)


def _boolean(value: Any, name: str) -> bool:
    if not isinstance(value, bool):
        raise CardError(f'"{name}" must be true or false, found {value!r}')
    return value
