"""The optimizer comparison (``python -m optimizer.compare``): equal budgets, every output file,
resume, robust scoring, methods found by looking, and the statistics on data with a known answer."""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_driver import FakeEvaluator, Killed, synthetic_fitness

from gait import GENE_BOUNDS, repair_genes
from optimizer.compare import methods as methods_package
from optimizer.compare.__main__ import main
from optimizer.compare.budget import drive
from optimizer.compare.methods import Problem, discover
from optimizer.compare.statistics import holm, pairwise, summarise
from optimizer.evaluation.pool import EpisodeOutcome, EpisodeTask
from optimizer.run.driver import Driver
from optimizer.run.folder import EpisodeLog
from optimizer.run.transfer_report import reported_gaits
from optimizer.search.protocol import Batch

TINY = [
    "--methods",
    "random,ga-paper",
    "--seeds",
    "2",
    "--budget",
    "14",
    "--population",
    "4",
    "--seed",
    "3",
    "--check-repeats",
    "2",
    "--robust-walks",
    "1",
    "--quiet",
]


def _log(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines()]


def test_a_tiny_comparison_spends_equal_budgets_and_writes_every_file(tmp_path: Path) -> None:
    out = tmp_path / "c"
    assert main([*TINY, "--out", str(out)], make_evaluator=lambda s: FakeEvaluator()) == 0
    logged = _log(out)
    for method in ("random", "ga-paper"):
        for seed in ("s00", "s01"):
            search = [r for r in logged if r["key"].startswith(f"{method}/{seed}/")]
            assert len(search) == 14  # the budget, a batch cut to fit
    checks = [r for r in logged if r["key"].startswith("check/")]
    assert len(checks) == 4 * 2  # counted apart
    runs = list(csv.DictReader((out / "runs.csv").open()))
    assert [(r["method"], r["seed_index"]) for r in runs] == [
        ("random", "0"),
        ("random", "1"),
        ("ga-paper", "0"),
        ("ga-paper", "1"),
    ]
    for run in runs:  # the best is the best of the run's own walks
        own = [r for r in logged if r["key"].startswith(f"{run['method']}/s0{run['seed_index']}/")]
        assert float(run["best_distance"]) == pytest.approx(max(r["distance"] for r in own))
        assert run["check_walks"] == "2" and run["check_falls"] == "0"
    summary = {r["method"]: r for r in csv.DictReader((out / "summary.csv").open())}
    assert set(summary) == {"random", "ga-paper"} and summary["random"]["seeds"] == "2"
    [pair] = list(csv.DictReader((out / "pairs.csv").open()))
    assert (pair["a"], pair["b"]) == ("random", "ga-paper") and 0 <= float(pair["p_holm"]) <= 1
    results = json.loads((out / "results.json").read_text())
    assert len(results["reported"]) == 4 and all(len(r["curve"]) == 14 for r in results["runs"])
    assert "| method | seeds | median | IQR | best | success |" in (out / "comparison.md").read_text()
    assert (out / "convergence.png").stat().st_size > 0


def test_a_killed_comparison_resumes_to_the_same_files(tmp_path: Path) -> None:
    assert main([*TINY, "--out", str(tmp_path / "whole")], make_evaluator=lambda s: FakeEvaluator()) == 0
    with pytest.raises(Killed):
        main([*TINY, "--out", str(tmp_path / "cut")], make_evaluator=lambda s: FakeEvaluator(25))
    resumed = FakeEvaluator()
    assert main(["--resume", str(tmp_path / "cut"), "--quiet"], make_evaluator=lambda s: resumed) == 0
    assert len(resumed.evaluated) == len(_log(tmp_path / "whole")) - 25
    for name in ("runs.csv", "summary.csv", "pairs.csv", "comparison.md", "results.json"):
        assert (tmp_path / "cut" / name).read_text() == (tmp_path / "whole" / name).read_text(), name


