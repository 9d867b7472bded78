"""The fidelity benchmark (``python -m bench.bench_fidelity``): its statistics on data with known answers, the
stored gait sets, its output files, the episode trace it reads, and a small end-to-end gate on a real server."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bench import fidelity
from bench.fidelity import (
    CSV_COLUMNS,
    FAST_REAL,
    Draws,
    FidelityConfig,
    FidelityGait,
    FidelityTargets,
    GaitComparison,
    Walk,
    agreement,
    fell_in_majority,
    ratio_error,
    spearman,
    summarize,
    turn_factor,
)
from gait import GENE_BOUNDS, GENE_NAMES, load_gait, repair_genes
from optimizer.episode import EpisodeConfig, EpisodeRunner, TracePoint
from optimizer.episode.scoring import heading_change, sideways_drift

ROOT = Path(__file__).resolve().parents[1]


# ----- statistics -----


def test_spearman_of_a_known_pairing() -> None:
    # ranks differ by 1, 1, 1, 1, 0: rho = 1 - 6 * 4 / (5 * 24) = 0.8
    assert spearman([1, 2, 3, 4, 5], [2, 1, 4, 3, 5]) == pytest.approx(0.8)


@given(st.lists(st.integers(-1000, 1000), min_size=3, max_size=30, unique=True))
def test_spearman_sees_ranks_only(xs: list[int]) -> None:
    """Any increasing transform ranks the same (1), any decreasing one the other way (-1)."""
    assert spearman(xs, [x**3 + 7 for x in xs]) == pytest.approx(1.0)
    assert spearman(xs, [-(x**3) for x in xs]) == pytest.approx(-1.0)


def test_spearman_is_nan_where_undefined() -> None:
    assert math.isnan(spearman([1, 2], [2, 1]))
    assert math.isnan(spearman([1, 2, 3], [4, 4, 4]))
    with pytest.raises(ValueError):
        spearman([1, 2, 3], [1, 2])


def test_agreement_and_the_majority_verdict() -> None:
    assert agreement([True, False, True, False], [True, True, True, True]) == 0.5
    assert math.isnan(agreement([], []))
    assert fell_in_majority(2, 3) and not fell_in_majority(1, 2) and not fell_in_majority(0, 1)


@given(st.floats(0.1, 50), st.floats(0.0, 0.9))
def test_ratio_error_is_symmetric_around_the_real_distance(real: float, off: float) -> None:
    assert ratio_error(real * (1 + off), real) == pytest.approx(off)
    assert ratio_error(real * (1 - off), real) == pytest.approx(off)


def test_ratio_error_of_no_real_distance_is_refused() -> None:
    with pytest.raises(ValueError):
        ratio_error(1.0, 0.0)


def test_turn_factor_with_slack() -> None:
    assert turn_factor(1.0, -3.0, slack=5.0) == 1.0  # both straight
    assert turn_factor(2.0, 40.0, slack=5.0) == pytest.approx(8.0)
    assert turn_factor(-60.0, 20.0, slack=5.0) == pytest.approx(3.0)  # by magnitude


@given(st.floats(-180, 180), st.floats(-180, 180), st.floats(0.5, 20))
def test_turn_factor_is_symmetric_and_at_least_one(a: float, b: float, slack: float) -> None:
    assert turn_factor(a, b, slack) == pytest.approx(turn_factor(b, a, slack))
    assert turn_factor(a, b, slack) >= 1.0


def _track(points: list[tuple[float, float, float]]) -> list[TracePoint]:
    """(x, y, heading) per state, 0.04 s apart."""
    return [TracePoint(0.04 * (i + 1), x, y, 0.37, 0.99, h) for i, (x, y, h) in enumerate(points)]


@given(st.floats(-180, 180), st.lists(st.floats(-170, 170), min_size=1, max_size=40))
def test_heading_change_unwraps_past_180(first: float, steps: list[float]) -> None:
    """The change is the sum of the steps, however often the heading crosses +-180 deg."""
    headings = np.cumsum([first, *steps])
    wrapped = (headings + 180.0) % 360.0 - 180.0
    track = _track([(0.0, 0.0, float(h)) for h in wrapped])
    assert heading_change(track) == pytest.approx(sum(steps), abs=1e-6)


def test_heading_change_of_a_known_turn() -> None:
    assert heading_change(_track([(0, 0, 170.0), (0, 0, 179.0), (0, 0, -175.0)])) == pytest.approx(15.0)
    assert heading_change(_track([(0, 0, 10.0)])) == 0.0


def test_heading_change_stops_where_the_torso_stopped_being_upright() -> None:
    """A torso tipping over swings its forward axis: the turn is read up to the last upright state."""
    track = [
        TracePoint(0.04, 0, 0, 0.37, 0.99, 0.0),
        TracePoint(0.08, 0, 0, 0.37, 0.95, 5.0),
        TracePoint(0.12, 0, 0, 0.30, 0.70, 40.0),
        TracePoint(0.16, 0, 0, 0.20, 0.50, 80.0),
    ]
    assert heading_change(track) == pytest.approx(5.0)
    assert heading_change(track, upright_up_z=0.4) == pytest.approx(80.0)
    assert heading_change([TracePoint(0.04, 0, 0, 0.1, 0.1, 0.0), TracePoint(0.08, 0, 0, 0.1, 0.1, 30.0)]) == 0.0


def test_sideways_drift_is_to_the_left_of_the_start_line() -> None:
    # facing +y: +x is to the right
    assert sideways_drift(_track([(1.0, 1.0, 90.0), (1.5, 3.0, 90.0)]), 90.0) == pytest.approx(-0.5)
    assert sideways_drift(_track([(-5.0, 0.0, 0.0), (3.0, 0.4, 0.0)]), 0.0) == pytest.approx(0.4)


# ----- over a set -----


def _walk(distance: float, fell: bool = False, turn: float = 0.0, status: str = "ok") -> Walk:
    return Walk(distance, fell, 1.0 if fell else 15.0, 0.0, turn, status)


def _gait(name: str) -> FidelityGait:
    return FidelityGait(name, "test", tuple(float(v) for v in load_gait().as_array()))


def _comparisons() -> list[GaitComparison]:
    """Five gaits with known figures: a (walks on both, 10% short), b (walks on both, 30% long, turns
    20 deg where real turns 4), c (real falls in 2 of 3, the stand-in stands), d (both fall),
    e (the stand-in's walk could not be run: left out)."""
    return [
        _pair("a", (_walk(9.0),), (_walk(9.5), _walk(10.0), _walk(10.5))),
        _pair("b", (_walk(5.2, turn=20.0),), (_walk(4.0, turn=4.0), _walk(4.0, turn=-4.0), _walk(4.0, turn=4.0))),
        _pair("c", (_walk(2.0),), (_walk(1.0, True), _walk(1.0, True), _walk(4.0))),
        _pair("d", (_walk(0.1, True),), (_walk(0.2, True), _walk(0.3, True), _walk(0.1, True))),
        _pair("e", (_walk(0.0, status="failed"),), (_walk(8.0),)),
    ]


def _pair(name: str, stand_in: tuple[Walk, ...], real: tuple[Walk, ...]) -> GaitComparison:
    return GaitComparison(_gait(name), Draws(stand_in), Draws(real))


def test_summary_of_known_comparisons() -> None:
    s = summarize(_comparisons())
    assert s.gaits == 4
    # stand-in 9, 5.2, 2, 0.1 against real means 10, 4, 2, 0.2: the same order
    assert s.spearman == pytest.approx(1.0)
    assert s.fall_agreement == pytest.approx(0.75)  # c: real fell in the majority, the stand-in did not
    assert s.walking_gaits == 2  # a and b (c fell on the real server, d too)
    assert s.median_ratio_error == pytest.approx((0.1 + 0.3) / 2)
    assert s.worst_ratio_error == pytest.approx(0.3)
    assert s.median_turn_factor == pytest.approx((1.0 + 4.0) / 2)  # a straight on both; b 20 vs max(4, 5)
    assert s.worst_turn_factor == pytest.approx(4.0)
    assert s.real_fall_fraction == pytest.approx(5 / 12)
    misses = " ".join(s.misses(FidelityTargets()))
    assert "Spearman" not in misses and "fall agreement 0.750" in misses
    assert "median |1-ratio| 0.200" in misses and "worst |1-ratio| 0.300" in misses and "heading" in misses
    a, b, _, d, _ = _comparisons()
    assert (
        summarize([a, b, d]).misses(FidelityTargets(median_ratio_error=0.25, worst_ratio_error=0.35, turn_factor=4.0))
        == []
    )
    assert summarize([a, b]).misses(
        FidelityTargets(median_ratio_error=0.25, worst_ratio_error=0.35, turn_factor=4.0)
    ) == ["Spearman - (target >= 0.9)"]


def test_a_real_walk_that_could_not_be_run_is_left_out() -> None:
    c = _pair("x", (_walk(3.0),), (_walk(3.0), _walk(0.0, status="failed"), _walk(3.3)))
    assert len(c.real.ran) == 2 and c.real.mean("distance") == pytest.approx(3.15)
    assert c.walks_on_real(FidelityTargets())


def test_several_stand_in_walks_are_judged_as_the_real_ones_are() -> None:
    """Both servers by their walks: mean distance, fall by majority, turn as the median |heading
    change| (walks turning +21, -20 and -10 deg turn 20 deg typically, not -3 deg on average)."""
    stand_in = (_walk(6.0, turn=21.0), _walk(2.0, True, turn=-20.0), _walk(7.0, turn=-10.0))
    real = (_walk(6.5, turn=15.0), _walk(6.5, turn=25.0))
    c = _pair("x", stand_in, real)
    assert c.stand_in.mean("distance") == pytest.approx(5.0) and not c.stand_in.fell and c.stand_in.falls == 1
    assert c.stand_in.turn == pytest.approx(20.0) and c.real.turn == pytest.approx(20.0)
    assert c.ratio() == pytest.approx(5.0 / 6.5) and c.turn_factor(FidelityTargets()) == pytest.approx(1.0)
    assert Draws(stand_in[1:2]).fell
    row = c.row(FidelityTargets())
    assert (row["stand_walks"], row["stand_falls"], row["stand_min_m"], row["stand_max_m"]) == (3, 1, 2.0, 7.0)
    assert row["stand_fall_time_s"] == pytest.approx(1.0) and row["real_fall_time_s"] is None


def test_turns_tested_as_spreads_and_the_real_servers_own_disagreement() -> None:
    apart = _pair(
        "apart",
        tuple(_walk(5.0, turn=t) for t in (30, -31, 32, 33, -34)),
        tuple(_walk(5.0, turn=t) for t in (1, 2, 3, 4, 5)),
    )
    alike = _pair(
        "alike",
        tuple(_walk(5.0, turn=t) for t in (10, -40, 12, 35)),
        tuple(_walk(5.0, turn=t) for t in (-11, 38, 9, 41)),
    )
    assert fidelity.turn_test(apart.stand_in, apart.real) == pytest.approx(2 / 252)  # complete separation, 5 v 5
    assert fidelity.turn_test(alike.stand_in, alike.real) > 0.5
    assert fidelity.turn_test(Draws(apart.stand_in.walks[:2]), apart.real) is None  # too few walks to test
    # even-numbered real walks turn 11 and 9 deg (median 10), odd ones 38 and 41 (39.5): 3.95x apart
    assert fidelity.self_turn_factor(alike.real, slack=5.0) == pytest.approx(3.95)
    assert fidelity.self_turn_factor(Draws(alike.real.walks[:1]), slack=5.0) is None
    s = summarize([apart, alike])
    assert (s.turn_gaits_tested, s.turn_gaits_differing) == (2, 1)  # apart: p 2/252, 0.016 after Holm over 2
    assert s.real_self_worst_turn_factor == pytest.approx(3.95)
    # every walk of both gaits: stand-in 10, 12, 30-35, 40 -> median 32; real 1-5, 9, 11, 38, 41 -> 5
    assert s.stand_pooled_turn == pytest.approx(32.0) and s.real_pooled_turn == pytest.approx(5.0)


def test_more_stand_in_walks_need_a_dither() -> None:
    with pytest.raises(ValueError, match="command_noise"):
        FidelityConfig(stand_in_repeats=3)
    config = FidelityConfig(stand_in_repeats=3, command_noise=0.001)
    assert config.episode_config().command_noise == 0.001


def test_output_files(tmp_path: Path) -> None:
    comparisons = _comparisons()
    for c in comparisons:  # give walks a track to write
        object.__setattr__(c.stand_in.walks[0], "track", tuple(_track([(-5.0, 0.0, 0.0), (-4.0, 0.1, 2.0)])))
    summary = summarize(comparisons)
    config = FidelityConfig(real_repeats=3)
    fidelity.write_csv(comparisons, tmp_path / "f.csv")
    fidelity.plot(comparisons, tmp_path / "f.png", summary)
    fidelity.write_tracks(comparisons, summary, config, tmp_path / "f.json", {"set": "test"})
    rows = list(csv.DictReader((tmp_path / "f.csv").open()))
    assert [r["gait"] for r in rows] == ["a", "b", "c", "d", "e"] and tuple(rows[0]) == CSV_COLUMNS
    assert float(rows[0]["real_mean_m"]) == pytest.approx(10.0) and rows[2]["real_fell"] == "True"
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"
    document = json.loads((tmp_path / "f.json").read_text())
    assert document["summary"]["gaits"] == 4 and document["set"] == "test"
    assert document["gaits"][0]["stand_in"][0]["track"][1] == [0.08, -4.0, 0.1, 0.37, 0.99, 2.0]
    again, stored = fidelity.read_run(tmp_path / "f.json")
    assert stored["real_repeats"] == 3 and [c.gait for c in again] == [c.gait for c in comparisons]

    def firsts(cs: list[GaitComparison]) -> list[tuple]:
        return [(c.stand_in.walks[0].distance, c.stand_in.walks[0].fell, c.real) for c in cs]

    assert firsts(again) == firsts(comparisons)  # real walks: no track, as stored
    # the stand-in's turn and drift are taken again from its track: 0 -> 2 deg, 0.1 m to the left
    walk = again[1].stand_in.walks[0]
    assert walk.heading_change == pytest.approx(2.0) and walk.drift == pytest.approx(0.1)
    # a run stored before several stand-in walks (format 1: the one walk on its own) reads as one walk
    for item in document["gaits"]:
        item["stand_in"] = item["stand_in"][0]
    (tmp_path / "old.json").write_text(json.dumps(document))
    old, _ = fidelity.read_run(tmp_path / "old.json")
    assert firsts(old) == firsts(again) and all(len(c.stand_in.walks) == 1 for c in old)
    report = fidelity.report(comparisons, summary)
    assert "Spearman rank correlation of the distances: 1.000" in report and "targets missed" in report


# ----- the stored gait sets -----


def test_the_gait_sets_load_and_are_valid_gaits_inside_the_box() -> None:
    training, held = fidelity.gait_set("training"), fidelity.gait_set("held_aside")
    everything = training + held
    assert 40 <= len(everything) <= 60
    assert 0.55 <= len(training) / len(everything) <= 0.75
    names = [g.name for g in everything]
    assert len(set(names)) == len(names)
    assert {g.family for g in everything} == {"line", "neighbour", "random", "found", "turning"}
    for family in {g.family for g in everything}:  # each family on both sides of the split
        assert any(g.family == family for g in training) and any(g.family == family for g in held), family
    for g in everything:
        genes = np.asarray(g.genes)
        assert np.all(genes >= GENE_BOUNDS[:, 0]) and np.all(genes <= GENE_BOUNDS[:, 1]), g.name
        assert np.allclose(repair_genes(genes), genes, atol=1e-3), g.name
        assert g.params.period > g.params.t2 > 0 and g.how and g.screen
    assert tuple(FAST_REAL) in {g.genes for g in everything}
    assert tuple(np.round(load_gait().as_array(), 4)) in {g.genes for g in everything}
    assert fidelity.gait_set("all") == everything


def test_a_set_file_must_say_its_format(tmp_path: Path) -> None:
    bad = tmp_path / "x.json"
    bad.write_text(json.dumps({"format": "something-else", "gaits": []}))
    with pytest.raises(ValueError, match="fidelity-gaits"):
        fidelity.load_gait_set(bad)
    with pytest.raises(ValueError, match="unknown gait set"):
        fidelity.gait_set("tuning")
    item = {"name": "x", "family": "f", "params": dict(zip(GENE_NAMES, [15, 30, 10, 10, 20, 0.5, 15.708]))}
    with pytest.raises(ValueError, match="t2"):  # t2 beyond the period (0.4 s): eq. 5
        FidelityGait.from_dict(item)


# ----- the trace the benchmark reads -----


def test_the_episode_trace_is_what_the_judge_scored() -> None:
    config = EpisodeConfig(walk_time=1.0, start=(-6.0, 1.0), heading=30.0)
    with EpisodeRunner(config, trace=True) as runner:
        result = runner.evaluate(load_gait())
        track = runner.last_trace
    assert result.status == "ok" and track
    first, last = track[0], track[-1]
    h = math.radians(30.0)
    assert (last.x - first.x) * math.cos(h) + (last.y - first.y) * math.sin(h) == pytest.approx(result.distance)
    assert abs(first.heading - 30.0) < 5.0 and 0.3 < first.z < 0.45 and first.up_z > 0.9
    assert all(b.game_time > a.game_time for a, b in zip(track, track[1:]))
    assert last.game_time >= 1.0 - 1e-6


def test_no_trace_unless_asked() -> None:
    with EpisodeRunner(EpisodeConfig(walk_time=0.2)) as runner:
        assert runner.evaluate(load_gait()).status == "ok"
        assert runner.last_trace is None
    with EpisodeRunner(EpisodeConfig(walk_time=0.2)) as runner, pytest.raises(ValueError, match="trace=True"):
        fidelity.walk_gaits(runner, [_gait("a")], 1)


def test_the_fast_real_walk_walks_on_the_stand_in() -> None:
    """Issue 15: the gait walking 13.4 m in 15 s on the real server (``FAST_REAL``) walks >= 11 m on
    the stand-in without falling (measured: 13.06 m; it fell within 0.5 s on the Bullet-solved one)."""
    with EpisodeRunner(EpisodeConfig()) as runner:
        result = runner.evaluate(FAST_REAL)
    assert result.status == "ok" and not result.fell and result.distance >= 11.0


# ----- a small gate on a real server -----

#: A fixed subset spanning the families: the shipped gait, the line's middle, the fast real walk,
#: a stand-in find that falls on the real server, a fast walk of the GALA row on real servers.
GATE_GAITS = ("line-00", "line-05", "line-10", "found-stub0", "centre-realrun0")
#: Walks per gait on each server, walk k with seed k of a 0.001 rad/s command dither: a walk is one
#: draw of a chaotic process, so each server is judged by its draws (``bench.fidelity``).
#: A gait's median turn and fall verdict need about 20 of them to settle. With 10, centre-realrun0
#: (a coin-flip gait: it fell in 6 of 20 walks on the stand-in, 9 of 20 on the real server)
#: fell in 2 of the stand-in's first 10 and 6 of the real server's, and the real server's median
#: turns over walks 0-4 and 5-9 were up to 4x apart. 20 walks a server: about 1 min.
GATE_WALKS = 20


@pytest.fixture(scope="module")
def gate(rcssserver3d: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("fidelity")
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "bench.bench_fidelity",
            "--set",
            "all",
            "--gaits",
            ",".join(GATE_GAITS),
            "--real-repeats",
            str(GATE_WALKS),
            "--stand-in-repeats",
            str(GATE_WALKS),
            "--command-noise",
            "0.001",
            "--out",
            str(out),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "RCSSSERVER3D": rcssserver3d},
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Spearman rank correlation of the distances" in done.stdout
    return out


@pytest.mark.real_server
@pytest.mark.slow
def test_the_gate_runs_end_to_end_and_writes_its_files(gate: Path) -> None:
    rows = list(csv.DictReader((gate / "fidelity.csv").open()))
    assert sorted(r["gait"] for r in rows) == sorted(GATE_GAITS)
    by_name = {r["gait"]: r for r in rows}
    # the shipped gait walks 2.6-3.2 m on the real server (README), the fast one ~13.3 m
    assert 2.3 < float(by_name["line-00"]["real_mean_m"]) < 3.6
    assert 11.0 < float(by_name["line-10"]["real_mean_m"]) < 14.5
    assert (gate / "fidelity.png").stat().st_size > 10_000
    document = json.loads((gate / "fidelity.json").read_text())
    for item in document["gaits"]:
        assert len(item["stand_in"]) == len(item["real"]) == GATE_WALKS
        assert all(walk["track"] for walk in item["stand_in"] + item["real"])
        assert item["real"][0]["track"][-1][0] == pytest.approx(item["real"][0]["time"], abs=0.05)
    assert document["command_noise"] == 0.001 and document["stand_in_repeats"] == GATE_WALKS


@pytest.mark.real_server
@pytest.mark.slow
def test_the_gate_meets_the_issue_targets_for_distance_and_falls(gate: Path) -> None:
    """Issue 15's targets on the gate's gaits, each server by its 20 dithered walks. Measured on all
    50 gaits, 20 walks each (default physics): Spearman 0.996, fall agreement 0.98, |1-ratio| median
    0.013, worst 0.038. The fast real walk: none of its dithered walks falls on either server and
    they go a median 13.0 m (the stand-in's 20: 10.6-13.5 m, the real server's 12.1-13.5 m); its
    undithered walk is checked on the stand-in alone (``test_the_fast_real_walk_walks_on_the_stand_in``)."""
    summary = json.loads((gate / "fidelity.json").read_text())["summary"]
    targets = FidelityTargets()
    assert summary["spearman"] is not None and summary["spearman"] >= targets.spearman
    assert summary["fall_agreement"] >= targets.fall_agreement
    assert summary["median_ratio_error"] is not None and summary["median_ratio_error"] <= targets.median_ratio_error
    assert summary["worst_ratio_error"] <= targets.worst_ratio_error
    by_name = {item["name"]: item for item in json.loads((gate / "fidelity.json").read_text())["gaits"]}
    fast = by_name["line-10"]["stand_in"]  # the 13.4 m real walk of the fidelity sets
    assert not any(walk["fell"] for walk in fast)
    assert float(np.median([walk["distance"] for walk in fast])) >= 11.0


@pytest.mark.real_server
@pytest.mark.slow
def test_the_gate_finds_no_gait_turning_differently_on_the_stand_in(gate: Path) -> None:
    """Turning, as the two servers' spreads: no walking gait's |heading change| over its walks
    differs from the real server's (Mann-Whitney, Holm-corrected, 5%). A stand-in whose feet
    twist on the ground (every walk turning tens of degrees where the real ones keep straight)
    fails this; a walk's own chaos does not."""
    summary = json.loads((gate / "fidelity.json").read_text())["summary"]
    assert summary["turn_gaits_tested"] >= 2
    assert summary["turn_gaits_differing"] == 0


@pytest.mark.real_server
@pytest.mark.slow
def test_the_gate_meets_the_issue_target_for_turning(gate: Path) -> None:
    """Each walking gait's turn (the median |heading change| of its 20 walks) within 2x of the real
    server's (5 deg of slack). Over all 50 gaits with 20 walks each: median 1.27x, worst 1.81x; the
    real server's even-numbered walks against its odd-numbered ones: 1.32x, worst 2.47x."""
    summary = json.loads((gate / "fidelity.json").read_text())["summary"]
    assert summary["turn_gaits_tested"] >= 2
    assert summary["worst_turn_factor"] <= FidelityTargets().turn_factor
