"""``server_stub.referee.fouls.IncapableRule`` cycle by cycle, on robots whose torso height the
test sets: the counts, their limits, the hold in the air and the place outside the field
(rcssserver3d 0.7.3's SoccerRuleAspect; the real server's own sequence is in
``tests/test_referee_scenarios.py``'s ``incapable`` recording)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from server_stub.agent_state import AgentState
from server_stub.config import RefereeConfig
from server_stub.referee.fouls import INCAPABLE, IncapableRule


class _Torso:
    """Stands in for a robot: a torso centre the test moves, and the referee's moves recorded."""

    def __init__(self, z: float, x: float = -3.0, y: float = 1.0) -> None:
        self.position = (x, y, z)
        self.moves: list[tuple[float, float, float]] = []

    def torso_position(self) -> tuple[float, float, float]:
        return self.position

    def place(self, x: float, y: float, z: float) -> None:
        self.position = (x, y, z)
        self.moves.append((x, y, z))


def _player(side: str, unum: int, torso: _Torso) -> AgentState:
    return AgentState(robot=torso, side=side, unum=unum)  # type: ignore[arg-type]


def _run(rule: IncapableRule, agents: list[AgentState], cycles: int, ball_y: float = 1.0) -> None:
    for _ in range(cycles):
        rule.update(agents, paused=False, ball_y=ball_y)


def test_a_field_player_on_the_ground_is_called_after_15_s_held_half_a_second_then_put_outside():
    rule = IncapableRule(RefereeConfig())
    torso = _Torso(z=0.1)
    agents = [_player("left", 3, torso)]
    _run(rule, agents, 750)  # 750 cycles on the ground: not yet past 15 s
    assert rule.fouls == [] and torso.moves == []
    _run(rule, agents, 1)
    assert [(f.kind, f.side, f.unum) for f in rule.fouls] == [(INCAPABLE, "left", 3)]
    assert torso.moves == [(-3.0, 1.0, pytest.approx(1.02))]
    _run(rule, agents, 24)  # held: 1 cm higher each cycle, a foul recorded each cycle
    assert [round(z, 2) for _, _, z in torso.moves] == [round(1.0 + 0.01 * k, 2) for k in range(2, 27)]
    _run(rule, agents, 1)  # then outside, on the side line away from the ball (y > 0), own half
    assert torso.moves[-1] == (pytest.approx(-0.6 * 4), -10.5, 0.4)
    assert len(rule.fouls) == 26 and [f.index for f in rule.fouls] == list(range(1, 27))
    torso.position = (*torso.position[:2], 0.05)  # lying outside the field: never counted
    _run(rule, agents, 2000)
    assert len(rule.fouls) == 26


def test_the_limits_by_role_and_posture():
    """Field player: 15 s on the ground or 30 s not standing; goalie: 30 s and 60 s. A torso
    between 0.15 and 0.25 m is not standing but not on the ground."""
    rule = IncapableRule(RefereeConfig())
    sitting, goalie_down, goalie_sitting = _Torso(0.2), _Torso(0.1), _Torso(0.2)
    agents = [_player("right", 5, sitting), _player("right", 1, goalie_down), _player("left", 1, goalie_sitting)]
    first_call: dict[tuple[str, int], int] = {}
    for cycle in range(1, 3100):
        rule.update(agents, paused=False, ball_y=-1.0)
        for foul in rule.fouls:
            first_call.setdefault((foul.side, foul.unum), cycle)
    assert first_call == {("right", 5): 1501, ("right", 1): 1501, ("left", 1): 3001}
    assert sitting.moves[-1] == (pytest.approx(0.6 * 2), 10.5, 0.4)  # the ball at y < 0: the other side


def test_half_a_second_standing_clears_the_not_standing_count_but_a_shorter_rise_does_not():
    rule = IncapableRule(RefereeConfig())
    torso = _Torso(0.2)
    agents = [_player("left", 4, torso)]
    _run(rule, agents, 1400)
    torso.position = (-3.0, 1.0, 0.3)
    _run(rule, agents, 25)  # 25 cycles up: not more than 0.5 s
    torso.position = (-3.0, 1.0, 0.2)
    _run(rule, agents, 101)
    assert rule.fouls, "the count went on after a rise of 0.5 s"
    rule = IncapableRule(RefereeConfig())
    torso = _Torso(0.2)
    agents = [_player("left", 4, torso)]
    _run(rule, agents, 1400)
    torso.position = (-3.0, 1.0, 0.3)
    _run(rule, agents, 26)
    torso.position = (-3.0, 1.0, 0.2)
    _run(rule, agents, 1500)
    assert rule.fouls == []


@given(
    paused_at=st.integers(min_value=0, max_value=740),
    y=st.floats(min_value=10.1, max_value=30.0),
)
def test_a_pause_or_lying_outside_the_field_restarts_or_stops_the_count(paused_at: int, y: float):
    rule = IncapableRule(RefereeConfig())
    inside, outside = _Torso(0.1), _Torso(0.1, y=y)
    agents = [_player("left", 2, inside), _player("right", 2, outside)]
    _run(rule, agents, paused_at)
    rule.update(agents, paused=True, ball_y=0.0)
    _run(rule, agents, 750)
    assert rule.fouls == []
    _run(rule, agents, 1)
    assert [(f.side, f.unum) for f in rule.fouls] == [("left", 2)]


def test_the_monitor_item_names_the_foul_as_simspark_does():
    rule = IncapableRule(RefereeConfig())
    agents = [_player("right", 7, _Torso(0.0))]
    _run(rule, agents, 751)
    assert rule.fouls[0].monitor_item() == "(foul 1 4 2 7)"


def test_counts_start_again_when_forgotten_as_when_the_field_empties():
    rule = IncapableRule(RefereeConfig())
    agents = [_player("left", 2, _Torso(0.1))]
    _run(rule, agents, 700)
    rule.forget()
    _run(rule, agents, 750)
    assert rule.fouls == []
    _run(rule, agents, 1)
    assert len(rule.fouls) == 1