def test_robust_scoring_races_each_run_within_its_episode_budget(tmp_path: Path) -> None:
    """Every gait walks once; only those whose first walk could enter the run's top 2 walk twice
    more (keys .../k1, .../k2; the rule itself: tests/test_robust.py), each walk with its own
    dither seed; the run stops once its episodes reach the budget."""
    out = tmp_path / "r"
    argv = ["--methods", "random", "--seeds", "1", "--budget", "20", "--population", "4"]
    argv += ["--robust-walks", "3", "--robust-top", "2", "--check-repeats", "0", "--quiet", "--out", str(out)]
    assert main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    logged = _log(out)
    firsts = [r for r in logged if "/k" not in r["key"]]
    extras = [r for r in logged if "/k" in r["key"]]
    raced = {r["key"].rsplit("/k", 1)[0] for r in extras}
    assert 20 <= len(logged) <= 20 + 2 * 4  # at most the last batch's extra walks past the budget
    assert raced and raced < {r["key"] for r in firsts}  # some gaits raced, not all
    assert all(sum(r["key"].startswith(k + "/k") for r in extras) == 2 for k in raced)
    assert len({r["seed"] for r in logged}) == len(logged)  # every walk its own dither draw


class FallingEvaluator(FakeEvaluator):
    """Every walk falls, after a distance that depends on its seed (so K dithered walks differ)."""

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        for outcome in super().evaluate(tasks):
            distance = 1.0 + (outcome.task.seed % 1000) / 100.0
            yield EpisodeOutcome(
                outcome.task, 0, {**outcome.result, "distance": distance, "fell": True, "fitness": 10.0 * distance}
            )


@pytest.mark.parametrize("robust", [["--robust-walks", "1"], ["--robust-walks", "2", "--robust-quantile", "mean"]])
def test_a_reported_best_says_what_its_own_walks_did(tmp_path: Path, robust: list[str]) -> None:
    """Without a check, optimizer.transfer sets the reported walk beside the new ones: it must be
    the walks that scored the best (their falls, their mean distance), not the score with no fall."""
    out = tmp_path / "f"
    argv = ["--methods", "random", "--seeds", "1", "--budget", "4", "--population", "4", "--check-repeats", "0"]
    assert main([*argv, *robust, "--quiet", "--out", str(out)], make_evaluator=lambda s: FallingEvaluator()) == 0
    results = json.loads((out / "results.json").read_text())
    [reported] = results["reported"]
    [run] = results["runs"]
    own = [r for r in _log(out) if r["key"] == run["best_key"] or r["key"].startswith(run["best_key"] + "/k")]
    assert len(own) == int(robust[1])
    assert reported["walk"]["fell"] is True
    assert reported["walk"]["distance"] == pytest.approx(sum(r["distance"] for r in own) / len(own))
    [gait] = reported_gaits(results)
    assert gait.run_falls == 1 and gait.run_distances == [pytest.approx(reported["walk"]["distance"])]


def test_refusals_name_the_flag(tmp_path: Path, capsys) -> None:
    for flags, said in (
        (["--methods", "gala,nope"], "unknown method(s) nope"),
        (["--methods", "gala,gala"], "named twice"),
        (["--robust-walks", "0"], "--robust-walks"),
    ):
        with pytest.raises(SystemExit) as exit_:
            main([*flags, "--out", str(tmp_path / "x")], make_evaluator=lambda s: FakeEvaluator())
        assert exit_.value.code == 2 and said in capsys.readouterr().err, flags


def test_the_six_methods_are_found_and_a_new_module_adds_one(tmp_path: Path, monkeypatch) -> None:
    assert set(discover()) == {"gala", "ga-dejong", "ga-grefenstette", "ga-paper", "cmaes", "random"}
    (tmp_path / "zigzag.py").write_text(
        "from optimizer.compare.methods import Method\n"
        "from optimizer.compare.methods.random_search import _program\n"
        "METHODS = (Method('zigzag', 'a plug-in', _program),)\n"
    )
    monkeypatch.setattr(methods_package, "__path__", [*methods_package.__path__, str(tmp_path)])
    assert "zigzag" in discover()


