"""The worker pool: every task answered once, workers that die, hang or raise are handled, runners
are reused. Fake runners (no physics) stand in for EpisodeRunner; what a fake does is chosen by
its first gene."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from optimizer.evaluation.pool import (
    EpisodeTask,
    EvaluationError,
    ProcessPoolEvaluator,
)
from optimizer.seeds import stable_seed

DIE_ONCE, ALWAYS_DIE, HANG, WAIT_TO_BE_KILLED, RAISE = -1.0, -2.0, -3.0, -4.0, -5.0


@dataclass(frozen=True)
class FakeResult:
    fitness: float
    seed: int

    def to_dict(self) -> dict:
        return {
            "distance": self.fitness / 10,
            "fell": False,
            "time": 15.0,
            "fitness": self.fitness,
            "mean_speed": self.fitness / 150,
            "status": "ok",
            "reason": "",
            "wall": 0.0,
            "runner_seed": self.seed,
        }


class FakeRunner:
    """Fitness = sum of the genes. It starts a child process, as EpisodeRunner starts a stub server,
    and writes the child's pid to ``<tmp>/child-<worker pid>``."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.child = subprocess.Popen(["sleep", "300"])
        (tmp / f"child-{os.getpid()}").write_text(str(self.child.pid))
        (tmp / f"runner-{os.getpid()}").write_text("made")

    def evaluate(self, genes, seed: int, start=None, trace=False) -> FakeResult:
        mark = self.tmp / f"seen-{seed}"
        first_time = not mark.exists()
        mark.write_text(str(os.getpid()))
        kind = genes[0]
        if kind == ALWAYS_DIE or (kind == DIE_ONCE and first_time):
            os.kill(os.getpid(), signal.SIGKILL)
        if kind == HANG:
            time.sleep(300)
        if kind == WAIT_TO_BE_KILLED and first_time:
            (self.tmp / f"pid-{seed}").write_text(str(os.getpid()))
            time.sleep(300)
        if kind == RAISE:
            raise RuntimeError("boom")
        return FakeResult(float(sum(genes)), seed)

    def close(self) -> None:
        self.child.kill()
        self.child.wait()


@dataclass(frozen=True)
class FakeFactory:
    tmp: str
    broken: bool = False

    def __call__(self, worker: int) -> FakeRunner:
        if self.broken:
            raise OSError("no server at 127.0.0.1:3100")
        return FakeRunner(Path(self.tmp))


def tasks(*first_genes: float) -> list[EpisodeTask]:
    return [EpisodeTask(f"b/i{k:03d}", (g, float(k)), seed=1000 + k) for k, g in enumerate(first_genes)]


def gone(pid: int) -> bool:
    """True once ``pid`` has exited (a zombie waiting for its reaper counts as exited)."""
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except FileNotFoundError:
            return True
        if state in "ZX":
            return True
        time.sleep(0.05)
    return False


def test_stable_seed_is_a_fixed_hash() -> None:
    assert stable_seed(3, "pc0.8/it001/g00/i004") == stable_seed(3, "pc0.8/it001/g00/i004")
    seeds = {stable_seed(s, k) for s in range(3) for k in ("a", "b", "c")}
    assert len(seeds) == 9 and all(0 <= s < 2**32 for s in seeds)


def test_every_task_is_answered_once_and_runners_are_reused(tmp_path: Path) -> None:
    with ProcessPoolEvaluator(FakeFactory(str(tmp_path)), 2, task_timeout=60) as pool:
        first = list(pool.evaluate(tasks(*[0.5] * 9)))
        second = list(pool.evaluate(tasks(2.0, 3.0)))
    assert sorted(o.task.key for o in first) == [t.key for t in tasks(*[0.5] * 9)]
    for outcome in first + second:
        assert outcome.fitness == sum(outcome.task.genes)
        assert outcome.result["runner_seed"] == outcome.task.seed  # the episode's seed reached the runner
        assert outcome.worker in (0, 1)
        assert outcome.to_record().key == outcome.task.key
    assert len(list(tmp_path.glob("runner-*"))) == 2  # one runner per worker, for both batches


