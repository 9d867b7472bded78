"""``say`` and ``hear`` as rcssserver3d 0.7.3 relays them (docs/robot_and_server.md section 8):
the stand-in's rules one by one, in process, and the ``say`` scenario recorded on the real server
(``tests/data/referee/say.json``, ``python -m bench.record_referee --only say``) played again on the
stand-in over its sockets: the same lines, at the same cycles, from the same directions."""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest

from bench import record_referee
from protocol.nao import LAYOUT
from protocol.perception import parse_perception
from server_stub.agent_state import AgentState
from server_stub.config import ServerConfig
from server_stub.sensors.perception_text import GameStateText, format_hear, format_perception
from server_stub.sensors.sensing import hear_direction, within_hearing
from server_stub.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]

RECORDED = json.loads((ROOT / "tests" / "data" / "referee" / "say.json").read_text())
_SAY = next(s for s in record_referee.SCENARIOS if s.name == "say")
#: The real server's game clock starts one cycle earlier or later from run to run (the trainer's
#: ``PlayOn`` races its cycle: the recorder's docstring), so a hear line's time within one cycle.
TIME_TOLERANCE = 0.02 + 1e-6
#: Directions are printed with 2 decimals; float noise in the geometry may move the last one.
DIRECTION_TOLERANCE = 0.01 + 1e-6
#: (team, unum, where it stands: x, y, facing deg) of the in-process robots.
_LEFT_1, _LEFT_2, _RIGHT_1 = ("Ref", 1, (-3.0, 0.0, 0.0)), ("Ref", 2, (-5.0, 3.0, 0.0)), ("Opp", 1, (4.0, 2.0, 0.0))


def _ignore(problem: str, key: str) -> None:
    """A ``warn`` for commands the test expects to be applied."""


@pytest.fixture
def sim() -> Iterator[Simulation]:
    simulation = Simulation(ServerConfig(sync=True, realtime=False, beam_noise=False, vision_noise=False))
    yield simulation
    simulation.close()


def _robots(sim: Simulation, *players: tuple[str, int, tuple[float, float, float]]) -> list[AgentState]:
    """Robots with a team, put by the trainer where ``players`` say (field coordinates, upright)."""
    states = [sim.join() for _ in players]
    for state in states:
        sim.apply_frame(state, b"(scene rsg/agent/nao/nao.rsg)", _ignore)
    sim.step()
    for state, (team, unum, _) in zip(states, players):
        sim.apply_frame(state, f"(init (unum {unum})(teamname {team}))".encode(), _ignore)
    sim.step()
    for state, (_, unum, (x, y, facing)) in zip(states, players):
        assert state.side is not None
        sim.place_agent(state.side, unum, (x, y, 0.4), facing)
    return states


def _cycle(sim: Simulation, states: list[AgentState], said: Mapping[int, str]) -> list[list[tuple]]:
    """One cycle: the robots' ``say`` (by index), the step, then every robot's perception (as the
    server makes one for each, every cycle); what each heard as (team, time, from, message)."""
    for index, message in said.items():
        sim.apply_frame(states[index], f"(say {message})".encode(), _ignore)
    sim.step()
    perceptions = [parse_perception(sim.perception(state, False)) for state in states]
    return [[(h.team, h.time, h.direction, h.message) for h in p.hear] for p in perceptions]


# ----- where and when -----


def test_hear_comes_right_after_gs_with_the_game_time(sim: Simulation) -> None:
    """Before kick-off the game clock stands at 0 while the server's runs on: ``hear`` carries the
    game's, and sits between ``GS`` and ``GYR`` (HearPerceptor hangs under the AgentState)."""
    (state,) = _robots(sim, _LEFT_1)
    sim.apply_frame(state, b"(say hi)", _ignore)
    sim.step()
    text = sim.perception(state, False)
    assert "(pm BeforeKickOff))(hear Ref 0.00 self hi)(GYR" in text
    assert parse_perception(text).time > 0.0


