"""The real calibration walk (fixtures/rcssserver3d/walk_calibration) replayed on the stub."""
from __future__ import annotations

import json
import re

import pytest

from server_stub import calibration_walk
from server_stub.world import World

_HJ = re.compile(r"\(HJ \(n (\w+)\) \(ax ([-\d.]+)\)\)")
_COMMAND = re.compile(r"\(([a-z]+\d) ([-\d.]+)\)")


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


@pytest.mark.slow
def test_calibration_walk_goes_as_far_as_on_the_real_server(fixtures_dir):
    real = json.loads((fixtures_dir / "walk_calibration" / "summary.json").read_text())
    with World() as world:
        result = calibration_walk.run(world)
    assert not result.fell
    assert result.dx == pytest.approx(3.0, rel=0.15)  # real: 2.91-3.14 m
    worst_real_drift = max(abs(r["dy"]) for r in real)
    assert abs(result.dy) <= 2 * worst_real_drift
    # feet alternate about every 0.2 s as on the real server (75 single-support phases in 15 s)
    changes = sum(1 for a, b in zip(result.feet, result.feet[1:]) if len(a) == 1 and len(b) == 1 and a != b)
    assert changes > 0 or any(len(f) == 2 for f in result.feet)
