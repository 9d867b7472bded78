"""Walk cards (``optimizer.run.walk_card``): the figures of a gait's repeated walks per server,
their files beside the gait file, and the picture of their tracks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from optimizer.episode.scoring import TracePoint, sideways_drift
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.walk_card import (
    REAL_SERVER,
    STAND_IN,
    CardError,
    CardWalk,
    WalkCard,
    card_figure,
    card_markdown,
    card_paths,
    read_card,
    track_in_start_frame,
    write_card,
)

GENES = (15.0, 30.0, 10.0, 10.0, 20.0, 0.35, 15.708)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _track(*xy: tuple[float, float], up_z: float = 1.0, heading: float = 0.0) -> tuple[tuple[float, ...], ...]:
    """Points (game_time, x, y, z, up_z, heading) 0.2 s apart through the given (x, y)."""
    return tuple((0.2 * i, x, y, 0.35, up_z, heading) for i, (x, y) in enumerate(xy))


def _record(key: str, distance: float, fell: bool = False, status: str = "ok", **shape) -> EpisodeRecord:
    return EpisodeRecord(
        key, GENES, 10 * distance, WalkKind.CHECK, distance=distance, fell=fell, time=10.0, status=status, **shape
    )


#: Known answers: 4 walks ran (one fell), one was lost; the old-log walk has no drift, turn or track.
RECORDS = [
    _record("r00", 3.0, drift=0.1, heading_change=-4.0, track=_track((0, 0), (1.5, 0.05), (3.0, 0.1))),
    _record("r01", 1.0, fell=True, drift=-0.5, heading_change=10.0, track=_track((0, 0), (1.0, -0.5))),
    _record("r02", 2.0, drift=0.2, heading_change=2.0, track=_track((0, 0), (2.0, 0.2))),
    _record("r03", 0.0, status="failed"),
    _record("r04", 4.0),
]


def _card(side: str = STAND_IN, records=RECORDS) -> WalkCard:
    return WalkCard.from_records("fastest walk", GENES, 10.0, 0.0, side, records)


def test_summary_counts_falls_and_lost_walks_apart_and_takes_medians_of_magnitudes() -> None:
    summary = _card().summary(STAND_IN)
    assert summary["walks"] == 4 and summary["falls"] == 1 and summary["failed"] == 1
    assert summary["distance_mean"] == pytest.approx(2.5)  # (3 + 1 + 2 + 4) / 4: the lost walk is in no figure
    assert summary["speed"] == pytest.approx(0.25)  # over the 10-s walk time
    assert (summary["distance_min"], summary["distance_max"]) == (1.0, 4.0)
    assert summary["drift_walks"] == 3 and summary["drift_median"] == pytest.approx(0.2)
    assert summary["drift_worst"] == pytest.approx(0.5)  # a right drift is as bad as a left one
    assert summary["turn_walks"] == 3 and summary["turn_median"] == pytest.approx(4.0)
    assert summary["turn_worst"] == pytest.approx(10.0)
    assert summary["drawn"] == 3  # the old log's walk counts, but has nothing to draw


def test_a_side_without_walks_that_ran_has_no_figures() -> None:
    summary = _card(records=[_record("r00", 0.0, status="failed")]).summary(STAND_IN)
    assert summary["walks"] == 0 and summary["failed"] == 1
    assert summary["speed"] is None and summary["distance_mean"] is None and summary["drift_median"] is None
    with pytest.raises(KeyError):
        _card().summary(REAL_SERVER)


def test_a_walk_keeps_its_own_start_heading_and_whether_it_ran() -> None:
    moved = EpisodeRecord("r", GENES, 10.0, WalkKind.CHECK, start=(-5.0, 0.0, 7.5), distance=1.0)
    assert CardWalk.from_record(moved).heading == 7.5 and CardWalk.from_record(moved).ran
    assert CardWalk.from_record(RECORDS[0]).heading is None  # from the run's start: the card's heading
    assert not CardWalk.from_record(RECORDS[3]).ran


def test_a_track_is_drawn_in_the_frame_of_its_start_heading() -> None:
    # facing +y (90 deg) from (1, 2): 1 m ahead and 0.2 m to the left is (0.8, 3.0)
    track = _track((1.0, 2.0), (0.9, 2.5), (0.8, 3.0), heading=90.0)
    forward, left = track_in_start_frame(track, 90.0)
    assert forward == pytest.approx([0.0, 0.5, 1.0]) and left == pytest.approx([0.0, 0.1, 0.2])
    points = [TracePoint(*p) for p in track]
    assert left[-1] == pytest.approx(sideways_drift(points, 90.0))  # the judge's drift, where the walk ended


def test_with_side_keeps_the_other_side_and_its_place() -> None:
    card = _card()
    real = (CardWalk(5.0, False, 10.0, key="real/r00"),)
    both = card.with_side(REAL_SERVER, real)
    assert list(both.sides) == [STAND_IN, REAL_SERVER]
    assert both.sides[STAND_IN] == card.sides[STAND_IN] and both.sides[REAL_SERVER] == real
    again = both.with_side(STAND_IN, real)  # replacing the first side keeps it first
    assert list(again.sides) == [STAND_IN, REAL_SERVER] and again.sides[STAND_IN] == real
    assert both.sides[STAND_IN] == card.sides[STAND_IN]  # the card it came from is not changed
    assert card.sides.keys() == {STAND_IN}


def test_an_untracked_or_lost_walk_is_counted_but_not_drawn() -> None:
    figure = card_figure(_card())
    [ax] = figure.axes
    drawn = sorted(line.get_gid() for line in ax.lines if line.get_gid())
    assert drawn == ["fall:r01", "walk:r00", "walk:r01", "walk:r02"]
    notes = " ".join(t.get_text() for t in ax.texts)
    assert "1 walk(s) without a track" in notes and "1 walk(s) could not be run" in notes
    assert "1 of 4 fell" in ax.get_title()


def test_two_sides_are_two_panels_with_the_same_limits() -> None:
    far = _record("real/r00", 6.0, drift=0.9, heading_change=1.0, track=_track((0, 0), (6.0, 0.9)))
    figure = card_figure(_card().with_side(REAL_SERVER, [CardWalk.from_record(far)]))
    left, right = figure.axes
    assert left.get_xlim() == right.get_xlim() and left.get_ylim() == right.get_ylim()
    assert left.get_xlim()[1] >= 6.0 and left.get_ylim()[1] >= 0.9  # the other side's walk fits on both
    assert REAL_SERVER in right.get_title() and [line.get_gid() for line in right.lines if line.get_gid()] == [
        "walk:real/r00"
    ]


def test_write_card_writes_json_markdown_and_png_beside_the_gait(tmp_path: Path) -> None:
    gait = tmp_path / "fastest_gait.json"
    card = _card().with_side(REAL_SERVER, [CardWalk.from_record(RECORDS[1])])
    write_card(card, gait)
    json_path, md_path, png_path = card_paths(gait)
    assert [p.name for p in (json_path, md_path, png_path)] == [
        "fastest_gait.card.json",
        "fastest_gait.card.md",
        "fastest_gait.card.png",
    ]
    assert png_path.read_bytes().startswith(PNG_SIGNATURE)
    markdown = md_path.read_text()
    header = next(line for line in markdown.splitlines() if line.startswith("| |"))
    assert header == f"| | {STAND_IN} | {REAL_SERVER} |" and "fastest_gait.card.png" in markdown
    assert "| falls | 1/4 | 1/1 |" in markdown and "| walks | 4 (+1 could not be run) | 1 |" in markdown
    assert read_card(gait) == card
    assert json.loads(json_path.read_text())["summary"][STAND_IN]["falls"] == 1


def test_a_gait_without_a_card_reads_none_and_a_broken_card_says_why(tmp_path: Path) -> None:
    gait = tmp_path / "best_gait.json"
    assert read_card(gait) is None
    card_paths(gait)[0].write_text('{"format": "walk-card/1", "sides": {"stand-in": [{"fell": 1}]}}')
    with pytest.raises(CardError, match="best_gait.card.json"):
        read_card(gait)
    card_paths(gait)[0].write_text("{")
    with pytest.raises(CardError, match="not JSON"):
        read_card(gait)


def test_the_markdown_of_one_side_has_one_column_and_shows_missing_figures() -> None:
    markdown = card_markdown(_card(records=RECORDS[4:]))
    assert f"| | {STAND_IN} |" in markdown and REAL_SERVER not in markdown
    assert "| sideways drift (m): median / worst | - |" in markdown
    with_drift = card_markdown(_card())
    assert "| sideways drift (m): median / worst | 0.20 / 0.50 (of 3) |" in with_drift
    assert "| speed (m/s) | 0.250 |" in with_drift


#: any float a walk could carry (and far more): the file must give back each one bit for bit
finite = st.floats(min_value=-1e6, max_value=1e6)
points = st.tuples(*[finite] * 6)
walks = st.builds(
    CardWalk,
    distance=finite,
    fell=st.booleans(),
    time=finite,
    drift=st.none() | finite,
    heading_change=st.none() | finite,
    track=st.none() | st.lists(points, max_size=4).map(tuple),
    heading=st.none() | finite,
    ran=st.booleans(),
    key=st.text(max_size=12),
)
cards = st.builds(
    WalkCard,
    name=st.text(max_size=20),
    genes=st.lists(finite, min_size=7, max_size=7).map(tuple),
    walk_time=st.floats(min_value=0.1, max_value=60.0),
    heading=finite,
    sides=st.dictionaries(st.sampled_from([STAND_IN, REAL_SERVER, "other"]), st.lists(walks, max_size=3).map(tuple)),
)


@given(cards)
def test_a_card_survives_its_json_file(card: WalkCard) -> None:
    document = json.loads(json.dumps(card.to_json(), allow_nan=False))
    back = WalkCard.from_json(document)
    assert back == card and list(back.sides) == list(card.sides)
