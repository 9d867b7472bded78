"""The transfer report (``python -m optimizer.transfer``): which gaits a run reported, walked again
elsewhere, with every output file; on a real server where one is configured."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest
from test_driver import FakeEvaluator

from gait import load_gait
from optimizer.cli import gala_command as gala_command
from optimizer.cli import transfer_command as transfer
from optimizer.episode import DEFAULT_START
from optimizer.episode.real_server import RCSSSERVER3D_ENV
from optimizer.evaluation.pool import EpisodeOutcome
from optimizer.evaluation.record import EpisodeRecord
from optimizer.run import transfer_report
from optimizer.run.session import EvaluationSetup
from optimizer.run.walk_card import (
    REAL_SERVER,
    STAND_IN,
    CardWalk,
    WalkCard,
    read_card,
    track_in_start_frame,
    write_card,
)

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
    "--refine",
    "20",
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
    first, second = transfer_report.reported_gaits(results)
    assert first.names == ["Table I pc 0.8"] and first.run_distances == [2.0, 1.0] and first.run_falls == 1
    assert second.names == ["Table I pc 0.3", "fastest"] and second.run_distances == [4.0] and second.run_falls == 0
    assert first.files == ["best_gait-pc0.8.json", "best_gait.json"]  # which row best_gait.json holds: by genes
    assert second.files == ["best_gait-pc0.3.json", "best_gait.json", "fastest_gait.json"]
    [ga] = transfer_report.reported_gaits(
        {"best_genes": [3.0] * 7, "check": None, "best_episode": {"distance": 1.5, "fell": True}}
    )
    assert ga.name == "GA best" and ga.run_distances == [1.5] and ga.run_falls == 1 and ga.files == ["best_gait.json"]
    [compared] = transfer_report.reported_gaits({"reported": [{"name": "gala s00", "genes": [3.0] * 7}]})
    assert compared.files == []  # a comparison writes no gait file


def test_transfer_walks_every_gait_and_writes_its_files(tmp_path: Path) -> None:
    out = _run(tmp_path)
    setups: list[EvaluationSetup] = []
    evaluator = FakeEvaluator()

    def make(setup: EvaluationSetup) -> FakeEvaluator:
        setups.append(setup)
        return evaluator

    assert transfer.main([str(out), "--repeats", "3"], make_evaluator=make) == 0
    results = json.loads((out / "results.json").read_text())
    gaits = transfer_report.reported_gaits(results)
    rows = list(csv.DictReader((out / "transfer.csv").open()))
    assert [r["gait"] for r in rows] == [g.name for g in gaits] and len(rows) >= 2
    assert len(evaluator.evaluated) == 3 * len(gaits) and all(r["walks"] == "3" for r in rows)
    for row in rows:  # the fake's distance depends on the genes only: the run's figure comes back
        assert float(row["mean_ratio"]) == pytest.approx(1.0) and row["falls"] == "0"
    walks = json.loads((out / "transfer.json").read_text())
    assert walks["target"] == "stand-in" and walks["run_server"] == "stand-in"
    assert [len(g["walks"]) for g in walks["gaits"]] == [3] * len(gaits)
    # as the run's checks: from starts moved within its check jitter, each walk with its own dither draw
    settings = json.loads((out / "manifest.json").read_text())["settings"]
    assert setups[0].command_noise == settings["command_noise"] > 0 and walks["command_noise"] > 0
    starts = [tuple(w["start"]) for g in walks["gaits"] for w in g["walks"]]
    jitter = settings["check_jitter"]
    assert all(abs(s[i] - DEFAULT_START[i]) <= jitter[i] for s in starts for i in range(3)) and any(jitter)
    assert len(set(starts)) == len(starts)
    assert len({w["seed"] for g in walks["gaits"] for w in g["walks"]}) == 3 * len(gaits)
    assert setups[0].real_command is None and setups[0].start == DEFAULT_START
    assert "| Table I pc 0.8" in (out / "transfer.md").read_text()
    assert (out / "transfer.png").stat().st_size > 0


class TracingFake(FakeEvaluator):
    """The fake's walks, with a straight track drifting 0.1 m left where a trace is asked for."""

    def __init__(self) -> None:
        super().__init__()
        self.traced: list[bool] = []

    def evaluate(self, tasks):
        for outcome in super().evaluate(tasks):
            self.traced.append(outcome.task.trace)
            result = dict(outcome.result)
            if outcome.task.trace:
                x0, y0, _ = outcome.task.start
                d = result["distance"]
                result.update(drift=0.1, heading_change=1.0, track=[[0.0, x0, y0, 0.35, 1.0, 0.0]])
                result["track"].append([15.0, x0 + d, y0 + 0.1, 0.35, 1.0, 1.0])
            yield EpisodeOutcome(outcome.task, outcome.worker, result)


