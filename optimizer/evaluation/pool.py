"""Evaluating episodes: the ``Evaluator`` interface and a local pool of worker processes.

An evaluator takes a batch of ``EpisodeTask`` and yields one ``EpisodeOutcome`` per task as each
finishes, in whatever order they finish; the driver logs each at once. Nothing else is assumed, so
a distributed evaluator (e.g. on Dask) is one new module implementing ``evaluate`` and ``close``.

``ProcessPoolEvaluator`` runs N worker processes, each holding ONE episode runner (a stub server
and an agent, or a connection to a real server) that it reuses across episodes: starting a
server per episode would cost more than the episode. Workers are started with the "spawn"
context: pybullet and open sockets do not survive a fork of a process that used them.

Each worker makes itself the leader of a process group, so whatever its runner started (a stub
server, an agent process) can be killed with it: a worker that dies or hangs is killed as a group,
restarted, and its episode retried once; a second loss records the episode as failed, with the
reason, and the search goes on.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, Protocol

from gait import Gait, family_named
from optimizer.episode import EpisodeConfig, EpisodeResult, EpisodeRunner, ServerAddress, Start
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs
from optimizer.evaluation.record import EpisodeRecord, WalkKind


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to run: the candidate's key and genes, and its own seed (``stable_seed`` of the
    run seed and the key), so its result does not depend on which worker runs it or when.
    ``start`` (x, y, heading) moves this episode's start point; None walks from the run's.
    ``kind`` goes into the episode's record (``optimizer.evaluation.record``). ``trace`` asks for
    the walk's drift, turn and track (a walk card's material; ``EpisodeRunner.evaluate``).
    ``family`` names the genes' gait family where it is not the runner's (None)."""

    key: str
    genes: tuple[float, ...]
    seed: int
    start: Start | None = None
    kind: WalkKind = WalkKind.SEARCH
    trace: bool = False
    family: str | None = None

    def run_on(self, runner: Runner) -> dict[str, Any]:
        """This episode on ``runner``, as the result dict a worker sends back."""
        gait = self.genes if self.family is None else family_named(self.family).gait(self.genes)
        return dict(runner.evaluate(gait, seed=self.seed, start=self.start, trace=self.trace).to_dict())


def failed_result(reason: str, wall: float) -> dict[str, Any]:
    """The result dict of an episode that could not be run (``EpisodeResult.failed``)."""
    return EpisodeResult.failed(reason, wall).to_dict()


@dataclass(frozen=True)
class EpisodeOutcome:
    """A finished episode: the task, the worker that ran it, and the runner's result as a dict
    (``EpisodeResult.to_dict()``: distance, fell, time, fitness, mean_speed, status, reason, wall)."""

    task: EpisodeTask
    worker: int
    result: Mapping[str, Any]

    @property
    def fitness(self) -> float:
        return float(self.result["fitness"])

    def to_record(self) -> EpisodeRecord:
        """The episode log's record of this outcome."""
        task = self.task
        return EpisodeRecord.of(
            task.key, task.genes, task.seed, task.start, task.kind, self.worker, self.result, task.family
        )


class Evaluator(Protocol):
    """What the driver needs: run a batch, hear about each episode as it finishes."""

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        """Yield exactly one outcome per task, as they finish (any order). Never raises for a
        lost episode (that is a failed outcome); raises ``EvaluationError`` when evaluating is
        impossible (e.g. a runner cannot be created at all)."""
        ...

    def close(self) -> None: ...


class EvaluationError(RuntimeError):
    """Episodes cannot be evaluated at all (not one lost episode: that is a failed outcome)."""


class Runner(Protocol):
    """What a worker needs from an episode runner (``optimizer.episode.EpisodeRunner``)."""

    def evaluate(
        self, genes: Sequence[float] | Gait, seed: int, start: Start | None = None, trace: bool = False
    ) -> Any: ...

    def close(self) -> None: ...


#: Picklable ``worker index -> runner``; called once in each worker process.
RunnerFactory = Callable[[int], Runner]


