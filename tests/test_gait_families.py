"""Gait families: every family's targets stay inside the joints' limits and its commands inside
the speed cap, tfs-plus with its additions at 0 is the TFS, tfs-start begun by its own gait is the
TFS and otherwise walks its start gait then blends into its cruise gait, gait files name their
family, and a search, an episode and an agent take any family."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_driver import FakeEvaluator

from agent.controller import joint_velocities
from gait import FAMILIES, TFS, TFS_PLUS, Gait, GaitFamily, family_named, load_gait, save_gait
from gait.nao_legs import LIMIT_MARGIN_DEG
from gait.tfs_plus import EXTRA_NAMES
from gait.tfs_start import BLEND, HOLD, TFS_START
from optimizer.cli import gala_command as gala_command
from optimizer.episode import EpisodeConfig, EpisodeRunner
from protocol.nao import JOINT_BY_EFFECTOR, JOINTS, SPEED_CAP

LIMITS = {j.effector: (j.min_deg, j.max_deg) for j in JOINTS}
times = st.floats(0.0, 30.0, allow_nan=False)


@st.composite
def gaits(draw: st.DrawFn, family: GaitFamily) -> Gait:
    """A gait anywhere in (and repaired into) the family's default box."""
    low, high = family.bounds[:, 0], family.bounds[:, 1]
    unit = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=len(low), max_size=len(low))))
    return family.gait(family.repair(low + unit * (high - low), family.bounds))


@pytest.mark.parametrize("family", list(FAMILIES.values()), ids=list(FAMILIES))
@settings(max_examples=60, deadline=None)
@given(data=st.data(), t=times)
def test_targets_stay_inside_the_limits_and_commands_inside_the_speed_cap(family: GaitFamily, data, t: float) -> None:
    gait = data.draw(gaits(family))
    targets = gait.walker().joint_targets(t, LIMITS)
    assert targets and set(targets) <= set(LIMITS)
    for name, value in targets.items():
        low, high = LIMITS[name]
        assert low + LIMIT_MARGIN_DEG - 1e-9 <= value <= high - LIMIT_MARGIN_DEG + 1e-9, name
    perceived = {JOINT_BY_EFFECTOR[name].perceptor: data.draw(st.floats(-120.0, 120.0)) for name in targets}
    assert all(abs(v) <= SPEED_CAP for v in joint_velocities(targets, perceived, gain=30.0).values())


@settings(max_examples=80, deadline=None)
@given(data=st.data(), t=times, phases=st.tuples(st.floats(0.0, 2 * math.pi), st.floats(0.0, 2 * math.pi)))
def test_tfs_plus_with_its_additions_at_zero_is_the_tfs(data, t: float, phases) -> None:
    tfs = data.draw(gaits(TFS))
    plus = TFS_PLUS.gait([*tfs.genes, 0.0, 0.0, phases[0], 0.0, phases[1], 0.0])
    expected = tfs.walker().joint_targets(t, LIMITS)
    got = plus.walker().joint_targets(t, LIMITS)
    assert {k: got[k] for k in expected} == expected
    # the joints only tfs-plus drives sit where the agent's posture holds them for the TFS
    assert {k: got[k] for k in set(got) - set(expected)} == {
        "lle2": 0.0,
        "rle2": 0.0,
        "lle6": 0.0,
        "rle6": 0.0,
        "lae1": -90.0,
        "rae1": -90.0,
    }


@settings(max_examples=80, deadline=None)
@given(data=st.data(), t=times)
def test_tfs_start_begun_by_its_own_gait_is_the_tfs(data, t: float) -> None:
    tfs = data.draw(gaits(TFS))
    started = TFS_START.from_gait(tfs)
    assert started.genes == tfs.genes + tfs.genes
    assert started.walker().joint_targets(t, LIMITS) == tfs.walker().joint_targets(t, LIMITS)


