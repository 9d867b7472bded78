"""Command-line values shared by ``python -m agent``, ``server_stub`` and ``optimizer.*``: a wrong
value is refused with a message that names the flag and what is wrong."""

from __future__ import annotations

import argparse

import pytest

from agent.__main__ import build_parser as agent_parser
from protocol import cli_values
from server_stub.__main__ import build_parser as stub_parser


@pytest.mark.parametrize(
    "check, text, problem",
    [
        (cli_values.number, "nan", "must be finite"),
        (cli_values.number, "1e999", "must be finite"),
        (cli_values.number, "abc", "must be a number"),
        (cli_values.positive_float, "0", "must be > 0"),
        (cli_values.probability, "1.01", "within [0, 1]"),
        (cli_values.positive_int, "0", "must be >= 1"),
        (cli_values.positive_int, "2.5", "whole number"),
        (cli_values.count, "-1", "must be >= 0"),
        (cli_values.port, "0", "1-65535"),
        (cli_values.listening_port, "65536", "0-65535"),
    ],
)
def test_wrong_values_are_refused_with_the_reason(check, text, problem):
    with pytest.raises(argparse.ArgumentTypeError, match=problem.replace("[", r"\[").replace("]", r"\]")):
        check(text)


@pytest.mark.parametrize(
    "check, text, value",
    [
        (cli_values.number, "-2.5", -2.5),
        (cli_values.positive_float, "1e-9", 1e-9),
        (cli_values.probability, "0", 0.0),
        (cli_values.probability, "1", 1.0),
        (cli_values.positive_int, "7", 7),
        (cli_values.count, "0", 0),
        (cli_values.port, "65535", 65535),
        (cli_values.listening_port, "0", 0),
    ],
)
def test_good_values_pass_unchanged(check, text, value):
    assert check(text) == value


@pytest.mark.parametrize(
    "parser, argv, message",
    [
        (agent_parser, ["--port", "70000"], "argument --port: port must be 1-65535"),
        (agent_parser, ["--duration", "inf"], "argument --duration: must be finite"),
        (agent_parser, ["--unum", "12"], "argument --unum: unum must be 0-11"),
        (stub_parser, ["--agent-port", "-1"], "argument --agent-port: port must be 0-65535"),
        (stub_parser, ["--agent-timeout", "0"], "argument --agent-timeout: must be > 0"),
        (stub_parser, ["--seed", "x"], "argument --seed: must be a whole number"),
    ],
)
def test_programs_name_the_flag_and_the_problem(parser, argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        parser().parse_args(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
