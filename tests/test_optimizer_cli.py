"""The command lines: refused input names its flag; a run writes its folder; a killed run resumed
with --resume ends with the same files as an uninterrupted one. A fake evaluator stands in for
the workers (no physics); the end-to-end runs on the stub are the lead's slow tests."""

from __future__ import annotations

import json
import os
import signal
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from test_driver import FakeEvaluator, Killed

from gait import DEFAULT_GAIT_PATH, GENE_BOUNDS, LEGACY_GENE_BOUNDS, TFS, TFS_PLUS, load_gait
from optimizer import job
from optimizer.cli import episode_command as episode_command
from optimizer.cli import ga_command as ga_command
from optimizer.cli import gala_command as gala_command
from optimizer.episode import EpisodeResult
from optimizer.evaluation.pool import EpisodeOutcome
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run import repeats
from optimizer.run.report import read_table_csv
from optimizer.run.robust import ScoredGait, jittered_starts
from optimizer.run.stability import check_candidates
from optimizer.run.walk_card import REAL_SERVER, STAND_IN, read_card
from optimizer.search.config import GAConfig, GALAConfig
from optimizer.search.ga import GARun
from optimizer.search.ga import planned_episodes as ga_episodes
from optimizer.search.gala import GALA
from optimizer.search.refinement import Arm, heat_gaits, refinement_arms
from optimizer.settings import LEGACY, Settings, defaults

BOUNDS = [[0.0, 1.0]] * 3
#: the paper's protocol, small: one walk a gait, no refinement phase
SMALL = ["--population", "6", "--iterations", "3", "--generations", "2", "--quiet"]
SMALL += ["--robust-walks", "1", "--refine", "0"]


def refused(main, argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as exit_info:
        main(argv, make_evaluator=lambda setup: pytest.fail("must not start evaluating"))
    assert exit_info.value.code == 2
    return capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, flag, why",
    [
        (["--crossover", "1.5"], "--crossover", "[0, 1]"),
        (["--crossover", "abc"], "--crossover", "number"),
        (["--workers", "0"], "--workers", ">= 1"),
        (["--population", "-3"], "--population", ">= 1"),
        (["--walk-time", "0"], "--walk-time", "> 0"),
        (["--scheme", "lrx"], "--scheme", "invalid choice"),
        (["--server", "localhost:3100"], "--server", "HOST:AGENT_PORT:MONITOR_PORT"),
        (["--server", "localhost:3100:99999"], "--server", "outside 1-65535"),
        (["--crossover", "0.8", "--crossover", "0.8"], "--crossover", "given twice"),
        (["--server", "h:1:2", "--server", "h:3:4", "--workers", "3"], "--workers 3", "one worker per server"),
        (["--check-repeats", "-1"], "--check-repeats", ">= 0"),
        (["--check-repeats", "2.5"], "--check-repeats", "whole number"),
        (["--check-jitter", "0.1", "0.1"], "--check-jitter", "expected 3 arguments"),
        (["--check-jitter", "0.1", "0.1", "-2"], "--check-jitter", ">= 0"),
        (["--check-confirm", "-1"], "--check-confirm", ">= 0"),
        (["--hand-over-walks", "-1"], "--hand-over-walks", ">= 0"),
        (["--hand-over-walks", "1.5"], "--hand-over-walks", "whole number"),
        (["--refine-quantile", "1.5"], "--refine-quantile", "[0, 1]"),
    ],
)
def test_gala_refuses_a_wrong_value_naming_the_flag(argv, flag, why, capsys) -> None:
    err = refused(gala_command.main, argv, capsys)
    assert flag in err and why in err


def test_only_a_command_that_hands_over_a_fastest_walk_takes_check_confirm(capsys) -> None:
    """The GA hands over its best gait, checked, and no fastest walk: a confirmation flag would do
    nothing there, so it has none."""
    assert "unrecognized arguments: --check-confirm" in refused(ga_command.main, ["--check-confirm", "5"], capsys)
    assert "unrecognized arguments: --hand-over-walks" in refused(ga_command.main, ["--hand-over-walks", "50"], capsys)


def test_resume_needs_a_run_folder_and_the_same_settings(tmp_path: Path, capsys) -> None:
    assert "no manifest.json" in refused(gala_command.main, ["--resume", str(tmp_path)], capsys)
    assert "no manifest.json" in refused(gala_command.main, ["--resume", str(tmp_path / "none")], capsys)
    out = tmp_path / "run"
    assert (
        gala_command.main(
            ["--crossover", "0.8", *SMALL, "--seed", "3", "--out", str(out)],
            make_evaluator=lambda setup: FakeEvaluator(),
        )
        == 0
    )
    err = refused(gala_command.main, ["--resume", str(out), "--population", "7"], capsys)
    assert "--population 7 conflicts with the run's --population 6" in err
    err = refused(gala_command.main, ["--resume", str(out), "--seed", "4"], capsys)
    assert "--seed 4 conflicts" in err
    err = refused(gala_command.main, ["--resume", str(out), "--budget", "quick"], capsys)
    assert "conflicts" in err
    err = refused(gala_command.main, ["--resume", str(out), "--no-elitism"], capsys)
    assert "--no-elitism conflicts with the run's --elitism" in err
    err = refused(gala_command.main, ["--resume", str(out), "--start", "-7", "0", "0"], capsys)
    assert "--start -7.0 0.0 0.0 conflicts with the run's --start -5.0 0.0 0.0" in err
    err = refused(gala_command.main, ["--resume", str(out), "--bounds", "legacy"], capsys)
    assert "--bounds legacy conflicts with the run's --bounds robot" in err
    assert "is a gala run, not a ga run" in refused(ga_command.main, ["--resume", str(out)], capsys)
    assert "already holds a run" in refused(gala_command.main, ["--out", str(out)], capsys)
    assert "not allowed with" in refused(gala_command.main, ["--out", "x", "--resume", str(out)], capsys)


