"""Effector and trainer commands, byte for byte against what real clients sent."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from protocol import commands, trainer
from protocol.numbers import number_text
from protocol.sexp import parse_sexp


def rebuild(line: str) -> str:
    """Re-create one sent agent message from its own content with the builders."""
    out = []
    velocities: dict[str, float] = {}
    for expr in parse_sexp(line):
        head, *args = expr
        if head not in ("scene", "init", "beam", "syn"):
            velocities[head] = float(args[0])
            continue
        if velocities:
            out.append(commands.hinge_velocities(velocities))
            velocities = {}
        if head == "scene":
            out.append(commands.scene(None if len(args) == 1 else int(args[1])))
        elif head == "init":
            out.append(commands.init(int(args[0][1]), args[1][1]))
        elif head == "beam":
            out.append(commands.beam(*map(float, args)))
        else:
            out.append(commands.syn())
    if velocities:
        out.append(commands.hinge_velocities(velocities))
    return "".join(out)


def test_first_agent_messages_byte_for_byte(fixtures_dir: Path) -> None:
    lines = (fixtures_dir / "agent_commands_sent.txt").read_text().splitlines()
    assert lines[0] == commands.scene()
    assert lines[1] == commands.init(1, "Probe") + commands.syn()
    assert lines[2] == commands.beam(-1.0, 0.0, 0.0) + commands.syn()
    assert (
        lines[3]
        == commands.hinge_velocities(
            {"lle3": 0.188, "lle4": -0.188, "lle5": 0.188, "rle3": 0.188, "rle4": -0.188, "rle5": 0.188}
        )
        + commands.syn()
    )


@pytest.mark.parametrize(
    "name",
    ["agent_commands_sent.txt", "agent_commands_sent_first20_realtime_mode.txt", "walk_calibration/run1_commands.txt"],
)
def test_every_sent_agent_message_is_rebuilt_exactly(fixtures_dir: Path, name: str) -> None:
    lines = (fixtures_dir / name).read_text().splitlines()
    assert len(lines) > 15
    for line in lines:
        assert rebuild(line) == line


def test_scene_for_heterogeneous_robots() -> None:
    assert commands.scene(0) == "(scene rsg/agent/nao/nao_hetero.rsg 0)"
    assert commands.scene(4) == "(scene rsg/agent/nao/nao_hetero.rsg 4)"
    with pytest.raises(ValueError, match="robot type"):
        commands.scene(5)


def test_hinge_velocities_keep_mapping_order_and_refuse_bad_input() -> None:
    assert commands.hinge_velocities({"rle4": -0.00001, "he1": 6.1395}) == "(rle4 -0.0000)(he1 6.1395)"
    with pytest.raises(ValueError, match="not finite"):
        commands.hinge_velocities({"he1": math.nan})
    with pytest.raises(ValueError, match="effector name"):
        commands.hinge_velocities({"he 1": 1.0})


def test_say_follows_the_server_message_rules() -> None:
    assert commands.say("ready!") == "(say ready!)"
    assert commands.say("x" * 20) == f"(say {'x' * 20})"
    with pytest.raises(ValueError, match="21 characters"):
        commands.say("x" * 21)
    with pytest.raises(ValueError, match="index 2"):
        commands.say("ab cd")
    with pytest.raises(ValueError, match="parenthesis"):
        commands.say("a(b")
    with pytest.raises(ValueError, match="printable ASCII"):
        commands.say("caf\u00e9")
    with pytest.raises(ValueError, match="empty"):
        commands.say("")


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_number_text_reads_back_exactly_without_exponent(value: float) -> None:
    text = number_text(value)
    assert float(text) == value
    assert "e" not in text.lower()
    assert not text.endswith(".0")


def test_number_text_examples() -> None:
    assert [number_text(v) for v in (-1.0, 0.0, -0.0, 0.4, 1e-7, 90)] == ["-1", "0", "0", "0.4", "0.0000001", "90"]
    with pytest.raises(ValueError):
        number_text(math.inf)


def test_trainer_commands_byte_for_byte(fixtures_dir: Path) -> None:
    lines = (fixtures_dir / "monitor_commands_sent.txt").read_text().splitlines()
    assert lines == [
        trainer.play_mode("PlayOn"),
        trainer.agent_move(1, "Left", -3.0, 2.0, 0.4, 90),
        trainer.agent_pos(1, "Left", -4.0, -1.0, 0.5),
        trainer.ball((1.0, 0.5, 0.042), (0.0, 0.0, 0.0)),
    ]
    assert trainer.ball((1.0, 0.5, 0.042)) == lines[3]


def test_other_trainer_commands() -> None:
    assert trainer.kick_off("left") == "(kickOff Left)"
    assert trainer.set_time(0.0) == "(time 0)"
    assert trainer.kill(2, "right") == "(kill (unum 2) (team Right))"
    assert trainer.repos(1, "Left") == "(repos (unum 1) (team Left))"
    assert trainer.req_full_state() == "(reqfullstate)"
    assert trainer.kill_sim() == "(killsim)"
    assert trainer.agent_move(1, "Left", 0.0, 0.0, 0.4, -90) == "(agent (unum 1) (team Left) (move 0.0 0.0 0.4 -90))"
    with pytest.raises(ValueError, match="Left"):
        trainer.agent_pos(1, "Middle", 0, 0, 0)
    with pytest.raises(ValueError, match="unknown play mode"):
        trainer.play_mode("Playon")
