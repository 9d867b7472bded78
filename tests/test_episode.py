"""Episodes (paper eq. 9) on the stub over real sockets, and their failure handling."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from gait import load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner, ServerAddress
from optimizer.episode.servers import StubProcess

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def runner():
    with EpisodeRunner(EpisodeConfig(walk_time=3.0)) as r:
        yield r


def test_episode_scores_eq9_and_is_reproducible(runner: EpisodeRunner) -> None:
    first = runner.evaluate(load_gait())
    second = runner.evaluate(load_gait().as_array())
    assert first.status == "ok", first.reason
    assert first.fitness == pytest.approx(10 * first.distance)
    assert 0 < first.time <= 3.0
    assert first.fell or first.time == pytest.approx(3.0)
    assert first.mean_speed == pytest.approx(first.distance / first.time)
    # same gait, same server, fresh robot: the same walk (sync mode, trainer commands at fixed cycles)
    assert (second.distance, second.fell, second.time) == (first.distance, first.fell, first.time)


def test_a_walk_from_another_start_is_measured_from_it(runner: EpisodeRunner) -> None:
    """Beamed to (-6, 3) facing +y, the robot walks as from the origin, and the distance is taken
    along its heading from that point (a beam or a judge that ignored the start would give ~0 or
    ~-3 m)."""
    at_origin = runner.evaluate(load_gait())
    with EpisodeRunner(EpisodeConfig(walk_time=3.0, start=(-6.0, 3.0), heading=90.0)) as other:
        turned = other.evaluate(load_gait())
    assert turned.status == "ok" and not turned.fell
    assert at_origin.distance > 0.3
    assert turned.distance == pytest.approx(at_origin.distance, abs=0.1)
    # the same start given to one episode of the origin's runner (a stability check's way)
    moved = runner.evaluate(load_gait(), start=(-6.0, 3.0, 90.0))
    assert (moved.distance, moved.fell, moved.time) == (turned.distance, turned.fell, turned.time)
    assert runner.evaluate(load_gait()).distance == at_origin.distance  # the next one starts at home


def test_distance_is_measured_from_where_the_robot_stands_not_where_it_was_sent(runner: EpisodeRunner) -> None:
    """A beam past the centre line is clipped to x = 0 (the left team's own half), so the robot
    walks exactly the origin's walk; a judge measuring from the beam's target would take 0.4 m
    off it. A start the server honours still moves the robot (the walk differs)."""
    at_origin = runner.evaluate(load_gait(), start=(0.0, 0.0, 0.0))
    clipped = runner.evaluate(load_gait(), start=(0.4, 0.0, 0.0))
    assert clipped.status == "ok"
    assert (clipped.distance, clipped.fell, clipped.time) == (at_origin.distance, at_origin.fell, at_origin.time)
    behind = runner.evaluate(load_gait(), start=(-0.4, 0.0, 0.0))
    assert behind.distance == pytest.approx(at_origin.distance, abs=0.05)


def test_a_gait_that_collapses_is_scored_at_its_fall(runner: EpisodeRunner) -> None:
    collapse = load_gait().as_array()
    collapse[0], collapse[2], collapse[3] = 40.0, 40.0, 40.0  # hip far forward, big swings
    result = runner.evaluate(collapse)
    assert result.status == "ok"
    assert result.fell and result.time < 3.0


def test_process_agents_give_a_valid_episode() -> None:
    with EpisodeRunner(EpisodeConfig(walk_time=1.0, agent_mode="process")) as r:
        result = r.evaluate(load_gait())
    assert result.status == "ok", result.reason
    assert result.time == pytest.approx(1.0) or result.fell


def test_unreachable_server_is_a_failed_episode_not_an_exception() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with EpisodeRunner(EpisodeConfig(walk_time=1.0, episode_timeout=2.0), ServerAddress("127.0.0.1", port, port)) as r:
        result = r.evaluate(load_gait())
    assert result.status == "failed" and "refused" in result.reason.lower()
    assert result.fitness == 0.0


def test_hung_server_times_out_and_fails_the_episode() -> None:
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    port = listener.getsockname()[1]
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def accept_and_ignore() -> None:
        listener.settimeout(0.2)
        while not stop.is_set():
            try:
                accepted.append(listener.accept()[0])
            except OSError:
                pass

    thread = threading.Thread(target=accept_and_ignore, daemon=True)
    thread.start()
    try:
        with EpisodeRunner(
            EpisodeConfig(walk_time=1.0, episode_timeout=1.0), ServerAddress("127.0.0.1", port, port)
        ) as r:
            result = r.evaluate(load_gait())
    finally:
        stop.set()
        thread.join()
        for conn in accepted:
            conn.close()
        listener.close()
    assert result.status == "failed"
    assert result.wall < 10


def test_a_dead_stub_is_restarted() -> None:
    stub = StubProcess()
    with EpisodeRunner(EpisodeConfig(walk_time=0.5), stub) as r:
        assert r.evaluate(load_gait()).status == "ok"
        crashed = stub.pid
        assert crashed is not None
        os.kill(crashed, signal.SIGKILL)  # simulate a crash between episodes
        result = r.evaluate(load_gait())
        assert stub.pid not in (None, crashed)
    assert result.status == "ok", result.reason
    assert stub.pid is None  # stopped with the runner


@pytest.mark.parametrize(
    "text, words",
    [("localhost:3100", "HOST:AGENT_PORT:MONITOR_PORT"), ("h:x:3200", "integers"), ("h:3100:70000", "70000")],
)
def test_server_address_errors_say_what_is_wrong(text: str, words: str) -> None:
    with pytest.raises(ValueError, match=words):
        ServerAddress.parse(text)
    assert ServerAddress.parse("rcss1:3100:3200") == ServerAddress("rcss1", 3100, 3200)


def test_a_killed_worker_does_not_leave_its_stub_behind(tmp_path: Path) -> None:
    """SIGKILL gives a worker no chance to stop its stub; the stub notices and exits by itself."""
    pid_file = tmp_path / "stub.pid"
    script = (
        "import time; from optimizer.episode.servers import StubProcess; s = StubProcess(); s.ensure_running(); "
        f"open({str(pid_file)!r}, 'w').write(str(s._process.pid)); time.sleep(60)"
    )
    worker = subprocess.Popen([sys.executable, "-c", script], cwd=REPO)
    deadline = time.monotonic() + 30
    while not (pid_file.exists() and pid_file.read_text()):
        assert time.monotonic() < deadline, "the worker did not start its stub"
        time.sleep(0.05)
    stub_pid = int(pid_file.read_text())
    os.kill(worker.pid, signal.SIGKILL)
    worker.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(stub_pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    os.kill(stub_pid, signal.SIGKILL)
    raise AssertionError("the stub outlived its killed parent")


def test_a_drift_penalty_takes_the_sideways_drift_off_the_fitness_and_nothing_else() -> None:
    """``EpisodeConfig.drift_penalty`` W: fitness 10 x (distance - W |drift|), the drift the traced
    walk's card shows; the walk itself (distance, fall, time) is the same walk."""
    gait = load_gait()
    with EpisodeRunner(EpisodeConfig(walk_time=3.0)) as plain:
        straight = plain.evaluate(gait, trace=True)
    with EpisodeRunner(EpisodeConfig(walk_time=3.0, drift_penalty=2.0)) as penalised:
        bent = penalised.evaluate(gait, trace=True)
    assert (bent.distance, bent.fell, bent.time) == (straight.distance, straight.fell, straight.time)
    assert straight.fitness == 10.0 * straight.distance and straight.drift
    assert bent.fitness == pytest.approx(10.0 * (straight.distance - 2.0 * abs(straight.drift)), abs=1e-9)
    with pytest.raises(ValueError, match="drift_penalty"):
        EpisodeConfig(drift_penalty=-1.0)
