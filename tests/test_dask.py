"""Dask-distributed evaluation on a LocalCluster: same results as local mode, lost workers retried."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

if not os.environ.get("CI"):
    pytest.importorskip("distributed")  # an optional extra locally; CI installs it and must run these

from gait import load_gait  # noqa: E402
from optimizer.episode import EpisodeConfig  # noqa: E402
from optimizer.evaluation.dask_cluster import DaskEvaluator  # noqa: E402
from optimizer.evaluation.pool import EpisodeTask  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TINY = [
    "--crossover",
    "0.8",
    "--population",
    "4",
    "--iterations",
    "2",
    "--generations",
    "2",
    "--walk-time",
    "2",
    "--seed",
    "11",
    "--quiet",
]


def _fitness_by_key(folder: Path) -> dict[str, float]:
    records = [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines()]
    assert len({r["key"] for r in records}) == len(records)
    return {r["key"]: r["fitness"] for r in records}


@pytest.mark.slow
def test_dask_local_run_equals_the_local_run(tmp_path: Path) -> None:
    def gala(*args: str) -> None:
        done = subprocess.run(
            [sys.executable, "-m", "optimizer.gala", *TINY, *args],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr

    gala("--dask-local", "2", "--out", str(tmp_path / "dask"))
    gala("--workers", "2", "--out", str(tmp_path / "local"))
    assert _fitness_by_key(tmp_path / "dask") == _fitness_by_key(tmp_path / "local")
    assert (tmp_path / "dask" / "table1.csv").read_text() == (tmp_path / "local" / "table1.csv").read_text()
    assert (tmp_path / "dask" / "gala-pc0.8.png").is_file()
    manifest = json.loads((tmp_path / "dask" / "manifest.json").read_text())
    assert "local:2" in json.dumps(manifest)


@pytest.mark.slow
def test_a_worker_lost_mid_episode_is_retried_elsewhere_and_counted_once() -> None:
    genes = tuple(load_gait().as_array())
    tasks = [EpisodeTask(f"t{i:02d}", genes, i) for i in range(8)]
    evaluator = DaskEvaluator(EpisodeConfig(walk_time=3.0), seed=1, local_workers=2)
    try:
        pids = evaluator._client.run(os.getpid)
        outcomes = []
        for outcome in evaluator.evaluate(tasks):
            outcomes.append(outcome)
            if len(outcomes) == 1:
                os.kill(next(iter(pids.values())), signal.SIGKILL)  # a worker dies mid-batch
    finally:
        evaluator.close()
    assert sorted(o.task.key for o in outcomes) == [t.key for t in tasks]
    assert all(o.result["status"] == "ok" for o in outcomes), [o.result["reason"] for o in outcomes]
    # the same gait walks the same way wherever and whenever it ran
    assert len({o.result["fitness"] for o in outcomes}) == 1