def test_hear_is_the_only_difference_a_message_makes() -> None:
    joints = {name: 0.0 for block in LAYOUT.blocks for name in block}
    gs = GameStateText(0, 0, 1.0, "PlayOn")
    quiet = format_perception(2.0, gs, (0.0, 0.0, 0.0), (0.0, 0.0, 9.81), joints, {})
    loud = format_perception(
        2.0, gs, (0.0, 0.0, 0.0), (0.0, 0.0, 9.81), joints, {}, hear=[format_hear("A", 1.0, 5, "x")]
    )
    assert "(hear" not in quiet and loud == quiet.replace("(pm PlayOn))", "(pm PlayOn))(hear A 1.00 5.00 x)", 1)


def _directions(heard: list[tuple]) -> list[float]:
    return [float(direction) for _, _, direction, _ in heard]


def test_the_direction_is_in_the_listeners_field_frame_not_its_heading(sim: Simulation) -> None:
    """From (-3, 0) to (-5, 3): 123.69 deg whichever way the listener faces; a right-team listener
    at field (4, 2) hears (-5, 3) at -6.34, its field turned half round."""
    states = _robots(sim, _LEFT_1, _LEFT_2, _RIGHT_1)
    before = _cycle(sim, states, {1: "two"})
    sim.place_agent("left", 1, (-3.0, 0.0, 0.4), 90.0)
    _cycle(sim, states, {})  # the teammates' capacity back
    turned = _cycle(sim, states, {1: "again"})
    assert _directions(before[0]) == _directions(turned[0]) == [pytest.approx(123.69, abs=0.01)]
    assert _directions(before[2]) == [pytest.approx(-6.34, abs=0.01)]
    assert hear_direction((4.0, 2.0, 0.4), (-3.0, 0.0, 0.4), "right") == pytest.approx(15.945, abs=0.001)
    assert hear_direction((4.0, 2.0, 0.4), (-3.0, 0.0, 0.4), "left") == pytest.approx(15.945 - 180.0, abs=0.001)


# ----- who hears what -----


def test_hearing_reaches_less_than_50_m_in_3d() -> None:
    assert within_hearing((0.0, 0.0, 0.0), (49.99, 0.0, 0.0), 50.0)
    assert not within_hearing((0.0, 0.0, 0.0), (50.0, 0.0, 0.0), 50.0)
    assert not within_hearing((0.0, 0.0, 0.0), (40.0, 0.0, 30.1), 50.0)  # 40 m apart on the ground


def test_a_robot_out_of_range_hears_nothing_but_the_speaker_hears_itself(sim: Simulation) -> None:
    states = _robots(sim, ("Ref", 1, (-22.0, -22.0, 0.0)), ("Opp", 1, (22.0, 22.0, 0.0)))
    assert _cycle(sim, states, {0: "far"}) == [[("Ref", 0.0, "self", "far")], []]


def test_one_message_of_each_kind_then_none_of_that_kind_next_cycle(sim: Simulation) -> None:
    """A teammate speaking every cycle is heard every other cycle; an opponent's message gets
    through in the cycle the teammates' is lost; a robot hears its own every time."""
    states = _robots(sim, _LEFT_1, _LEFT_2, _RIGHT_1)
    heard = [_cycle(sim, states, {0: f"m{k}", **({2: "o"} if k == 1 else {})}) for k in range(4)]
    assert [[h[3] for h in cycle[1]] for cycle in heard] == [["m0"], ["o"], ["m2"], []]
    assert [[h[3] for h in cycle[0]] for cycle in heard] == [["m0"], ["m1", "o"], ["m2"], ["m3"]]


def test_of_two_teammates_speaking_at_once_an_opponent_hears_the_first(sim: Simulation) -> None:
    """(The real server takes them in the order of its clients' addresses, which varies from run
    to run: recorded, one of the two, never both.)"""
    states = _robots(sim, _LEFT_1, _LEFT_2, _RIGHT_1)
    heard = _cycle(sim, states, {0: "first", 1: "second"})
    assert [h[3] for h in heard[2]] == ["first"]
    assert [h[3] for h in heard[0]] == ["first", "second"]