def test_a_worker_killed_from_outside_is_replaced_and_its_episode_retried(tmp_path: Path) -> None:
    batch = tasks(0.0, WAIT_TO_BE_KILLED, 1.0, 2.0, 3.0)
    victim_seed = batch[1].seed

    def kill_the_worker() -> None:
        pid_file = tmp_path / f"pid-{victim_seed}"
        while not pid_file.exists():
            time.sleep(0.02)
        time.sleep(0.05)
        os.kill(int(pid_file.read_text()), signal.SIGKILL)

    killer = threading.Thread(target=kill_the_worker, daemon=True)
    killer.start()
    with ProcessPoolEvaluator(FakeFactory(str(tmp_path)), 2, task_timeout=60) as pool:
        outcomes = {o.task.key: o for o in pool.evaluate(batch)}
        killer.join(5)
        victim = int((tmp_path / f"pid-{victim_seed}").read_text())
        orphan = int((tmp_path / f"child-{victim}").read_text())
        assert gone(orphan)  # what the dead worker's runner started went with it
        assert victim not in pool.pids() and len(pool.pids()) == 2  # replaced
    assert sorted(outcomes) == [t.key for t in batch]
    assert all(o.result["status"] == "ok" for o in outcomes.values())
    assert outcomes[batch[1].key].fitness == sum(batch[1].genes)


def test_a_worker_that_dies_once_is_retried_twice_is_failed_and_nothing_else_is_lost(tmp_path: Path) -> None:
    batch = tasks(DIE_ONCE, 1.0, ALWAYS_DIE, 2.0, 3.0, 4.0)
    with ProcessPoolEvaluator(FakeFactory(str(tmp_path)), 2, task_timeout=60) as pool:
        outcomes = {o.task.key: o for o in pool.evaluate(batch)}
        after = list(pool.evaluate(tasks(5.0)))  # the pool still works
    assert sorted(outcomes) == [t.key for t in batch]
    assert outcomes[batch[0].key].result["status"] == "ok"
    lost = outcomes[batch[2].key].result
    assert lost["status"] == "failed" and lost["fitness"] == 0.0
    assert lost["reason"].count("died (exit code -9)") == 2 and "retried" in lost["reason"]
    for t in (batch[1], *batch[3:]):
        assert outcomes[t.key].result["status"] == "ok" and outcomes[t.key].fitness == sum(t.genes)
    assert after[0].fitness == 5.0 + 0.0


def test_a_hanging_worker_is_killed_after_the_timeout(tmp_path: Path) -> None:
    batch = tasks(1.0, HANG, 2.0)
    with ProcessPoolEvaluator(FakeFactory(str(tmp_path)), 2, task_timeout=1.5) as pool:
        outcomes = {o.task.key: o for o in pool.evaluate(batch)}
    hung = outcomes[batch[1].key].result
    assert hung["status"] == "failed" and hung["reason"].count("timed out after 1.5 s") == 2
    assert outcomes[batch[0].key].fitness == 1.0 and outcomes[batch[2].key].fitness == 4.0


def test_a_runner_that_raises_fails_that_episode_only(tmp_path: Path) -> None:
    batch = tasks(RAISE, 1.0)
    with ProcessPoolEvaluator(FakeFactory(str(tmp_path)), 1, task_timeout=60) as pool:
        outcomes = {o.task.key: o for o in pool.evaluate(batch)}
    assert outcomes[batch[0].key].result["status"] == "failed"
    assert "RuntimeError: boom" in outcomes[batch[0].key].result["reason"]
    assert outcomes[batch[1].key].fitness == 2.0
    assert len(list(tmp_path.glob("runner-*"))) == 1  # the worker was kept


def test_a_runner_that_cannot_be_made_stops_the_evaluation(tmp_path: Path) -> None:
    with ProcessPoolEvaluator(FakeFactory(str(tmp_path), broken=True), 1, task_timeout=60) as pool:
        with pytest.raises(EvaluationError, match="no server at 127.0.0.1:3100"):
            list(pool.evaluate(tasks(1.0)))


def test_closing_stops_workers_and_what_they_started(tmp_path: Path) -> None:
    pool = ProcessPoolEvaluator(FakeFactory(str(tmp_path)), 2, task_timeout=60)
    list(pool.evaluate(tasks(1.0, 2.0, 3.0)))
    pids = pool.pids()
    pool.close()
    children = [int(p.read_text()) for p in tmp_path.glob("child-*")]
    assert len(children) == 2
    assert all(gone(pid) for pid in pids + children)
