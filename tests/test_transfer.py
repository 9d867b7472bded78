"""The transfer report (``python -m optimizer.transfer``): which gaits a run reported, walked again
elsewhere, with every output file; on a real server where one is configured."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest
from test_driver import FakeEvaluator

from optimizer.cli import gala as gala_command
from optimizer.cli import transfer
from optimizer.cli.common import EvaluationSetup
from optimizer.episode import DEFAULT_START
from optimizer.episode.real_server import RCSSSERVER3D_ENV

TINY = [
    "--crossover",
    "0.8",
    "--crossover",
    "0.3",
    "--population",
    "6",
    "--iterations",
    "3",
    "--generations",
    "2",
    "--seed",
    "4",
    "--check-repeats",
    "2",
    "--quiet",
]


def _run(tmp_path: Path) -> Path:
    out = tmp_path / "run"
    assert gala_command.main([*TINY, "--out", str(out)], make_evaluator=lambda setup: FakeEvaluator()) == 0
    return out


def test_each_reported_gait_is_listed_once_under_all_its_names() -> None:
    check = {
        "walks": [
            {"distance": 2.0, "fell": False, "status": "ok"},
            {"distance": 1.0, "fell": True, "status": "ok"},
            {"distance": 0.0, "fell": False, "status": "failed"},
        ]
    }
    results = {
        "rows": [
            {"crossover": 0.8, "best_genes": [1.0] * 7, "check": check, "best_episode": None},
            {
                "crossover": 0.3,
                "best_genes": [2.0] * 7,
                "check": None,
                "best_episode": {"distance": 4.0, "fell": False},
            },
        ],
        "fastest_episode": {"genes": [2.0] * 7, "distance": 4.0, "fell": False},
        "fastest_check": None,
    }
    first, second = transfer.reported_gaits(results)
    assert first.names == ["Table I pc 0.8"] and first.run_distances == [2.0, 1.0] and first.run_falls == 1
    assert second.names == ["Table I pc 0.3", "fastest"] and second.run_distances == [4.0] and second.run_falls == 0
    [ga] = transfer.reported_gaits(
        {"best_genes": [3.0] * 7, "check": None, "best_episode": {"distance": 1.5, "fell": True}}
    )
    assert ga.name == "GA best" and ga.run_distances == [1.5] and ga.run_falls == 1


def test_transfer_walks_every_gait_and_writes_its_files(tmp_path: Path) -> None:
    out = _run(tmp_path)
    setups: list[EvaluationSetup] = []
    evaluator = FakeEvaluator()

    def make(setup: EvaluationSetup) -> FakeEvaluator:
        setups.append(setup)
        return evaluator

    assert transfer.main([str(out), "--repeats", "3"], make_evaluator=make) == 0
    results = json.loads((out / "results.json").read_text())
    gaits = transfer.reported_gaits(results)
    rows = list(csv.DictReader((out / "transfer.csv").open()))
    assert [r["gait"] for r in rows] == [g.name for g in gaits] and len(rows) >= 2
    assert len(evaluator.evaluated) == 3 * len(gaits) and all(r["walks"] == "3" for r in rows)
    for row in rows:  # the fake's distance depends on the genes only: the run's figure comes back
        assert float(row["mean_ratio"]) == pytest.approx(1.0) and row["falls"] == "0"
    walks = json.loads((out / "transfer.json").read_text())
    assert walks["target"] == "stand-in" and walks["run_server"] == "stand-in"
    assert [len(g["walks"]) for g in walks["gaits"]] == [3] * len(gaits)
    starts = {tuple(w["start"]) for g in walks["gaits"] for w in g["walks"]}
    assert len(starts) == 3 * len(gaits)  # moved within the run's check jitter, each its own
    assert all(abs(x - DEFAULT_START[0]) <= 0.05 for x, _, _ in starts)
    assert setups[0].real_command is None and setups[0].start == DEFAULT_START
    assert "| Table I pc 0.8" in (out / "transfer.md").read_text()
    assert (out / "transfer.png").stat().st_size > 0


def test_a_run_without_results_is_refused(tmp_path: Path, capsys) -> None:
    out = _run(tmp_path)
    (out / "results.json").unlink()
    with pytest.raises(SystemExit) as exit_:
        transfer.main([str(out)], make_evaluator=lambda setup: FakeEvaluator())
    assert exit_.value.code == 2 and "no readable results.json" in capsys.readouterr().err


@pytest.mark.real_server
def test_transfer_onto_a_real_server(rcssserver3d: str, tmp_path: Path, monkeypatch) -> None:
    out = _run(tmp_path)
    monkeypatch.setenv(RCSSSERVER3D_ENV, rcssserver3d)
    assert transfer.main([str(out), "--real", "1", "--repeats", "2"]) == 0
    walks = json.loads((out / "transfer.json").read_text())
    assert walks["target"] == "real server" and walks["real_command"] == rcssserver3d
    assert all(w["status"] == "ok" for g in walks["gaits"] for w in g["walks"])
    assert os.path.getsize(out / "transfer.png") > 0