def test_a_message_over_20_characters_is_heard_by_nobody(sim: Simulation) -> None:
    states = _robots(sim, _LEFT_1, _LEFT_2)
    assert _cycle(sim, states, {0: "twenty_one_characters"}) == [[], []]
    assert [h[3] for h in _cycle(sim, states, {0: "exactly_twenty_chars"})[1]] == ["exactly_twenty_chars"]


def test_a_say_of_several_words_is_heard_as_its_first_word(sim: Simulation) -> None:
    """As the real server relays ``(say a b)`` (a probe heard ``hear B 0.00 self a``)."""
    states = _robots(sim, _LEFT_1, _LEFT_2)
    assert [[h[3] for h in heard] for heard in _cycle(sim, states, {0: "first second"})] == [["first"], ["first"]]


def test_say_before_init_is_refused(sim: Simulation) -> None:
    state = sim.join()
    sim.apply_frame(state, b"(scene rsg/agent/nao/nao.rsg)", _ignore)
    problems: list[str] = []
    sim.apply_frame(state, b"(say hi)", lambda problem, key: problems.append(problem))
    assert problems and "before scene and init" in problems[0]


# ----- the recording -----


def _said(heard: list[dict], only_self: bool = False) -> list[str]:
    return [h["said"] for h in heard if h["from"] == "self" or not only_self]


def test_the_recording_shows_each_rule() -> None:
    """What the real server did with the scenario's messages, so that a new recording that
    differs in a rule fails here."""
    ref_1, ref_2, opp_1 = RECORDED["hear"]
    everything = {h["said"] for robot in RECORDED["hear"] for h in robot}
    assert "twenty_one_characters" not in everything and "exactly_twenty_chars" in everything
    # its own message every cycle; a teammate's every other cycle, an opponent's in between
    own = ["hello", "again", "onemore", "exactly_twenty_chars", "m50", "m51", "m52", "m53"]
    assert _said(ref_1, only_self=True) == own
    assert [s for s in _said(ref_2) if s in {"m50", "m51", "m52", "m53", "o51"}] == ["m50", "o51", "m52"]
    # 62 m and 52 m: not heard; 48.6 m: heard
    assert "far1" not in _said(opp_1) and "out52" not in _said(opp_1) and "in49" in _said(opp_1)
    assert "far2" not in _said(ref_2) and "far2" in _said(ref_1)
    # self, then the other team, in one perception
    three = next(h["cycle"] for h in opp_1 if h["said"] == "three")
    assert [(h["team"], h["from"]) for h in opp_1 if h["cycle"] == three] == [("Opp", "self"), ("Ref", "-6.34")]


def assert_same_hearing(real: dict, stand_in: dict) -> None:
    """Per robot the same lines (cycle, team, message) in the same order, ``self`` where the real
    server said it, directions within ``DIRECTION_TOLERANCE`` and times within a cycle."""
    table = f"real:\n{record_referee.table(real)}\nstand-in:\n{record_referee.table(stand_in)}"
    for theirs, ours in zip(real["hear"], stand_in["hear"], strict=True):
        assert [(h["cycle"], h["team"], h["said"]) for h in ours] == [
            (h["cycle"], h["team"], h["said"]) for h in theirs
        ], table
        for real_line, line in zip(theirs, ours):
            assert abs(line["t"] - real_line["t"]) <= TIME_TOLERANCE, table
            assert (line["from"] == "self") == (real_line["from"] == "self"), table
            if real_line["from"] != "self":
                assert abs(float(line["from"]) - float(real_line["from"])) <= DIRECTION_TOLERANCE, table


def _on_the_stand_in() -> dict:
    with record_referee.stand_in() as address:
        return record_referee.run(_SAY, address, record_referee.TRAINER_LEAD["stand-in"])


def test_the_stand_in_hears_as_the_real_server_did() -> None:
    assert_same_hearing(RECORDED, _on_the_stand_in())


@pytest.mark.real_server
def test_the_say_scenario_live_on_the_real_server_matches_the_stand_in(rcssserver3d: str) -> None:
    assert_same_hearing(record_referee.record(_SAY, rcssserver3d), _on_the_stand_in())
