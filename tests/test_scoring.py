"""Where an episode is scored (``optimizer.episode.scoring``): eq. 9 from monitor states alone."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.episode import EpisodeConfig, Judge
from protocol.monitor import MonitorState, RobotPose


def _state(
    t: float,
    x: float,
    y: float,
    z: float = 0.38,
    up_z: float = 1.0,
    mode: str = "PlayOn",
    team: str = "left",
    unum: int = 1,
) -> MonitorState:
    up = (math.sqrt(max(0.0, 1 - up_z**2)), 0.0, up_z)
    robot = RobotPose(team, unum, 0, (x, y, z), up, (1.0, 0.0, 0.0))
    return MonitorState(t, mode, 1, 0, 0, "GALA", None, [robot])


def test_the_distance_counts_from_where_the_walk_began_along_the_heading() -> None:
    judge = Judge(EpisodeConfig(walk_time=1.0, start=(-5.0, 0.0), heading=90.0))
    judge.feed(_state(0.0, -5.0, 0.0, mode="BeforeKickOff"))  # before the walk: not counted
    judge.feed(_state(0.02, -4.9, 0.1))  # the first PlayOn state: the origin
    judge.feed(_state(0.5, -3.0, 0.6))
    assert judge.result is None
    judge.feed(_state(1.0, -2.0, 1.1))
    assert judge.result is not None
    assert judge.result.distance == pytest.approx(1.0)  # along +y only, from y = 0.1
    assert judge.result.fitness == pytest.approx(10.0) and not judge.result.fell
    assert judge.result.time == 1.0 and judge.result.mean_speed == pytest.approx(1.0)
    judge.feed(_state(1.5, 0.0, 5.0))  # after the end: ignored
    assert judge.result.distance == pytest.approx(1.0)


@pytest.mark.parametrize("z, up_z", [(0.24, 1.0), (0.38, 0.59)])
def test_a_fall_ends_the_episode_where_it_happens(z: float, up_z: float) -> None:
    judge = Judge(EpisodeConfig(walk_time=15.0))
    judge.feed(_state(0.02, -5.0, 0.0))
    judge.feed(_state(0.50, -4.8, 0.0))
    judge.feed(_state(0.54, -4.7, 0.0, z=z, up_z=up_z))
    assert judge.result is not None and judge.result.fell and judge.result.time == 0.54
    assert judge.result.distance == pytest.approx(0.3)


def test_other_robots_and_a_robot_without_a_team_are_not_judged() -> None:
    judge = Judge(EpisodeConfig(walk_time=0.1))
    judge.feed(_state(0.02, 0.0, 0.0, team="right"))
    judge.feed(_state(0.04, 0.0, 0.0, unum=2))
    judge.feed(_state(0.2, 0.0, 0.0, team=None))  # type: ignore[arg-type]
    assert judge.result is None


@settings(deadline=None)  # no timing in it: a busy machine must not fail it
@given(st.floats(-10, 10), st.floats(-10, 10), st.floats(-180, 180), st.floats(0.1, 5.0))
def test_a_walk_straight_along_the_heading_scores_its_length(x: float, y: float, heading: float, length: float) -> None:
    h = math.radians(heading)
    judge = Judge(EpisodeConfig(walk_time=2.0, heading=heading), trace=True)
    judge.feed(_state(0.02, x, y))
    judge.feed(_state(2.0, x + length * math.cos(h), y + length * math.sin(h)))
    assert judge.result is not None and judge.result.distance == pytest.approx(length, abs=1e-9)
    assert judge.trace is not None and len(judge.trace) == 2 and judge.trace[0].x == x
