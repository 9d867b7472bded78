"""Command calibration (``optimizer.episode.command_map``, ``python -m optimizer.calibrate``): the
walked speeds are read from the judge's track in the torso's frame, each gain moves by commanded
over walked on its own axis and ``side_turn`` by the turn walked per sideways metre, and the
command calibrates a steerable walk on the stand-in so that it walks nearer what it is
commanded, changing no other gene."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import OMNI, load_gait
from gait.omni import CALIBRATION_GENES
from optimizer.cli.calibrate_command import main
from optimizer.episode.command_map import CommandWalks, achieved, calibrated, command_error
from optimizer.episode.scoring import TracePoint

WALKS = Path(__file__).resolve().parent.parent / "gait" / "walks"
START = WALKS / "omni_start.json"


def track(forward: float, left: float, turn: float, heading0: float, seconds: float = 2.0) -> list[TracePoint]:
    """A torso walking ``forward`` and ``left`` m/s in its own frame while turning ``turn`` deg/s,
    seen every 0.04 s (the judge's cadence), integrated finely in between."""
    points, x, y, h, t, dt = [], 0.0, 0.0, math.radians(heading0), 0.0, 0.001
    for k in range(round(seconds / dt) + 1):
        if k % 40 == 0:
            points.append(TracePoint(t, x, y, 0.33, 1.0, math.degrees(h)))
        x += (forward * math.cos(h) - left * math.sin(h)) * dt
        y += (forward * math.sin(h) + left * math.cos(h)) * dt
        h += math.radians(turn) * dt
        t += dt
    return points


@settings(max_examples=40, deadline=None)
@given(
    forward=st.floats(-1.0, 1.0),
    left=st.floats(-0.7, 0.7),
    turn=st.floats(-40.0, 40.0),
    heading0=st.floats(-180.0, 180.0),
)
def test_walked_speeds_are_read_in_the_torsos_frame_as_it_turned(forward, left, turn, heading0) -> None:
    got = achieved(track(forward, left, turn, heading0))
    # the judge's 0.04 s samples of a curving path: straight chords, off by (turn x 0.04 s)^2 / 24
    assert got == pytest.approx((forward, left, turn), abs=2e-3)
    later = achieved(track(forward, left, turn, heading0), since=1.0)
    assert later == pytest.approx((forward, left, turn), abs=2e-3)


def walks(rows: list[tuple[tuple[float, float, float], tuple[float, float, float] | None]]) -> list[CommandWalks]:
    return [CommandWalks(command, 3, 0 if got else 3, got, got) for command, got in rows]


def test_each_gain_moves_by_commanded_over_walked_on_its_axis_and_side_turn_by_the_sideways_turn() -> None:
    gait = load_gait(START)
    measured = walks(
        [
            ((0.4, 0.0, 0.0), (0.32, 0.01, 2.0)),  # walks 80% forward: the gain x 1.25
            ((-0.4, 0.0, 0.0), (-0.2, 0.0, 0.0)),  # 50% back, and ...
            ((-0.2, 0.0, 0.0), (-0.2, 0.0, 0.0)),  # ... 100%: the mean, x 1.5
            ((0.0, 0.3, 0.0), (-0.04, 0.25, 10.0)),  # sideways 0.3 -> 0.25, turning 40 deg/m
            ((0.0, -0.3, 0.0), (-0.04, -0.2, -8.0)),  # 0.3 -> 0.2, 40 deg/m
            ((0.0, 0.0, 50.0), None),  # every turning walk fell: the turn gain stays
        ]
    )
    after = calibrated(gait, measured).params
    before = gait.params
    assert after["gain_forward"] == pytest.approx(before["gain_forward"] * 1.25)
    assert after["gain_backward"] == pytest.approx(before["gain_backward"] * 1.5)
    assert after["gain_left"] == pytest.approx(before["gain_left"] * (1.2 + 1.5) / 2)
    assert after["gain_turn"] == before["gain_turn"]
    assert after["side_turn"] == pytest.approx(before["side_turn"] - before["gain_turn"] * 40.0)
    assert {k: v for k, v in after.items() if k not in CALIBRATION_GENES} == {
        k: v for k, v in before.items() if k not in CALIBRATION_GENES
    }
    assert command_error(measured) == pytest.approx(0.5)  # the backward walk at half its command


def test_a_gain_stays_inside_the_familys_box() -> None:
    gait = load_gait(START)
    after = calibrated(gait, walks([((0.5, 0.0, 0.0), (0.01, 0.0, 0.0))])).params
    assert after["gain_forward"] == OMNI.bounds[OMNI.gene_names.index("gain_forward"), 1]


def test_the_command_calibrates_a_walk_on_the_stand_in(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, rounds = tmp_path / "calibrated.json", tmp_path / "rounds.json"
    code = main(
        [str(START), "--out", str(out), "--runs", "1", "--rounds", "1", "--seconds", "3", "--json", str(rounds)]
    )
    assert code == 0
    printed = capsys.readouterr().out
    misses = [float(m) for m in re.findall(r"worst miss: ([0-9.]+)%", printed)]
    assert len(misses) == 2 and misses[1] < misses[0]  # the check round walks nearer the commands
    before, after = load_gait(START).params, load_gait(out).params
    assert all(after[k] == v for k, v in before.items() if k not in CALIBRATION_GENES)
    # the robot walks less than it plans: each gain above 1; and stepping sideways turned it
    assert all(after[k] > 1.0 for k in CALIBRATION_GENES if k.startswith("gain"))
    assert after["side_turn"] != 0.0
    document = json.loads(out.read_text())
    assert "python -m optimizer.calibrate" in document["notes"]
    recorded = json.loads(rounds.read_text())
    assert [r["round"] for r in recorded] == [1, 2] and len(recorded[0]["walks"]) == 12


@pytest.mark.parametrize(
    "args, said",
    [
        ([str(WALKS.parent / "default_gait.json")], "takes no command"),
        ([str(START), "--runs", "0"], "--runs"),
        ([str(START), "--real", "2"], "use --real 1"),
    ],
)
def test_a_wrong_value_is_refused_before_any_walk(
    args: list[str], said: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main([*args, "--out", str(tmp_path / "x.json")])
    assert exit_.value.code == 2 and said in capsys.readouterr().err
    assert not (tmp_path / "x.json").exists()


def test_an_out_file_in_no_folder_is_refused(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_:
        main([str(START), "--out", str(tmp_path / "nowhere" / "x.json")])
    assert exit_.value.code == 2 and "folder does not exist" in capsys.readouterr().err
