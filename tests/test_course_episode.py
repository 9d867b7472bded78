"""Course walks end to end: an omni gait walks to poses on the stand-in, in process and over
sockets with the same outcome to the last digit, steering by the server's pose or by its own
estimate; the episode command prints what a script needs; the real server walks it too."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from gait import load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner
from optimizer.episode.course import Course
from optimizer.episode.real_server import RealServerProcess

ROOT = Path(__file__).resolve().parents[1]
OMNI = ROOT / "gait" / "walks" / "omni.json"
#: A short course of the big one's kinds of leg: ahead, to the left, a turn on the spot.
SHORT = Course(
    start=(-12.0, 0.0, 0.0), poses=((-11.2, 0.0, 0.0), (-11.2, 0.5, 0.0), (-11.2, 0.5, 90.0)), time_limit=20.0
)


def _outcome(embedded_stub: str, true_pose: bool) -> list[tuple]:
    config = EpisodeConfig(embedded_stub=embedded_stub, true_pose=true_pose, command_noise=1e-6).on_course(SHORT)
    gait = load_gait(OMNI)
    out = []
    with EpisodeRunner(config, trace=True) as runner:
        for seed in (0, 1):
            r = runner.evaluate(gait, seed=seed)
            assert r.status == "ok", r.reason
            out.append((r.finished, r.reached, r.legs, r.time, r.fell, r.fitness, r.distance, r.track))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("true_pose", [True, False], ids=["server-pose", "own-estimate"])
def test_a_course_walks_the_same_in_process_and_over_sockets(true_pose):
    inprocess = _outcome("inprocess", true_pose)
    assert inprocess == _outcome("socket", true_pose)
    assert all(finished for finished, *_ in inprocess), inprocess


@pytest.mark.slow
def test_an_agent_process_walks_a_course_by_its_command_line():
    """``python -m agent --goto ...`` (the runner's process mode passes the course's poses so)."""
    config = EpisodeConfig(agent_mode="process", command_noise=1e-6).on_course(SHORT)
    with EpisodeRunner(config) as runner:
        result = runner.evaluate(load_gait(OMNI), seed=0)
    assert result.status == "ok", result.reason
    assert result.finished and not result.fell and result.reached == len(SHORT.poses)


def test_the_episode_command_prints_a_course_walk_as_json(tmp_path):
    course = tmp_path / "short.json"
    course.write_text(json.dumps(SHORT.to_document()))
    done = subprocess.run(
        [sys.executable, "-m", "optimizer.episode", "--gait", str(OMNI), "--course", str(course), "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    (line,) = done.stdout.splitlines()
    walk = json.loads(line)
    assert walk["finished"] is True and walk["fell"] is False and walk["reached"] == len(SHORT.poses)
    assert len(walk["legs"]) == len(SHORT.poses) and 0 < walk["legs"][-1] == walk["time"] < SHORT.time_limit


def test_a_course_needs_a_steerable_gait(tmp_path):
    course = tmp_path / "short.json"
    course.write_text(json.dumps(SHORT.to_document()))
    done = subprocess.run(
        [sys.executable, "-m", "optimizer.episode", "--course", str(course)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert done.returncode == 2 and "steerable" in done.stderr


@pytest.mark.slow
@pytest.mark.real_server
def test_the_real_server_walks_a_short_course(rcssserver3d):
    config = EpisodeConfig(command_noise=1e-6).on_course(SHORT)
    with EpisodeRunner(config, RealServerProcess(rcssserver3d)) as runner:
        result = runner.evaluate(load_gait(OMNI), seed=0)
    assert result.status == "ok", result.reason
    assert result.finished and not result.fell and result.reached == len(SHORT.poses)