def test_a_gala_run_writes_its_folder(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    setups = []

    def fake(setup):
        setups.append(setup)
        return FakeEvaluator()

    argv = [
        "--crossover",
        "0.8",
        "--crossover",
        "0.3",
        *SMALL,
        "--seed",
        "9",
        "--out",
        str(out),
        "--server",
        "127.0.0.1:3100:3200",
        "--server",
        "127.0.0.1:3101:3201",
        "--walk-time",
        "5",
    ]
    assert gala_command.main(argv, make_evaluator=fake) == 0
    assert setups[0].workers == 2 and [s.agent_port for s in setups[0].servers] == [3100, 3101]
    assert setups[0].walk_time == 5.0 and setups[0].seed == 9 and setups[0].start == (-5.0, 0.0, 0.0)

    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["crossover"] == [0.8, 0.3] and manifest["settings"]["population"] == 6
    assert manifest["runtime"]["servers"] == ["127.0.0.1:3100:3200", "127.0.0.1:3101:3201"]
    rows = read_table_csv(out / "table1.csv")
    results = json.loads((out / "results.json").read_text())["rows"]
    assert [r.crossover_rate for r in rows] == [0.8, 0.3]
    for row, result in zip(rows, results):
        assert row.best_fitness == result["best_fitness"]
        assert row.distance_m == result["best_episode"]["distance"] == result["best_fitness"] / 10
        assert result["best_episode"]["genes"] == result["best_genes"]
    for name in ("gala-pc0.8.png", "ga-pc0.8.png", "gala-pc0.3.png", "ga-pc0.3.png", "table1.md"):
        assert (out / name).stat().st_size > 0
    best_row = max(results, key=lambda r: r["best_fitness"])
    assert list(load_gait(out / "best_gait.json").genes) == best_row["best_genes"]
    assert list(load_gait(out / "best_gait-pc0.3.json").genes) == results[1]["best_genes"]
    episodes = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    searched = [r for r in episodes if not r["key"].startswith("check/")]
    search = Settings.from_stored(manifest["settings"], "gala").search
    assert len(searched) == 2 * job.planned_episodes(job.gala_config(search))
    by_key = {r["key"]: r for r in episodes}
    for row, result in zip(rows, results):  # each row's best walked 10 times from moved starts
        key = result["best_episode"]["key"]
        assert [w["key"] for w in result["check"]["walks"]] == [f"check/{key}/r{j:02d}" for j in range(10)]
        repeats = [by_key[w["key"]] for w in result["check"]["walks"]]
        assert row.repeats == 10 and row.repeat_falls == 0
        distances = [r["distance"] for r in repeats]
        assert row.repeat_min_distance_m == min(distances) and row.repeat_max_distance_m == max(distances)
        assert row.repeat_mean_distance_m == pytest.approx(sum(distances) / len(distances))
        assert result["check"]["std_distance"] == pytest.approx(float(np.std(distances, ddof=1)))
        # each from a start of its own, with a dither seed of its own
        assert all(r["genes"] == result["best_genes"] and len(r["start"]) == 3 for r in repeats)
        assert len({tuple(r["start"]) for r in repeats}) == len({r["seed"] for r in repeats}) == 10
    for gait in ("best_gait.json", "best_gait-pc0.8.json", "best_gait-pc0.3.json", "fastest_gait.json"):
        card = read_card(out / gait)
        assert card is not None and card.genes == load_gait(out / gait).genes
        # the run walked on servers given as --server; the fastest walk was handed over after 200
        assert card.summary(REAL_SERVER)["walks"] == (200 if gait == "fastest_gait.json" else 10)
    printed = capsys.readouterr().out
    assert "| 0.80 |" in printed and "| 0/10 |" in printed


def test_the_farthest_walk_without_a_fall_is_kept(tmp_path: Path, capsys) -> None:
    class FallingWhenFast(FakeEvaluator):
        """The farther half of the walks end in a fall."""

        def evaluate(self, tasks):
            for outcome in super().evaluate(tasks):
                fell = outcome.result["fitness"] > 25.0
                yield EpisodeOutcome(outcome.task, outcome.worker, {**outcome.result, "fell": fell})

    out = tmp_path / "run"
    argv = ["--crossover", "0.8", *SMALL, "--seed", "4", "--out", str(out)]
    assert gala_command.main(argv, make_evaluator=lambda s: FallingWhenFast()) == 0
    records = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    records = [r for r in records if r["kind"] == "search"]  # the search's walks, not the checks'
    assert any(r["fell"] for r in records) and any(not r["fell"] for r in records)
    fastest = max((r for r in records if not r["fell"]), key=lambda r: r["fitness"])
    assert json.loads((out / "results.json").read_text())["fastest_episode"] == fastest
    assert list(load_gait(out / "fastest_gait.json").genes) == fastest["genes"]
    assert f"{fastest['distance']:.2f} m" in capsys.readouterr().out


def test_fastest_gait_is_the_fastest_walk_that_passes_its_check(tmp_path: Path, capsys) -> None:
    class FastestIsFragile(FakeEvaluator):
        """Walks over 25 fall; so does every check walk of the fastest gait under 25."""

        fragile: tuple | None = None

        def evaluate(self, tasks):
            for outcome in super().evaluate(tasks):
                fitness = outcome.result["fitness"]
                fell = fitness > 25.0 or (outcome.task.kind is WalkKind.CHECK and outcome.task.genes == self.fragile)
                yield EpisodeOutcome(outcome.task, outcome.worker, {**outcome.result, "fell": fell})

    # the fragile gait: the fastest walk under 25 of the same run without checks
    plain = tmp_path / "plain"
    argv = ["--crossover", "0.8", *SMALL, "--seed", "4"]
    evaluator = FastestIsFragile()
    assert (
        gala_command.main([*argv, "--out", str(plain), "--check-repeats", "0"], make_evaluator=lambda s: evaluator) == 0
    )
    first = json.loads((plain / "results.json").read_text())["fastest_episode"]
    FastestIsFragile.fragile = tuple(first["genes"])
    capsys.readouterr()

    out = tmp_path / "run"
    assert gala_command.main([*argv, "--out", str(out)], make_evaluator=lambda s: FastestIsFragile()) == 0
    records = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    searched = [r for r in records if r["kind"] == "search"]
    runner_up = max((r for r in searched if not r["fell"] and r["genes"] != first["genes"]), key=lambda r: r["fitness"])
    results = json.loads((out / "results.json").read_text())
    assert results["fastest_episode"]["key"] == results["fastest_check"]["key"] == runner_up["key"]
    assert results["fastest_check"]["falls"] == 0 and results["fastest_check"]["repeats"] == 200  # handed over
    assert list(load_gait(out / "fastest_gait.json").genes) == runner_up["genes"]
    fragile_checks = [r for r in records if r["key"].startswith(f"check/{first['key']}/")]
    assert len(fragile_checks) == 10 and all(r["fell"] for r in fragile_checks)  # not confirmed: it fell
    d = runner_up["distance"]
    assert f"fastest walk that held: fell in 0 of 200 check walks, {d:.2f}-{d:.2f} m" in capsys.readouterr().out


def test_without_checks_the_table_has_no_check_figures(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["--crossover", "0.8", *SMALL, "--seed", "4", "--out", str(out), "--check-repeats", "0"]
    assert gala_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    records = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert not any("start" in r or r["key"].startswith("check/") for r in records)
    [row] = read_table_csv(out / "table1.csv")
    assert (row.repeats, row.repeat_falls, row.repeat_min_distance_m) == (None, None, None)
    assert "| - | - |" in (out / "table1.md").read_text()
    results = json.loads((out / "results.json").read_text())
    assert results["fastest_check"] is None and results["rows"][0]["check"] is None
    assert results["fastest_episode"] == max(records, key=lambda r: r["fitness"])


def test_a_killed_gala_run_resumes_to_the_same_files(tmp_path: Path) -> None:
    argv = ["--crossover", "0.8", "--crossover", "0.5", *SMALL, "--seed", "11"]
    assert gala_command.main([*argv, "--out", str(tmp_path / "whole")], make_evaluator=lambda s: FakeEvaluator()) == 0
    with pytest.raises(Killed):
        gala_command.main([*argv, "--out", str(tmp_path / "cut")], make_evaluator=lambda s: FakeEvaluator(30))
    resumed = FakeEvaluator()
    assert gala_command.main(["--resume", str(tmp_path / "cut"), "--quiet"], make_evaluator=lambda s: resumed) == 0
    assert len(resumed.evaluated) == len((tmp_path / "whole" / "episodes.jsonl").read_text().splitlines()) - 30
    for name in ("results.json", "table1.csv", "table1.md", "best_gait.json", "fastest_gait.json"):
        assert (tmp_path / "cut" / name).read_text() == (tmp_path / "whole" / name).read_text(), name


def test_a_run_made_before_start_checks_and_the_robot_box_existed_resumes_as_it_began(tmp_path: Path) -> None:
    """From the origin, unchecked, in the legacy gene box."""
    out = tmp_path / "old"
    argv = ["--crossover", "0.8", *SMALL, "--seed", "5", "--bounds", "legacy"]
    with pytest.raises(Killed):
        gala_command.main([*argv, "--out", str(out)], make_evaluator=lambda s: FakeEvaluator(10))
    manifest = json.loads((out / "manifest.json").read_text())
    earlier = ("start", "check_repeats", "check_jitter", "bounds")  # what an earlier version did not write
    earlier += ("robust_walks", "robust_top", "robust_quantile", "command_noise", "refine", "refine_sigma")
    earlier += ("refine_population", "family", "refine_patience", "refine_family")
    for name in earlier:
        del manifest["settings"][name]
    del manifest["settings_version"]  # nor the version of its settings
    (out / "manifest.json").write_text(json.dumps(manifest))
    setups = []

    def fake(setup):
        setups.append(setup)
        return FakeEvaluator()

    assert gala_command.main(["--resume", str(out), "--quiet"], make_evaluator=fake) == 0
    assert setups[0].start == (0.0, 0.0, 0.0) and setups[0].command_noise == 0.0  # one undithered walk a gait
    keys = [json.loads(line)["key"] for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert not any("/k" in k or k.startswith("refine") for k in keys)  # no racing, no refinement
    assert "check/" not in (out / "episodes.jsonl").read_text()
    genes = np.array([r["genes"] for r in map(json.loads, (out / "episodes.jsonl").read_text().splitlines())])
    assert np.all(genes >= LEGACY_GENE_BOUNDS[:, 0]) and np.all(genes <= LEGACY_GENE_BOUNDS[:, 1])


def test_a_new_run_searches_the_box_derived_from_the_robot(tmp_path: Path) -> None:
    out = tmp_path / "new"
    assert (
        gala_command.main(
            ["--crossover", "0.8", *SMALL, "--seed", "5", "--out", str(out), "--quiet"],
            make_evaluator=lambda s: FakeEvaluator(),
        )
        == 0
    )
    assert json.loads((out / "manifest.json").read_text())["settings"]["bounds"] == "robot"
    genes = np.array([r["genes"] for r in map(json.loads, (out / "episodes.jsonl").read_text().splitlines())])
    assert np.all(genes >= GENE_BOUNDS[:, 0]) and np.all(genes <= GENE_BOUNDS[:, 1])
    outside_legacy = (genes < LEGACY_GENE_BOUNDS[:, 0]) | (genes > LEGACY_GENE_BOUNDS[:, 1])
    assert outside_legacy.any(axis=0)[[0, 1, 4]].all()  # c_h, c_k and C reach beyond the old box


def test_sigterm_ends_a_run_as_ctrl_c_does(tmp_path: Path, capsys) -> None:
    class Terminated(FakeEvaluator):
        def evaluate(self, tasks):
            yield from list(super().evaluate(tasks))[:3]
            os.kill(os.getpid(), signal.SIGTERM)  # what a scheduler sends to stop a job

    before = signal.getsignal(signal.SIGTERM)
    code = gala_command.main(
        ["--crossover", "0.8", *SMALL, "--out", str(tmp_path / "r")], make_evaluator=lambda s: Terminated()
    )
    assert code == 130
    assert f"--resume {tmp_path / 'r'}" in capsys.readouterr().err
    assert len((tmp_path / "r" / "episodes.jsonl").read_text().splitlines()) == 3  # nothing finished is lost
    assert signal.getsignal(signal.SIGTERM) is before  # the handler is the run's alone


def test_an_interrupted_run_says_how_to_resume(tmp_path: Path, capsys) -> None:
    class Interrupted(FakeEvaluator):
        def evaluate(self, tasks):
            raise KeyboardInterrupt

    code = gala_command.main(
        ["--crossover", "0.8", *SMALL, "--out", str(tmp_path / "r")], make_evaluator=lambda s: Interrupted()
    )
    assert code == 130
    assert f"--resume {tmp_path / 'r'}" in capsys.readouterr().err


def test_ga_presets_and_its_folder(tmp_path: Path, capsys) -> None:
    out = tmp_path / "ga"
    argv = [
        "--preset",
        "dejong",
        "--population",
        "6",
        "--generations",
        "3",
        "--quiet",
        "--seed",
        "2",
        "--out",
        str(out),
    ]
    assert ga_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    settings = json.loads((out / "manifest.json").read_text())["settings"]
    assert (settings["crossover"], settings["mutation"], settings["preset"]) == (0.6, 0.001, "dejong")
    results = json.loads((out / "results.json").read_text())
    assert len(results["history"]) == 3 and (out / "ga.png").stat().st_size > 0
    assert list(load_gait(out / "best_gait.json").genes) == results["best_genes"]
    episodes = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    search = [r for r in episodes if r["kind"] == "search"]
    firsts = [r for r in search if "/k" not in r["key"]]
    assert len(firsts) == 6 + 2 * 5  # every gait walks once; the raced ones 4 more times (default 5 walks)
    assert {sum(e["key"].startswith(r["key"] + "/k") for e in search) for r in firsts} == {0, 4}
    repeats = [r for r in episodes if r["key"].startswith(f"check/{results['best_episode']['key']}/")]
    assert len(repeats) == 10 == results["check"]["repeats"] == len(episodes) - len(search)  # the best, checked
    assert all(r["genes"] == results["best_genes"] for r in repeats)
    printed = capsys.readouterr().out
    assert "best fitness" in printed and "fell in 0 of 10 check walks" in printed
    assert read_card(out / "best_gait.json") is not None
    err = refused(ga_command.main, ["--resume", str(out), "--preset", "grefenstette"], capsys)
    assert "--preset grefenstette conflicts with the run's --preset dejong" in err
    assert "--mutation" in refused(ga_command.main, ["--mutation", "2"], capsys)


@pytest.mark.parametrize("restart, elitism", [(False, True), (True, True), (False, False), (True, False)])
def test_planned_episodes_match_what_the_searches_ask(restart: bool, elitism: bool) -> None:
    ga = GAConfig(population_size=5, generations=3, elitism=elitism)
    config = GALAConfig(ga=ga, iterations=4, generations_per_iteration=2, restart_each_iteration=restart)
    asked: list[str] = []

    def count(search):
        while not search.done:
            batch = search.ask()
            asked.extend(c.key for c in batch)
            search.tell({c.key: float(sum(c.genes)) for c in batch})

    count(GALA(BOUNDS, config, 0.5, 1))
    assert len(asked) == job.planned_episodes(config)
    asked.clear()
    count(GARun(BOUNDS, ga, 1))
    assert len(asked) == ga_episodes(ga)


class _RecordingRunner:
    """Stands in for EpisodeRunner: records the start of every walk; ``fail_at`` fails one."""

    walks: list = []
    fail_at: int | None = None

    def __init__(self, config, server, seed):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        pass

    def evaluate(self, params, start):
        self.walks.append(start)
        if len(self.walks) - 1 == self.fail_at:
            return EpisodeResult.failed("server gone", 1.0)
        return EpisodeResult(float(len(self.walks)), len(self.walks) == 2, 15.0, 10.0 * len(self.walks), 0.1)


def test_episode_command_takes_a_start(monkeypatch, capsys) -> None:
    _RecordingRunner.walks, _RecordingRunner.fail_at = [], None
    monkeypatch.setattr(repeats, "EpisodeRunner", _RecordingRunner)
    assert episode_command.main(["--start", "-6", "3.5", "90", "--json"]) == 0
    assert _RecordingRunner.walks == [(-6.0, 3.5, 90.0)]
    assert json.loads(capsys.readouterr().out)["distance"] == 1.0


def test_episode_command_refuses_a_bad_gait_file_or_server(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "gait.json"
    bad.write_text("{}")
    for argv, flag in (
        (["--gait", str(bad)], "--gait"),
        (["--server", "nowhere"], "--server"),
        (["--agent-mode", "thread"], "--agent-mode"),
        (["--start", "1", "2"], "--start"),
        (["--start", "1", "2", "nan"], "--start"),
        (["--repeat", "0"], "--repeat"),
        (["--jitter", "0.1", "-0.1", "0"], "--jitter"),
        (["--jitter", "0.1", "0.1"], "--jitter"),
    ):
        with pytest.raises(SystemExit) as exit_info:
            episode_command.main(argv)
        assert exit_info.value.code == 2
        assert flag in capsys.readouterr().err


def test_episode_command_repeats_from_jittered_starts(monkeypatch, capsys) -> None:
    _RecordingRunner.walks, _RecordingRunner.fail_at = [], None
    monkeypatch.setattr(repeats, "EpisodeRunner", _RecordingRunner)
    argv = ["--start", "-6", "3", "90", "--repeat", "4", "--jitter", "0.1", "0.2", "5", "--seed", "7"]
    assert episode_command.main([*argv, "--json"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    expected = jittered_starts((-6.0, 3.0, 90.0), (0.1, 0.2, 5.0), 4, seed=7)
    assert [tuple(line["start"]) for line in lines] == expected
    assert _RecordingRunner.walks == expected
    assert [line["distance"] for line in lines] == [1.0, 2.0, 3.0, 4.0]

    _RecordingRunner.walks, _RecordingRunner.fail_at = [], 2
    assert episode_command.main(argv) == 1  # one walk could not be run
    out, err = capsys.readouterr()
    assert "could not be run: server gone" in err
    assert len(out.splitlines()) == 4  # the three that ran, then the summary
    assert out.splitlines()[-1] == (
        "3 walks: 1 fell; distance 1.000-4.000 m, mean 2.333 m; mean speed 0.100 m/s; 1 could not be run"
    )


def test_the_refinement_phase_searches_on_from_the_best_and_leaves_table_i_alone(tmp_path: Path) -> None:
    """Robust scoring and the refinement phase (the defaults): Table I is the same with or without
    the refinement, which tries exactly --refine more gaits (CMA-ES from the fastest gait that held,
    once per step, the gaits shared) and on the synthetic hill ends at least as high as the rows did."""
    base = ["--crossover", "0.8", "--population", "6", "--iterations", "3", "--generations", "2"]
    base += ["--seed", "4", "--quiet", "--check-repeats", "3"]
    for name, refine in (("rows", "0"), ("refined", "40")):
        argv = [*base, "--refine", refine, "--out", str(tmp_path / name)]
        assert gala_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    rows, refined = tmp_path / "rows", tmp_path / "refined"
    assert (rows / "table1.csv").read_text() == (refined / "table1.csv").read_text()
    tried = _refined(refined)
    assert len(tried) == 40 and not _refined(rows)
    before = json.loads((rows / "results.json").read_text())["fastest_score"]["score"]
    after = json.loads((refined / "results.json").read_text())["fastest_score"]
    assert after["score"] >= before and after["key"].startswith("refine")
    card = read_card(refined / "fastest_gait.json")
    assert card is not None and card.summary(STAND_IN)["walks"] == 200  # its check, its confirmation, its hand-over
    # two CMA-ES runs (steps 0.05 and 0.1), 20 gaits each: one generation of the default 20
    generations = Counter("/".join(r["key"].split("/")[:2]) for r in tried)
    assert generations == {"refine0/g000": 20, "refine1/g000": 20}
    paper = defaults("gala")
    assert paper["refine_population"] == 20 and paper["refine_sigma"] == [0.05, 0.1]
    assert paper["refine_patience"] is None  # no restarts by default (yet)
    wide = tmp_path / "wide"
    argv = [*base, "--refine", "40", "--refine-population", "8", "--refine-sigma", "0.2", "--out", str(wide)]
    argv += ["--refine-patience", "30"]
    assert gala_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    generations = Counter("/".join(r["key"].split("/")[:2]) for r in _refined(wide))
    assert generations == {f"refine0/g{g:03d}": 8 for g in range(5)}
    settings = json.loads((wide / "manifest.json").read_text())["settings"]
    assert settings["refine_population"] == 8 and settings["refine_sigma"] == [0.2]
    assert settings["refine_patience"] == 30


#: The main job's refinement settings when no flag is given.
REFINEMENT = Settings.new("gala").refinement


def test_the_refinement_runs_one_cma_es_per_start_and_step_and_an_older_run_keeps_its_one_run() -> None:
    a, b = (1.0, 2.0), (3.0, 4.0)
    arms = refinement_arms(replace(REFINEMENT, sigma=(0.05, 0.1)), [a, b])
    assert [(arm.prefix, arm.start, arm.sigma) for arm in arms] == [
        ("refine0", a, 0.05),
        ("refine1", a, 0.1),
        ("refine2", b, 0.05),
        ("refine3", b, 0.1),
    ]
    assert refinement_arms(replace(REFINEMENT, sigma=0.05), [a]) == [Arm("refine", a, 0.05)]  # keyed as it was made


def test_the_race_heat_is_whole_generations_of_a_quarter_of_the_budget_over_two_runs() -> None:
    race = replace(REFINEMENT, budget=1600, population=20, race=True)
    assert heat_gaits(race, 4, 7) == 200 and heat_gaits(race, 2, 7) == 400
    assert heat_gaits(replace(race, budget=1619), 4, 7) == 200  # whole generations only
    assert heat_gaits(race, 1, 7) == 0  # nothing to race
    assert heat_gaits(replace(race, budget=40), 2, 7) == 0  # not a generation each: shared
    assert heat_gaits(replace(race, race=False), 4, 7) == 0
    assert heat_gaits(replace(race, race=LEGACY["refine_race"]), 2, 7) == 0  # a run from before the race
    assert heat_gaits(replace(race, budget=360, population=None), 2, 7) == 90  # the library's 9 a generation


def _refined(folder: Path) -> list[dict]:
    """The refinement's gaits (their first walks) in a run's log."""
    return [r for r in _episodes(folder) if r["key"].startswith("refine") and "/k" not in r["key"]]


def _episodes(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines()]


def _refined_run(tmp_path: Path, *flags: str) -> tuple[Path, list[dict]]:
    out = tmp_path / "refined"
    argv = ["--crossover", "0.8", "--population", "6", "--iterations", "3", "--generations", "2", "--quiet"]
    argv += ["--seed", "4", "--check-repeats", "2", "--refine", "80", *flags, "--out", str(out)]
    assert gala_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    return out, [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]


def test_the_refinement_holds_a_rows_walk_as_the_start_and_searches_the_cruise_gait(tmp_path: Path) -> None:
    """By default the main job refines its rows' walks as tfs-start walks: each refined gait keeps a
    gait of the rows as its start gait, its episodes say their family, and the walk handed over is
    a tfs-start gait file begun by a rows' gait; Table I's gaits stay TFS gaits."""
    out, episodes = _refined_run(tmp_path)
    rows = {tuple(e["genes"]) for e in episodes if e["key"].startswith("pc")}
    assert all("family" not in e for e in episodes if e["key"].startswith("pc"))
    refined = [e for e in episodes if e["key"].startswith("refine")]
    assert refined and all(e["family"] == "tfs-start" and len(e["genes"]) == 14 for e in refined)
    assert {tuple(e["genes"][7:]) for e in refined} <= rows
    assert len({tuple(e["genes"][:7]) for e in refined}) > 40
    assert load_gait(out / "best_gait.json").family.name == "tfs"
    handed = load_gait(out / "fastest_gait.json")
    assert handed.family.name == "tfs-start" and handed.genes[7:] in rows
    results = json.loads((out / "results.json").read_text())
    assert results["fastest_episode"]["family"] == "tfs-start"
    checks = [e for e in episodes if e["key"].startswith("check/" + results["fastest_score"]["key"])]
    assert len(checks) == 200 and all(e["family"] == "tfs-start" for e in checks)
    assert json.loads((out / "fastest_gait.card.json").read_text())["family"] == "tfs-start"


def _held_starts(folder: Path) -> dict[str, set[tuple[float, ...]]]:
    """Each tfs-start refinement run's held start gaits (its genes after the cruise gait's 7)."""
    held: dict[str, set[tuple[float, ...]]] = {}
    for e in _episodes(folder):
        if e["key"].startswith("refine"):
            held.setdefault(e["key"].split("/")[0], set()).add(tuple(e["genes"][7:]))
    return held


def test_the_refinement_can_start_from_the_reference_walk_too(tmp_path: Path) -> None:
    """--refine-reference: the last CMA-ES runs start from the reference walk (in tfs-start, it is
    their held start gait), the rows' runs keep their numbers and starts, and the manifest says so."""
    reference = load_gait(DEFAULT_GAIT_PATH).genes
    plain, _ = _refined_run(tmp_path / "plain")
    also, _ = _refined_run(tmp_path / "also", "--refine-reference")
    without, held = _held_starts(plain), _held_starts(also)
    assert all(reference not in starts for starts in without.values())
    arms = sorted(held, key=lambda arm: int(arm[len("refine") :]))
    assert len(arms) == len(without) + 2 and [held[arm] for arm in arms[-2:]] == [{reference}, {reference}]
    assert all(held[arm] == without[arm] for arm in without)
    for folder, stored in ((plain, False), (also, True)):
        assert json.loads((folder / "manifest.json").read_text())["settings"]["refine_reference"] is stored


def test_the_reference_walk_is_lifted_into_the_runs_family_and_refused_outside_its_box() -> None:
    reference = load_gait(DEFAULT_GAIT_PATH).genes
    assert job.reference_start(TFS, LEGACY_GENE_BOUNDS) == reference
    assert job.reference_start(TFS_PLUS, TFS_PLUS.bounds)[:7] == reference
    narrow = LEGACY_GENE_BOUNDS.copy()
    narrow[6] = (20.0, 25.0)  # w: the reference walk's 15.7 rad/s lies below
    with pytest.raises(ValueError, match="the reference walk lies outside the tfs family's search box"):
        job.reference_start(TFS, narrow)


class WalkToWalk(FakeEvaluator):
    """The synthetic hill, each walk a little off it by its own seed: walks of one gait differ."""

    def evaluate(self, tasks):
        for outcome in super().evaluate(tasks):
            fitness = outcome.result["fitness"] + outcome.task.seed % 97 / 10
            yield EpisodeOutcome(outcome.task, 0, {**outcome.result, "fitness": fitness, "distance": fitness / 10})


def _raced_walks(fitness: dict[str, float], score: dict) -> list[float]:
    """The fitness of the walks behind a raced gait's score (results.json's ``*_score``): 5, or
    the refinement's 20 of a leader."""
    assert score["walks"] in (5, 20)
    return [fitness[score["key"]], *(fitness[f"{score['key']}/k{j}"] for j in range(1, score["walks"]))]


def test_the_refinement_scores_a_gait_by_its_worst_walk_and_the_rows_by_their_quantile(tmp_path: Path) -> None:
    """The walk handed over comes from the refinement, which forgives no bad walk; the rows keep
    --robust-quantile (0.25: the second-worst of 5). --refine-quantile changes the refinement's."""
    for name, flags, stored in (("worst", [], 0.0), ("mean", ["--refine-quantile", "mean"], "mean")):
        out = tmp_path / name
        argv = ["--crossover", "0.8", "--population", "6", "--iterations", "3", "--generations", "2", "--quiet"]
        argv += ["--seed", "4", "--check-repeats", "2", "--check-confirm", "1", "--refine", "40", *flags]
        assert gala_command.main([*argv, "--out", str(out)], make_evaluator=lambda s: WalkToWalk()) == 0
        fitness = {e["key"]: e["fitness"] for e in _episodes(out)}
        results = json.loads((out / "results.json").read_text())
        row, fastest = results["rows"][0]["best_score"], results["fastest_score"]
        assert row["score"] == pytest.approx(np.quantile(_raced_walks(fitness, row), 0.25))
        assert fastest["key"].startswith("refine")
        scored = _raced_walks(fitness, fastest)
        assert fastest["score"] == pytest.approx(min(scored) if stored == 0.0 else np.mean(scored))
        assert min(scored) < np.quantile(scored, 0.25) < np.mean(scored)  # the three differ here
        assert json.loads((out / "manifest.json").read_text())["settings"]["refine_quantile"] == stored


def test_the_refinements_best_walks_on_as_its_leader_and_bad_lead_walks_are_refused(tmp_path: Path, capsys) -> None:
    """By default a refined gait that would be the refinement's best walks on to 20 walks and is
    scored by all of them; --refine-lead-walks 0 walks none on; a count not above the gait's
    --robust-walks is refused, naming both."""
    argv = ["--crossover", "0.8", "--population", "6", "--iterations", "3", "--generations", "2", "--quiet"]
    argv += ["--seed", "4", "--check-repeats", "2", "--check-confirm", "1", "--refine", "40"]
    for name, flags, stored, most in (("lead", [], 20, 20), ("none", ["--refine-lead-walks", "0"], 0, 5)):
        out = tmp_path / name
        assert gala_command.main([*argv, *flags, "--out", str(out)], make_evaluator=lambda s: WalkToWalk()) == 0
        episodes = _episodes(out)
        walks = Counter(e["key"].split("/k")[0] for e in episodes if e["key"].startswith("refine"))
        assert max(walks.values()) == most
        assert json.loads((out / "manifest.json").read_text())["settings"]["refine_lead_walks"] == stored
    for bad, message in (
        ("3", "lead walks 3: a leader walks on past its --robust-walks 5"),
        ("1", "1 is not more walks"),
    ):
        with pytest.raises(SystemExit) as exit_info:
            gala_command.main([*argv, "--refine-lead-walks", bad, "--out", str(tmp_path / f"bad{bad}")])
        assert exit_info.value.code == 2
        assert message in capsys.readouterr().err


def test_the_refinement_can_search_the_runs_own_family(tmp_path: Path) -> None:
    out, episodes = _refined_run(tmp_path, "--refine-family", "tfs")
    refined = [e for e in episodes if e["key"].startswith("refine")]
    assert refined and all("family" not in e and len(e["genes"]) == 7 for e in refined)
    assert load_gait(out / "fastest_gait.json").family.name == "tfs"


def test_a_refinement_of_two_families_gives_each_its_share_and_hands_over_the_best_of_both(tmp_path: Path) -> None:
    """The first family's runs are the runs it walks alone with its share of the gaits (the same
    keys, genes and seeds); the second's are numbered on from them; the checks rank both."""
    out, episodes = _refined_run(tmp_path, "--refine-family", "tfs", "tfs-start")
    searched = [e for e in episodes if e["key"].startswith("refine") and "/k" not in e["key"]]
    tfs = [e for e in searched if "family" not in e]
    start = [e for e in searched if e.get("family") == "tfs-start"]
    assert len(tfs) + len(start) == len(searched) and len(tfs) == len(start) == 40
    assert all(len(e["genes"]) == 7 for e in tfs) and all(len(e["genes"]) == 14 for e in start)
    arms = {e["key"].split("/")[0] for e in tfs}, {e["key"].split("/")[0] for e in start}
    assert arms[0].isdisjoint(arms[1]) and max(arms[0]) < min(arms[1])
    alone, alone_episodes = _refined_run(tmp_path / "alone", "--refine-family", "tfs", "--refine", "40")
    shared = {(e["key"], tuple(e["genes"]), e["seed"]) for e in episodes if e["key"].startswith("refine")}
    solo = {(e["key"], tuple(e["genes"]), e["seed"]) for e in alone_episodes if e["key"].startswith("refine")}
    assert solo and solo <= shared
    results = json.loads((out / "results.json").read_text())
    families = {e.get("family", "tfs") for e in episodes if e["key"].startswith("check/refine")}
    assert families == {"tfs", "tfs-start"}
    assert results["fastest_score"]["key"].startswith("refine")


def test_the_checks_of_a_refinement_of_two_families_walk_the_best_of_each() -> None:
    """``check_candidates``: the ten best of each family, best-scored first, where the ten best of
    the run could all be of one family."""
    walk = EpisodeRecord("k", (0.0,), 10.0, distance=1.0, time=15.0)
    ranked = [ScoredGait(f"s{j}", (float(j),), 100.0 - j, (walk,), "tfs-start") for j in range(12)]
    ranked += [ScoredGait(f"t{j}", (float(j), 1.0), 50.0 - j, (walk,)) for j in range(12)]
    assert [g.key for g in check_candidates(ranked, 10)] == [f"s{j}" for j in range(10)]
    both = check_candidates(ranked, 10, by_family=True)
    assert [g.key for g in both] == [f"s{j}" for j in range(10)] + [f"t{j}" for j in range(10)]
    assert check_candidates(ranked[:12], 10, by_family=True) == check_candidates(ranked[:12], 10)


def test_a_refinement_family_given_twice_is_refused(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        gala_command.main(["--refine-family", "tfs", "tfs", "--out", str(tmp_path / "x")])
    assert exit_info.value.code == 2
    assert "--refine-family: a family is given twice (tfs tfs)" in capsys.readouterr().err


def test_a_refinement_family_that_cannot_refine_the_runs_walks_is_refused(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        gala_command.main(["--family", "tfs-plus", "--out", str(tmp_path / "x")])
    assert exit_info.value.code == 2
    assert "--refine-family tfs-start: it cannot refine tfs-plus walks" in capsys.readouterr().err


def test_the_quick_budget_refines_tfs_gaits_and_tfs_start_walks_and_the_paper_budget_tfs_start_walks(
    tmp_path: Path,
) -> None:
    """Which family climbs from a quick row's slow walks depends on the seed: its refinement
    searches both, and races no leaders."""
    for budget, family, refine, lead, reference in (
        ("quick", ["tfs", "tfs-start"], 3200, 0, True),
        ("paper", "tfs-start", 4000, 20, False),
    ):
        out = tmp_path / budget
        with pytest.raises(Killed):
            gala_command.main(
                ["--budget", budget, "--out", str(out), "--quiet"], make_evaluator=lambda s: FakeEvaluator(1)
            )
        settings = json.loads((out / "manifest.json").read_text())["settings"]
        assert (settings["refine_family"], settings["refine"], settings["refine_lead_walks"]) == (family, refine, lead)
        assert settings["refine_reference"] is reference
