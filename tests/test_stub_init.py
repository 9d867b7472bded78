"""Where ``init`` puts a robot: the real server's InitEffector moves it to the next place of its
team's row along the side line (GameStateAspect::RequestInitPosition / RequestInitOrientation),
before any beam. Robots created together so stand apart, and before kick-off none stands in the
other half (where the referee would move them all onto one spot)."""

from __future__ import annotations

import itertools
import math

import pytest

from server_stub.config import ServerConfig
from server_stub.game import Game
from server_stub.simulation import Simulation


def test_init_places_follow_the_real_servers_rows() -> None:
    game = Game()
    left = [game.init_pose("left") for _ in range(40)]
    right = game.init_pose("right")
    # 2 agent radii (0.4 m) in from the corner, then 3 radii down the side line, facing the other goal
    assert left[0] == pytest.approx((-14.2, 9.2, 0.0), abs=1e-5)
    assert left[1] == pytest.approx((-14.2, 8.0, 0.0), abs=1e-5)
    assert right == pytest.approx((14.2, 9.2, 180.0), abs=1e-5)
    # past the other side line a new row starts 2 radii further along x
    rows = [list(group) for _, group in itertools.groupby(left, key=lambda pose: round(pose[0], 4))]
    assert [round(row[0][0], 4) for row in rows[:3]] == [-14.2, -13.4, -12.6]
    assert all(row[0][1] == pytest.approx(9.2, abs=1e-5) for row in rows)
    assert all(-10.0 <= y <= 9.2 + 1e-5 for _, y, _ in left)
    assert len(rows[0]) == len(rows[1]) >= 16


def _torsos(states) -> list[tuple[float, float, float]]:
    return [state.robot.torso_position() for state in states]


def test_a_team_created_at_once_stands_apart_until_it_beams() -> None:
    """22 robots asking for a body and a team in the same cycles (no beam): each stands at its init
    place, the right team in its own half, none on top of another; they would pile up on the
    referee's spot 2.5 m behind the centre line if init left them at the spawn point."""
    sim = Simulation(ServerConfig(sync=True, realtime=False, beam_noise=False))
    states = [sim.join() for _ in range(22)]
    for state in states:
        sim.apply_frame(state, b"(scene rsg/agent/nao/nao.rsg)", lambda problem, key: None)
    sim.step()
    for k, state in enumerate(states):
        team, unum = ("Left", k + 1) if k < 11 else ("Right", k - 10)
        sim.apply_frame(state, f"(init (unum {unum})(teamname {team}))".encode(), lambda problem, key: None)
    for _ in range(10):
        sim.step()
    torsos = _torsos(states)
    for (ax, ay, _), (bx, by, _) in itertools.combinations(torsos, 2):
        assert math.hypot(ax - bx, ay - by) > 1.0
    assert all(x < -13 for x, _, _ in torsos[:11]) and all(x > 13 for x, _, _ in torsos[11:])
    assert all(0.3 < z < 0.45 for *_, z in torsos)
    sim.close()


def test_a_side_whose_robots_all_left_starts_its_row_again() -> None:
    """So that an episode on a long-lived stand-in walks as on a fresh one (a resumed search gives
    the same scores): the lone walker of every episode stands at the first place before its beam."""
    game = Game()
    for unum in (1, 2):
        game.join("Walker", unum)
    first, second = game.init_pose("left"), game.init_pose("left")
    game.leave("left", 1)
    assert game.init_pose("left") != first  # a robot of the side is still there
    game.leave("left", 2)
    game.join("Other", 1)
    assert game.init_pose("left") == first and second != first
