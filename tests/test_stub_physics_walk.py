"""The real calibration walk (tests/data/rcssserver3d/walk_calibration) replayed on the stub."""

from __future__ import annotations

import json
import re

import pytest

from server_stub.physics import calibration_walk
from server_stub.physics.world import World
from tests.conftest import FIXTURES

_HJ = re.compile(r"\(HJ \(n (\w+)\) \(ax ([-\d.]+)\)\)")
_COMMAND = re.compile(r"\(([a-z]+\d) ([-\d.]+)\)")
_FRP = re.compile(r"\(FRP \(n (\w+)\)")
#: "Sideways drift of the same order" (the fixtures' README): at most this times the real runs' largest.
_DRIFT_FACTOR = 1.5


def test_controller_reproduces_every_command_the_real_agent_sent(fixtures_dir):
    """Fed the real perceptions, our copy of the README's controller sends the real commands."""
    folder = fixtures_dir / "walk_calibration"
    perceptions = (folder / "run1_perceptions.txt").read_text().splitlines()
    commands = (folder / "run1_commands.txt").read_text().splitlines()
    first_hold, first_walk = 4, 4 + calibration_walk.HOLD_CYCLES  # 1-based command lines
    assert len(commands) == first_walk + calibration_walk.WALK_CYCLES - 1
    for line in range(first_hold, len(commands) + 1):
        perceived = {n: float(v) for n, v in _HJ.findall(perceptions[line - 2])}
        sent = {n: float(v) for n, v in _COMMAND.findall(commands[line - 1])}
        t = (line - first_walk) * 0.02 if line >= first_walk else 0.0
        ours = calibration_walk.velocities(t, perceived)
        assert {n: round(v, 4) for n, v in ours.items()} == pytest.approx(sent, abs=1e-9), line


def _single_support_phases(feet: list[frozenset[str]]) -> int:
    """How many times the one foot on the ground changes (FRP of exactly one foot)."""
    phases, last = 0, None
    for touching in feet:
        if len(touching) == 1 and touching != last:
            phases, last = phases + 1, touching
    return phases


def _real_summary(fixtures_dir) -> list[dict]:
    return json.loads((fixtures_dir / "walk_calibration" / "summary.json").read_text())


@pytest.mark.slow
def test_calibration_walk_goes_as_far_as_on_the_real_server(fixtures_dir):
    folder = fixtures_dir / "walk_calibration"
    real = _real_summary(fixtures_dir)
    with World() as world:
        result = calibration_walk.run(world)
    assert not result.fell
    assert result.dx == pytest.approx(3.0, rel=0.15)  # real: 2.91-3.14 m
    # Sideways drift of the same order as the real runs' (0.40-0.99 m): at most 1.5x the largest.
    # Over 72 perturbed starts ours has a median of 0.65 m (the real runs': 0.66 m) and reaches 1.62 m.
    assert abs(result.dy) <= _DRIFT_FACTOR * max(abs(r["dy"]) for r in real)
    # Feet alternate with the gait, about every 0.2 s: 75-76 single-support phases on the real server.
    real_phases = [
        _single_support_phases(
            [
                frozenset(_FRP.findall(line))
                for line in (folder / f"run{r['run']}_perceptions.txt")
                .read_text()
                .splitlines()[28 : 28 + calibration_walk.WALK_CYCLES]
            ]
        )
        for r in real
    ]
    assert min(real_phases) >= 70
    assert _single_support_phases(result.feet) == pytest.approx(sum(real_phases) / 3, abs=5)
    # Both feet report FRP in 11.6-12.0% of the real walk's cycles (a touching foot counts even
    # with no load on it); ours, without that rule, showed under 1%.
    real_double = [
        sum(
            len(set(_FRP.findall(line))) == 2
            for line in (folder / f"run{r['run']}_perceptions.txt")
            .read_text()
            .splitlines()[28 : 28 + calibration_walk.WALK_CYCLES]
        )
        / calibration_walk.WALK_CYCLES
        for r in real
    ]
    ours_double = sum(len(feet) == 2 for feet in result.feet) / len(result.feet)
    assert ours_double == pytest.approx(sum(real_double) / 3, abs=0.03)
    # The stance foot never leaves the ground: no cycle of the real walks lacks an FRP. Ours had
    # 8.9% such cycles until contacts got ODE's surface layer (a resting foot ended each step just
    # above the ground, so the next step found no contact and the robot dropped for a cycle).
    real_none = [
        sum(
            not _FRP.findall(line)
            for line in (folder / f"run{r['run']}_perceptions.txt")
            .read_text()
            .splitlines()[28 : 28 + calibration_walk.WALK_CYCLES]
        )
        for r in real
    ]
    assert real_none == [0, 0, 0]
    assert sum(not feet for feet in result.feet) / len(result.feet) <= 0.01
    # The torso rides at the real height while walking (monitor track, mean 0.377 m).
    real_z = [
        float(row.split("\t")[3])
        for r in real
        for row in (folder / f"run{r['run']}_torso_track.tsv").read_text().splitlines()[1:]
    ]
    ours = sum(p[2] for p in result.torso) / len(result.torso)
    assert ours == pytest.approx(sum(real_z) / len(real_z), abs=0.01)


def _real_probe() -> list[dict]:
    path = FIXTURES / "walk_calibration" / "probe_starts_real.json"
    return json.loads(path.read_text())["starts"]


@pytest.mark.slow
def test_calibration_walk_falls_or_walks_from_moved_starts_as_the_real_server_did():
    """72 small changes of the start (the repeated beam earlier, later or not at all, beams a step
    late, other places and headings, the first beam after 2-4 steps), walked on the real server
    too: it fell from 31, always in the first 1.5 s and by the start's timing, and walked the
    others 2.7-3.3 m. A stand-in that walks them all (as the Bullet-solved one did) tells the
    optimizer a start is safe where the real server punishes it. Target: fall agreement >= 90%
    (``tests/data/rcssserver3d``); where both walk, the stand-in's distance within 25% of the real one."""
    agree, ratios = 0, []
    for case in _real_probe():
        start = {**case["start"], "beam": tuple(case["start"]["beam"])}
        with World() as world:
            world.set_ball((0.0, 9.0, 0.042))  # out of the way of starts near the centre
            result = calibration_walk.run(world, **start)
        agree += result.fell == case["fell"]
        if not (result.fell or case["fell"]):
            ratios.append(result.dx / case["dx"])
    assert agree >= 0.9 * len(_real_probe())
    assert ratios and all(0.75 <= r <= 1.25 for r in ratios), ratios
