"""Monitor stream reader against the real captures."""

from __future__ import annotations

from pathlib import Path

import pytest

from protocol.errors import ProtocolError
from protocol.monitor import MonitorReader, MonitorState


@pytest.fixture(scope="session")
def monitor_messages(fixtures_dir: Path) -> list[str]:
    return (fixtures_dir / "monitor_messages.txt").read_text().splitlines()


def read_all(lines: list[str]) -> list[MonitorState]:
    reader = MonitorReader()
    return [reader.feed(line) for line in lines]


def test_full_run_reproduces_the_torso_track(fixtures_dir: Path) -> None:
    states = read_all((fixtures_dir / "monitor_full_run.txt").read_text().splitlines())
    rows = [
        f"{s.game_time:.2f}\t{p.position[0]:.4f}\t{p.position[1]:.4f}\t{p.position[2]:.4f}\t{p.up[2]:.4f}"
        for s in states
        for p in s.robots
    ]
    expected = (fixtures_dir / "monitor_full_run_torso_track.tsv").read_text().splitlines()
    assert expected[0].split("\t") == ["game_time", "torso_x", "torso_y", "torso_z", "torso_up_z"]
    assert rows == expected[1:]


def test_header_and_robot_identity_from_materials(monitor_messages: list[str]) -> None:
    states = read_all(monitor_messages)
    first = states[0]
    assert (first.game_time, first.play_mode, first.half, first.score_left, first.score_right) == (
        0.0,
        "BeforeKickOff",
        1,
        0,
        0,
    )
    assert first.robots == [] and first.team_left is None
    (before_init,) = states[6].robots  # robot appeared, team not known yet: matNum matTeam
    assert (before_init.team, before_init.unum, before_init.robot_type) == (None, None, 0)
    assert before_init.position == pytest.approx((0.0, -1.0, 1.5), abs=0.05)  # spawned at z 1.5, falling
    (after_init,) = states[7].robots
    assert (after_init.team, after_init.unum, after_init.robot_type) == ("left", 1, 0)
    assert states[7].team_left == "Probe" and states[7].team_right is None
    assert after_init.position == pytest.approx((-1.0, 0.0, 0.396), abs=1e-3)  # just beamed
    assert after_init.up[2] == pytest.approx(1.0, abs=1e-6)
    assert after_init.forward == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)  # beam rot 0 faces +x
    assert states[8].play_mode == "BeforeKickOff"


def test_deltas_carry_play_mode_and_moves(monitor_messages: list[str]) -> None:
    states = read_all(monitor_messages)
    assert (states[9].game_time, states[9].play_mode) == (0.04, "PlayOn")  # line 10
    assert states[10].robots[0].position[0] == pytest.approx(-0.89, abs=0.01)  # line 11: not moved yet
    moved = states[11].robots[0]  # line 12: after (move -3.0 2.0 0.4 90)
    assert moved.position == pytest.approx((-3.0, 2.0, 0.39), abs=0.01)
    assert moved.up[2] > 0.99
    assert states[13].robots[0].position[0] == pytest.approx(-3.44, abs=0.01)  # line 14
    placed = states[14].robots[0]  # line 15: after (pos -4.0 -1.0 0.5)
    assert placed.position == pytest.approx((-4.0, -1.0, 0.49), abs=0.01)
    assert all(s.play_mode == "PlayOn" and s.team_left == "Probe" for s in states[9:])


def test_right_team_materials(monitor_messages: list[str]) -> None:
    reader = MonitorReader()
    (robot,) = reader.feed(monitor_messages[7].replace("matNum1 matLeft", "matNum7 matRight")).robots
    assert (robot.team, robot.unum) == ("right", 7)


def test_states_are_snapshots(monitor_messages: list[str]) -> None:
    reader = MonitorReader()
    for line in monitor_messages[:8]:
        earlier = reader.feed(line)
    position = earlier.robots[0].position
    reader.feed(monitor_messages[11])
    assert earlier.robots[0].position == position


def test_malformed_streams_raise(monitor_messages: list[str]) -> None:
    with pytest.raises(ProtocolError, match="full scene"):
        MonitorReader().feed(monitor_messages[1])  # a delta with no scene to refer to
    reader = MonitorReader()
    reader.feed(monitor_messages[7])
    with pytest.raises(ProtocolError, match="balance"):
        reader.feed(monitor_messages[8][:-5])
    with pytest.raises(ProtocolError, match="inside a node"):
        MonitorReader().feed(monitor_messages[7][:-3])
    with pytest.raises(ProtocolError, match="header"):
        MonitorReader().feed("(time 1)(RDS 0 1)()")
    with pytest.raises(ProtocolError, match="play_mode"):
        MonitorReader().feed("((play_mode 99))")
    with pytest.raises(ProtocolError, match="SLT"):
        reader.feed(monitor_messages[8].replace("(SLT ", "(SLT 1 ", 1))