@dataclass(frozen=True)
class EpisodeRunnerFactory:
    """Makes the ``EpisodeRunner`` of worker ``i``: on ``servers[i]`` when servers run elsewhere
    are given (one worker per server), on a real rcssserver3d of its own when ``real_command``
    names one (``optimizer.episode.real_server``), else on its own embedded stub. Every runner gets the
    run's seed, so the stub's noise does not depend on which worker runs an episode."""

    config: EpisodeConfig
    servers: tuple[ServerAddress, ...] = ()
    seed: int = 0
    real_command: str | None = None

    def __call__(self, worker: int) -> Runner:
        if self.servers:
            return EpisodeRunner(self.config, self.servers[worker], seed=self.seed)
        if self.real_command is not None:
            return EpisodeRunner(self.config, RealServerProcess(self.real_command), seed=self.seed)
        return EpisodeRunner(self.config, seed=self.seed)


def _worker_main(factory: RunnerFactory, index: int, conn: Connection) -> None:
    """A worker process: make the runner, say ready, then run tasks until told to stop.

    Messages sent: ``("ready", pid)``, ``("done", key, result)``, ``("error", key, text)`` when the
    runner raised (against its contract; the worker stays usable), ``("broken", text)`` when the
    runner cannot be made.
    """
    os.setpgid(0, 0)  # its own process group: killing the group also kills what the runner started
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when work stops
    quiet_agent_logs()
    try:
        runner = factory(index)
    except BaseException:
        conn.send(("broken", traceback.format_exc()))
        return
    try:
        conn.send(("ready", os.getpid()))
        while True:
            task = conn.recv()
            if task is None:
                break
            try:
                message = ("done", task.key, task.run_on(runner))
            except Exception:
                message = ("error", task.key, traceback.format_exc(limit=4))
            conn.send(message)
    except (EOFError, OSError):
        pass  # the parent is gone
    finally:
        runner.close()


@dataclass
class _Worker:
    index: int
    process: multiprocessing.process.BaseProcess
    conn: Connection
    ready: bool = False
    task: EpisodeTask | None = None
    deadline: float = 0.0
    #: when the current task was sent (for the wall time of a lost episode)
    dispatched: float = 0.0