@settings(max_examples=60, deadline=None)
@given(data=st.data(), share=st.floats(0.0, 1.0))
def test_tfs_start_walks_its_start_gait_then_blends_into_its_cruise_gait(data, share: float) -> None:
    cruise, start = data.draw(gaits(TFS)), data.draw(gaits(TFS))
    walker = TFS_START.gait(cruise.genes + start.genes).walker()
    early = share * HOLD * 0.999
    assert walker.joint_targets(early, LIMITS) == start.walker().joint_targets(early, LIMITS)
    late = HOLD + BLEND + 10.0 * share
    assert walker.joint_targets(late, LIMITS) == cruise.walker().joint_targets(late, LIMITS)
    t = HOLD + share * BLEND * 0.999
    a, b = start.walker().joint_targets(t, LIMITS), cruise.walker().joint_targets(t, LIMITS)
    got = walker.joint_targets(t, LIMITS)
    for name in got:
        assert got[name] == pytest.approx(a[name] + share * 0.999 * (b[name] - a[name]), abs=1e-9)


def test_tfs_start_refuses_a_start_gait_no_robot_should_walk_by_name() -> None:
    base = (15.0, 30.0, 10.0, 10.0, 20.0, 0.35, 15.708)
    with pytest.raises(ValueError, match="c_k"):
        TFS_START.gait(base + (15.0, -5.0, 10.0, 10.0, 20.0, 0.35, 15.708))
    assert TFS_START.held == tuple(range(7, 14)) and TFS_START.gene_names[7:] == tuple(f"s_{n}" for n in TFS.gene_names)


def test_an_episode_walks_the_start_gait_for_its_first_second_then_the_cruise_gait() -> None:
    """On the stand-in: a tfs-start gait walks exactly as its start gait alone until the blend
    begins, and differently after it."""
    shipped = load_gait()
    cruise = list(shipped.genes)
    cruise[0] += 5.0  # c_h
    started = TFS_START.gait(tuple(cruise) + shipped.genes)
    with EpisodeRunner(EpisodeConfig(walk_time=HOLD - 0.1)) as runner:
        alone, begun = runner.evaluate(shipped), runner.evaluate(started)
    assert alone.status == begun.status == "ok"
    assert (begun.distance, begun.fell, begun.time) == (alone.distance, alone.fell, alone.time)
    with EpisodeRunner(EpisodeConfig(walk_time=HOLD + BLEND + 1.0)) as runner:
        alone, begun = runner.evaluate(shipped), runner.evaluate(started)
    assert begun.distance != alone.distance


@given(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=13, max_size=13))
def test_tfs_plus_repair_gives_a_valid_gait_inside_the_box(values: list[float]) -> None:
    genes = TFS_PLUS.repair(np.array(values), TFS_PLUS.bounds)
    assert np.all(genes >= TFS_PLUS.bounds[:, 0] - 1e-12) and np.all(genes <= TFS_PLUS.bounds[:, 1] + 1e-12)
    TFS_PLUS.gait(genes)  # raises if a rule is broken


def test_the_tfs_plus_additions_come_from_the_robot() -> None:
    box = dict(zip(TFS_PLUS.gene_names, TFS_PLUS.bounds))
    ankle, hip_roll, shoulder = (JOINT_BY_EFFECTOR[n] for n in ("lle5", "lle2", "lae1"))
    assert box["P"][1] == -ankle.min_deg and tuple(box["c_a"]) == (ankle.min_deg / 2, -ankle.min_deg / 2)
    assert box["S"][1] == -hip_roll.min_deg  # the left hip rolls 25 deg inwards (the right alike)
    assert tuple(box["R"]) == (-90.0, 90.0) and shoulder.min_deg < -90.0 - 0 < 0.0 < shoulder.max_deg
    assert np.array_equal(TFS_PLUS.bounds[: len(TFS.gene_names)], TFS.bounds)
    assert TFS_PLUS.gene_names[len(TFS.gene_names) :] == EXTRA_NAMES