@pytest.mark.parametrize("name", sorted(discover()))
def test_every_method_stays_in_the_box_and_is_seeded(name: str) -> None:
    """Its first 60 candidates on the synthetic hill: inside the box and repaired, the same for the
    same seed, others for another."""

    def first(seed: int) -> list[np.ndarray]:
        program = discover()[name].program(Problem(GENE_BOUNDS, repair_genes, seed, 60, 10, True))
        asked, fitness, count = [], None, 0
        while count < 60:
            batch = program.send(fitness)  # type: ignore[arg-type]
            genes = batch.genes[: 60 - count]
            asked.append(genes)
            count += len(genes)
            fitness = np.array([synthetic_fitness(g) for g in genes])
        return asked

    batches = first(7)
    genes = np.concatenate(batches)
    assert len(genes) == 60
    assert np.all(genes >= GENE_BOUNDS[:, 0]) and np.all(genes <= GENE_BOUNDS[:, 1])
    assert np.allclose([repair_genes(g) for g in genes], genes)
    assert all(np.array_equal(a, b) for a, b in zip(batches, first(7)))
    assert not np.array_equal(genes, np.concatenate(first(8)))


def test_a_budget_cuts_the_batch_that_crosses_it(tmp_path: Path) -> None:
    def program():
        for k in range(5):
            yield Batch(f"b{k}", np.full((4, 7), float(k)))

    with EpisodeLog(tmp_path / "episodes.jsonl") as log:
        driver = Driver(FakeEvaluator(), log, run_seed=1)
        cut = drive(driver, program(), 10, "n")
        everything = drive(driver, program(), 100, "o")
    assert [g.key for g in cut][-3:] == ["n/b1/i003", "n/b2/i000", "n/b2/i001"] and len(cut) == 10
    assert len(everything) == 20


@settings(deadline=None, max_examples=40)
@given(st.lists(st.floats(0.0, 10.0, allow_nan=False), min_size=8, max_size=15), st.floats(20.0, 50.0))
def test_a_clearly_better_method_is_found_better_and_identical_ones_are_not(base: list[float], gap: float) -> None:
    better = [b + gap for b in base]
    tests = pairwise({"better": better, "base": base, "same": list(base)})
    by_pair = {(t.a, t.b): t for t in tests}
    assert by_pair["better", "base"].significant() and by_pair["better", "base"].effect == pytest.approx(1.0)
    assert by_pair["base", "same"].p_holm == pytest.approx(1.0) and not by_pair["base", "same"].significant()
    assert by_pair["base", "same"].effect == pytest.approx(0.0)


@given(st.lists(st.floats(0.0, 1.0, allow_nan=False), min_size=1, max_size=12))
def test_holm_adjusts_upwards_keeps_the_order_and_caps_at_one(p_values: list[float]) -> None:
    adjusted = holm(p_values)
    assert all(a >= p and a <= 1.0 for a, p in zip(adjusted, p_values))
    ranked = sorted(range(len(p_values)), key=lambda i: p_values[i])
    assert all(adjusted[ranked[i]] <= adjusted[ranked[i + 1]] for i in range(len(ranked) - 1))
    assert min(adjusted) == pytest.approx(min(1.0, len(p_values) * min(p_values)))


def test_a_summary_gives_median_quartiles_best_and_success() -> None:
    s = summarise("m", [1.0, 2.0, 3.0, 4.0, 5.0], [True, False, False, True, False])
    assert (s.median, s.q1, s.q3, s.best, s.success, s.seeds) == (3.0, 2.0, 4.0, 5.0, 0.4, 5)


@pytest.mark.slow
def test_a_tiny_comparison_on_the_stub(tmp_path: Path) -> None:
    out = tmp_path / "stub"
    argv = [
        "--methods",
        "cmaes,random",
        "--seeds",
        "1",
        "--budget",
        "6",
        "--population",
        "3",
        "--walk-time",
        "2",
        "--check-repeats",
        "2",
        "--workers",
        "2",
        "--seed",
        "1",
        "--quiet",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    logged = _log(out)
    checks = [r for r in logged if r["key"].startswith("check/")]
    assert all(r["status"] == "ok" for r in logged) and len(checks) == 2 * 2
    for method in ("cmaes", "random"):  # the budget in episodes, raced walks included
        assert 6 <= sum(r["key"].startswith(method + "/") for r in logged) <= 6 + 4 * 3
    assert all(0 < r["time"] <= 2.0 for r in logged)
    assert all(r["track"] and r["drift"] is not None for r in checks)  # check walks are traced
    assert len(list(csv.DictReader((out / "runs.csv").open()))) == 2