class ProcessPoolEvaluator:
    """N worker processes, each with one runner made by ``factory(i)``.

    ``task_timeout`` bounds one episode (wall seconds, from dispatch to result: the runner's own
    restart-and-retry included); ``start_timeout`` bounds making a runner. ``start_failures``
    consecutive failed starts of one worker mean the runner cannot be made: ``EvaluationError``.
    """

    def __init__(
        self,
        factory: RunnerFactory,
        workers: int,
        *,
        task_timeout: float,
        start_timeout: float = 120.0,
        start_failures: int = 3,
    ) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self._factory = factory
        self._context = multiprocessing.get_context("spawn")
        self._task_timeout = task_timeout
        self._start_timeout = start_timeout
        self._start_failures = start_failures
        self._failed_starts = [0] * workers
        self._pool: list[_Worker] = []
        self._pool = [self._start(i) for i in range(workers)]

    def pids(self) -> list[int | None]:
        """Process ids of the current workers (what an operator, or a test, would kill)."""
        return [w.process.pid for w in self._pool]

    def _start(self, index: int) -> _Worker:
        parent, child = self._context.Pipe()
        process = self._context.Process(
            target=_worker_main, args=(self._factory, index, child), name=f"episode-worker-{index}"
        )
        process.start()
        child.close()
        return _Worker(index, process, parent, deadline=time.monotonic() + self._start_timeout)

    def _kill(self, worker: _Worker) -> None:
        """Kill the worker's whole process group (the worker and whatever its runner started),
        then reap the worker. The group is killed before the reap, so its id cannot be reused."""
        pid = worker.process.pid
        if pid is not None:
            try:
                os.killpg(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        worker.process.kill()
        worker.process.join(5.0)
        worker.conn.close()

    def _replace(self, worker: _Worker) -> _Worker:
        self._kill(worker)
        fresh = self._start(worker.index)
        self._pool[worker.index] = fresh
        return fresh

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        queue = deque(tasks)
        lost: dict[str, str] = {}  # key -> why its first attempt was lost
        finished = False
        try:
            while queue or any(w.task is not None for w in self._pool):
                for worker in self._pool:
                    if worker.ready and worker.task is None and queue:
                        worker.task = queue.popleft()
                        worker.dispatched = time.monotonic()
                        worker.deadline = worker.dispatched + self._task_timeout
                        worker.conn.send(worker.task)
                deadline = min(w.deadline for w in self._pool)
                timeout = None if deadline == math.inf else max(0.0, deadline - time.monotonic())
                wait([w.conn for w in self._pool] + [w.process.sentinel for w in self._pool], timeout)
                for worker in list(self._pool):
                    yield from self._service(worker, queue, lost)
            finished = True
        finally:
            if not finished:  # the caller stopped early: episodes in flight are abandoned
                for worker in self._pool:
                    if worker.task is not None:
                        self._replace(worker)

    def _service(self, worker: _Worker, queue: deque[EpisodeTask], lost: dict[str, str]) -> Iterator[EpisodeOutcome]:
        """Read what ``worker`` said, then see whether it died or overran its deadline."""
        try:
            while worker.conn.poll():
                outcome = self._handle(worker, worker.conn.recv())
                if outcome is not None:
                    yield outcome
        except (EOFError, OSError):
            pass  # the pipe broke: the process is dead or dying, handled below
        if worker.process.is_alive() and time.monotonic() < worker.deadline:
            return
        if worker.process.is_alive():
            what = (
                f"timed out after {self._task_timeout:g} s"
                if worker.ready
                else (f"did not start within {self._start_timeout:g} s")
            )
        else:
            what = f"died (exit code {worker.process.exitcode})"
        if not worker.ready:
            self._failed_starts[worker.index] += 1
            if self._failed_starts[worker.index] >= self._start_failures:
                self._kill(worker)
                raise EvaluationError(f"worker {worker.index} {what}, {self._start_failures} times in a row")
        task, wall = worker.task, time.monotonic() - worker.dispatched
        self._replace(worker)
        if task is None:
            return
        reason = f"worker {worker.index} {what}"
        if task.key in lost:
            yield EpisodeOutcome(task, worker.index, failed_result(f"{lost[task.key]}; retried: {reason}", wall))
        else:
            lost[task.key] = reason
            queue.appendleft(task)

    def _handle(self, worker: _Worker, message: tuple) -> EpisodeOutcome | None:
        kind = message[0]
        if kind == "ready":
            worker.ready = True
            worker.deadline = math.inf
            self._failed_starts[worker.index] = 0
            return None
        if kind == "broken":
            self._kill(worker)
            raise EvaluationError(f"worker {worker.index} cannot make its episode runner:\n{message[1]}")
        task, worker.task, worker.deadline = worker.task, None, math.inf
        if task is None or task.key != message[1]:
            raise EvaluationError(f"worker {worker.index} answered {message[1]!r}, which it was not given")
        if kind == "done":
            return EpisodeOutcome(task, worker.index, message[2])
        return EpisodeOutcome(
            task,
            worker.index,
            failed_result(
                f"the runner raised: {message[2].strip().splitlines()[-1]}", time.monotonic() - worker.dispatched
            ),
        )

    def close(self) -> None:
        """Stop every worker: those without an episode are asked (their runners close their
        servers; one still starting stops once it has started), the rest are killed with their
        process groups."""
        for worker in self._pool:
            if worker.task is None:
                try:
                    worker.conn.send(None)
                except OSError:
                    pass
        for worker in self._pool:
            if worker.task is None:
                worker.process.join(self._start_timeout)
            self._kill(worker)
        self._pool = []

    def __enter__(self) -> ProcessPoolEvaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