def test_a_tfs_start_hand_over_is_walked_as_one_beside_the_tfs_rows(tmp_path: Path) -> None:
    """The main job's refined walk is a tfs-start gait among TFS rows: the transfer walks each in
    its own family, and its table has the gene columns of both (a row's start genes left empty)."""
    out = _run(tmp_path)
    assert json.loads((out / "results.json").read_text())["fastest_episode"]["family"] == "tfs-start"
    evaluator = FakeEvaluator()
    tasks: list = []
    original = evaluator.evaluate

    def spying(batch):
        tasks.extend(batch)
        return original(batch)

    evaluator.evaluate = spying  # type: ignore[method-assign]
    assert transfer.main([str(out), "--repeats", "2"], make_evaluator=lambda setup: evaluator) == 0
    gaits = transfer_report.reported_gaits(json.loads((out / "results.json").read_text()))
    expected = [None] * (len(gaits) - 1) + ["tfs-start"]  # the rows, then the fastest walk
    families = {t.key.split("/")[1]: t.family for t in tasks}
    assert [families[f"g{j}"] for j in range(len(gaits))] == expected
    rows = {r["gait"]: r for r in csv.DictReader((out / "transfer.csv").open())}
    assert rows["fastest"]["gene_s_w"] != "" and rows["Table I pc 0.8"]["gene_s_w"] == ""
    assert rows["fastest"]["gene_w"] != "" and rows["Table I pc 0.8"]["gene_w"] != ""
    document = json.loads((out / "transfer.json").read_text())
    assert [g.get("family") for g in document["gaits"]] == expected
    assert json.loads((out / "fastest_gait.card.json").read_text())["family"] == "tfs-start"


def test_transfer_puts_its_walks_on_the_cards_beside_the_gait_files(tmp_path: Path) -> None:
    out = _run(tmp_path)
    fastest = out / "fastest_gait.json"
    genes = tuple(float(g) for g in load_gait(fastest).as_array())
    earlier = (CardWalk(7.0, True, 9.0, key="earlier/r00"),)
    write_card(WalkCard("fastest walk", genes, 15.0, 0.0, {REAL_SERVER: earlier}), fastest)
    evaluator = TracingFake()
    assert transfer.main([str(out), "--repeats", "3"], make_evaluator=lambda setup: evaluator) == 0
    assert evaluator.traced and all(evaluator.traced)

    card = read_card(fastest)
    assert card is not None and card.name == "fastest walk"  # the card was updated, not replaced
    assert list(card.sides) == [REAL_SERVER, STAND_IN] and card.sides[REAL_SERVER] == earlier
    new = card.sides[STAND_IN]
    assert len(new) == 3 and all(w.track is not None and w.drift == 0.1 and w.heading is not None for w in new)
    assert card.summary(STAND_IN)["drawn"] == 3 and card.summary(REAL_SERVER)["falls"] == 1
    assert "| | real server | stand-in |" in (out / "fastest_gait.card.md").read_text()

    results = json.loads((out / "results.json").read_text())
    for gait in transfer_report.reported_gaits(results):
        files = transfer_report.gait_files(out, gait)
        assert files  # a GALA run writes every gait it reports
        for path in files:
            written = read_card(path)
            assert written is not None and written.genes == gait.genes
            assert [w.key for w in written.sides[STAND_IN]] == [w.key for w in gait_walks(out, gait)]
    for row in results["rows"]:  # each row's own file got a card of just the new walks
        row_card = read_card(out / f"best_gait-pc{row['crossover']:g}.json")
        assert row_card is not None and list(row_card.sides) == [STAND_IN]
    best = read_card(out / "best_gait.json")
    assert best is not None and best.genes == tuple(float(g) for g in load_gait(out / "best_gait.json").as_array())


