"""Evaluating episodes on a Dask cluster (``--scheduler tcp://HOST:8786`` or ``--dask-local N``).

Each Dask worker holds ONE episode runner for its whole life, set up by a worker plugin: its own
embedded stub server, a real rcssserver3d it starts itself (``--real`` with ``--dask-local``, or
``GALA_REAL_SERVER=1`` in the worker's environment: the worker finds it through its own
``RCSSSERVER3D`` or PATH), or the running rcssserver3d named for it (``GALA_SERVER=HOST:AP:MP`` in
the worker's environment, or a ``{worker name: address}`` mapping given here). An episode is one Dask
task; when a worker is lost mid-episode the scheduler runs the task again elsewhere, and the
evaluator yields each task's outcome exactly once, so nothing is lost or counted twice. Logging,
tables, plots and ``--resume`` are the driver's business and work as in local mode.

Requires the optional extra: ``pip install ".[dask]"``.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator, Mapping, Sequence

from distributed import Client, LocalCluster, WorkerPlugin, as_completed, get_worker

from optimizer.episode import EpisodeConfig, EpisodeRunner, ServerAddress
from optimizer.episode.real_server import RealServerProcess, find_rcssserver3d
from optimizer.episode.runner import quiet_agent_logs
from optimizer.evaluation.pool import EpisodeOutcome, EpisodeTask, failed_result

_PLUGIN = "gala-episode-runner"
#: Environment variable naming a Dask worker's real server (``HOST:AGENT_PORT:MONITOR_PORT``).
SERVER_ENV = "GALA_SERVER"
#: Environment variable that has a Dask worker start a real rcssserver3d of its own (any non-empty value but 0).
REAL_SERVER_ENV = "GALA_REAL_SERVER"


class EpisodeRunnerPlugin(WorkerPlugin):
    """Gives a Dask worker its episode runner at start and closes it (and its stub) at the end."""

    name = _PLUGIN

    def __init__(self, config: EpisodeConfig, servers: Mapping[str, str], seed: int, real: bool = False) -> None:
        self.config = config
        self.servers = dict(servers)
        self.seed = seed
        self.real = real
        self.runner: EpisodeRunner | None = None

    def setup(self, worker) -> None:  # noqa: ANN001 - distributed.Worker
        quiet_agent_logs()
        named = self.servers.get(worker.name) or self.servers.get(str(worker.name)) or os.environ.get(SERVER_ENV)
        if named:
            self.runner = EpisodeRunner(self.config, ServerAddress.parse(named), seed=self.seed)
        elif self.real or os.environ.get(REAL_SERVER_ENV, "0") not in ("", "0"):
            # started here, in the worker's long-lived thread: the kernel kills a server when the
            # thread that started it ends, and task threads may come and go
            server = RealServerProcess(find_rcssserver3d())
            server.ensure_running()
            self.runner = EpisodeRunner(self.config, server, seed=self.seed)
        else:
            self.runner = EpisodeRunner(self.config, seed=self.seed)

    def teardown(self, worker) -> None:  # noqa: ANN001
        if self.runner is not None:
            self.runner.close()


def _run_episode(task: EpisodeTask) -> tuple[dict, str]:
    """The Dask task: one episode on this worker's runner."""
    worker = get_worker()
    plugin = worker.plugins[_PLUGIN]
    assert isinstance(plugin, EpisodeRunnerPlugin) and plugin.runner is not None  # set up with the worker
    return task.run_on(plugin.runner), str(worker.name)


class DaskEvaluator:
    """The ``Evaluator`` of ``optimizer.evaluation.pool`` on a Dask cluster: an existing scheduler, or a
    ``LocalCluster`` of ``local_workers`` single-threaded worker processes started here."""

    def __init__(
        self,
        config: EpisodeConfig,
        seed: int,
        *,
        scheduler: str | None = None,
        local_workers: int | None = None,
        servers: Mapping[str, str] | None = None,
        real: bool = False,
    ) -> None:
        if (scheduler is None) == (local_workers is None):
            raise ValueError("give exactly one of scheduler and local_workers")
        self._cluster = None
        if local_workers is not None:
            # one thread per worker: a runner drives one robot at a time
            self._cluster = LocalCluster(
                n_workers=local_workers, threads_per_worker=1, processes=True, dashboard_address=None
            )
            self._client = Client(self._cluster)
        else:
            self._client = Client(scheduler)
        self._client.register_plugin(EpisodeRunnerPlugin(config, servers or {}, seed, real))
        self._worker_ids: dict[str, int] = {}

    def _worker_id(self, name: str) -> int:
        return self._worker_ids.setdefault(name, len(self._worker_ids))

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        futures = {
            self._client.submit(_run_episode, task, key=f"episode-{task.key}-{uuid.uuid4().hex[:8]}", pure=False): task
            for task in tasks
        }
        for future in as_completed(futures):
            task = futures[future]
            try:
                result, worker = future.result()
            except Exception as exc:  # the task failed on every worker Dask allowed it: record it
                result, worker = failed_result(f"{type(exc).__name__}: {exc}", 0.0), "?"
            yield EpisodeOutcome(task, self._worker_id(worker), result)

    def close(self) -> None:
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()