def test_tfs_plus_genes_outside_the_box_are_refused_by_name() -> None:
    base = [15.0, 30.0, 10.0, 10.0, 20.0, 0.35, 15.708]
    with pytest.raises(ValueError, match=r"\bS\b"):
        TFS_PLUS.gait([*base, 0.0, 0.0, 0.0, 40.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="t2"):
        TFS_PLUS.gait([15.0, 30.0, 10.0, 10.0, 20.0, 0.9, 15.708, 0, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="13 genes"):
        TFS_PLUS.gait(base)
    with pytest.raises(ValueError, match="known: tfs, tfs-plus, tfs-start"):
        family_named("hexapod")


@pytest.mark.parametrize("family", list(FAMILIES.values()), ids=list(FAMILIES))
def test_a_gait_file_names_its_family_and_round_trips(family: GaitFamily, tmp_path: Path) -> None:
    low, high = family.bounds[:, 0], family.bounds[:, 1]
    gait = family.gait(family.repair(low + 0.37 * (high - low), family.bounds))
    path = save_gait(gait, tmp_path / "g.json", notes="round trip")
    document = json.loads(path.read_text())
    assert document["family"] == family.name and list(document["params"]) == list(family.gene_names)
    again = load_gait(path)
    assert again == gait and again.family is family


def test_an_episode_walks_a_tfs_plus_gait_and_its_zero_additions_walk_as_the_tfs() -> None:
    """On the stand-in (direct), over one runner: the TFS gait and the same gait as tfs-plus with
    the additions at 0 walk the same walk; additions that are not 0 walk another."""
    shipped = load_gait()
    zero = TFS_PLUS.gait([*shipped.genes, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0])
    swaying = TFS_PLUS.gait([*shipped.genes, 5.0, 10.0, 1.0, 6.0, 2.0, 30.0])
    with EpisodeRunner(EpisodeConfig(walk_time=3.0)) as runner:
        tfs_walk, zero_walk, other = (runner.evaluate(g) for g in (shipped, zero, swaying))
    assert tfs_walk.status == zero_walk.status == other.status == "ok"
    assert (zero_walk.distance, zero_walk.fell, zero_walk.time) == (tfs_walk.distance, tfs_walk.fell, tfs_walk.time)
    assert other.distance != tfs_walk.distance


def test_an_agent_process_plays_a_tfs_plus_gait_file_over_a_socket() -> None:
    """``python -m agent --gait FILE`` (the runner's process mode writes the file and starts the
    agent) walks a tfs-plus gait on the stub over TCP. A separate process meets the server's
    cycles a little differently from one run step by step, so its walk is compared within 5 cm
    over 2 s; the plain TFS gait walks 18 cm further, so the additions were played."""
    tfs = load_gait()
    plus = TFS_PLUS.gait([*tfs.genes, 5.0, 10.0, 1.0, 6.0, 2.0, 30.0])
    with EpisodeRunner(EpisodeConfig(walk_time=2.0, agent_mode="process")) as runner:
        process_plus, process_tfs = runner.evaluate(plus), runner.evaluate(tfs)
    with EpisodeRunner(EpisodeConfig(walk_time=2.0, embedded_stub="socket")) as runner:
        socket_plus = runner.evaluate(plus)
    with EpisodeRunner(EpisodeConfig(walk_time=2.0)) as runner:
        direct_plus = runner.evaluate(plus)
    assert process_plus.status == process_tfs.status == "ok", process_plus.reason + process_tfs.reason
    assert (socket_plus.distance, socket_plus.fell) == (direct_plus.distance, direct_plus.fell)
    assert abs(process_plus.distance - direct_plus.distance) < 0.05
    assert process_tfs.distance - process_plus.distance > 0.1


def test_a_small_search_of_each_family_writes_gait_files_of_that_family(tmp_path: Path) -> None:
    argv = ["--crossover", "0.8", "--population", "6", "--iterations", "2", "--generations", "2", "--seed", "3"]
    argv += ["--quiet", "--check-repeats", "2", "--refine", "20"]
    for family in FAMILIES.values():
        out = tmp_path / family.name
        assert (
            gala_command.main(
                [*argv, "--family", family.name, "--refine-family", family.name, "--out", str(out)],
                make_evaluator=lambda s: FakeEvaluator(),
            )
            == 0
        )
        assert json.loads((out / "manifest.json").read_text())["settings"]["family"] == family.name
        for name in ("best_gait.json", "fastest_gait.json"):
            gait = load_gait(out / name)
            assert gait.family is family
            assert np.all(gait.as_array() >= family.bounds[:, 0]) and np.all(gait.as_array() <= family.bounds[:, 1])
        episodes = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
        assert {len(e["genes"]) for e in episodes} == {len(family.gene_names)}


def test_a_family_without_the_legacy_box_refuses_it(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        gala_command.main(["--family", "tfs-plus", "--bounds", "legacy", "--out", "/nonexistent/x"])
    assert exit_info.value.code == 2
    assert "--bounds legacy: the tfs-plus family has the boxes robot" in capsys.readouterr().err