def gait_walks(out: Path, gait: transfer_report.ReportedGait) -> list[EpisodeRecord]:
    """The gait's walks as transfer.json lists them."""
    [entry] = [g for g in json.loads((out / "transfer.json").read_text())["gaits"] if tuple(g["genes"]) == gait.genes]
    return [EpisodeRecord.from_json(w) for w in entry["walks"]]


def test_a_card_of_other_genes_is_replaced_with_a_note(tmp_path: Path, capsys) -> None:
    out = _run(tmp_path)
    fastest = out / "fastest_gait.json"
    stale = (CardWalk(1.0, False, 15.0),)
    write_card(WalkCard("old", (0.0,) * 7, 15.0, 0.0, {REAL_SERVER: stale}), fastest)
    assert transfer.main([str(out), "--repeats", "2"], make_evaluator=lambda setup: TracingFake()) == 0
    card = read_card(fastest)
    assert card is not None and list(card.sides) == [STAND_IN] and card.genes != (0.0,) * 7
    assert "fastest_gait.json: its card was of other genes" in capsys.readouterr().err


@pytest.mark.slow
def test_transfer_on_the_embedded_stand_in_writes_the_card_of_its_walks(tmp_path: Path) -> None:
    out = tmp_path / "run"
    fake = lambda setup: FakeEvaluator()  # noqa: E731 - the run's search is not what is tested
    assert gala_command.main([*TINY, "--walk-time", "2", "--out", str(out)], make_evaluator=fake) == 0
    assert transfer.main([str(out), "--repeats", "2"]) == 0  # the stub's real walks, traced
    card = read_card(out / "fastest_gait.json")
    assert card is not None and list(card.sides) == [STAND_IN] and card.walk_time == 2.0
    walks = card.sides[STAND_IN]
    assert len(walks) == 2 and all(w.ran and w.track and w.drift is not None for w in walks)
    for walk in walks:  # the track drawn in its start's frame ends where the judge scored the walk
        forward, left = track_in_start_frame(walk.track, walk.heading)
        assert forward[-1] == pytest.approx(walk.distance, abs=1e-3)
        assert left[-1] == pytest.approx(walk.drift, abs=1e-3)
    assert (out / "fastest_gait.card.png").read_bytes().startswith(b"\x89PNG")


def test_a_run_from_before_the_dither_is_walked_from_moved_starts(tmp_path: Path) -> None:
    out = _run(tmp_path)
    manifest = json.loads((out / "manifest.json").read_text())
    del manifest["settings"]["command_noise"]
    del manifest["settings_version"]  # a run from before the dither stored no settings version
    manifest["settings"]["check_jitter"] = [0.0, 0.0, 0.0]
    (out / "manifest.json").write_text(json.dumps(manifest))
    setups: list[EvaluationSetup] = []

    def make(setup: EvaluationSetup) -> TracingFake:
        setups.append(setup)
        return TracingFake()

    assert transfer.main([str(out), "--repeats", "3"], make_evaluator=make) == 0
    walks = json.loads((out / "transfer.json").read_text())
    starts = {tuple(w["start"]) for g in walks["gaits"] for w in g["walks"]}
    assert len(starts) == 3 * len(walks["gaits"])  # each its own, within the real server's beam noise
    assert all(abs(x - DEFAULT_START[0]) <= 0.05 and abs(h) <= 10 for x, _, h in starts)
    assert setups[0].command_noise == 0.0


def test_walks_on_a_real_server_are_undithered_and_make_the_cards_real_side(tmp_path: Path) -> None:
    out = _run(tmp_path)
    setups: list[EvaluationSetup] = []

    def make(setup: EvaluationSetup) -> TracingFake:
        setups.append(setup)
        return TracingFake()

    assert transfer.main([str(out), "--server", "127.0.0.1:3100:3200", "--repeats", "2"], make_evaluator=make) == 0
    assert setups[0].command_noise == 0.0 and setups[0].servers  # the real server has its own spread
    card = read_card(out / "fastest_gait.json")
    assert card is not None and list(card.sides)[-1] == REAL_SERVER and len(card.sides[REAL_SERVER]) == 2


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
