"""``python -m optimizer.refine``: CMA-ES from a gait file, scored and checked as every search,
handing back the start when nothing beats it, across families, resumable."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_driver import FakeEvaluator, Killed

from gait import TFS, TFS_PLUS, TFS_START, load_gait, save_gait
from gait.tfs_plus import NEUTRAL
from optimizer.cli import refine_command as refine_command
from optimizer.search.refinement import START_KEY

SMALL = ["--budget", "40", "--check-repeats", "2", "--seed", "2", "--quiet"]


def _start_file(tmp_path: Path) -> Path:
    return save_gait(load_gait(), tmp_path / "start.json")


def _episodes(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines()]


def test_refine_climbs_from_the_file_and_hands_over_a_checked_gait(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    argv = [str(_start_file(tmp_path)), *SMALL, "--out", str(out)]
    assert refine_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    episodes = _episodes(out)
    first = next(e for e in episodes if e["key"] == f"{START_KEY}/i000")
    assert first["genes"] == list(load_gait().genes)
    assert sum(1 for e in episodes if e["key"].startswith("refine") and "/k" not in e["key"]) == 40
    results = json.loads((out / "results.json").read_text())
    assert results["fastest_score"]["key"].startswith("refine")  # the synthetic hill rises from the shipped gait
    start_score = max(e["fitness"] for e in episodes if e["key"].startswith(START_KEY))
    assert results["fastest_score"]["score"] > start_score
    handed = load_gait(out / "fastest_gait.json")
    assert handed.family is TFS and list(handed.genes) == results["fastest_episode"]["genes"]
    assert (out / "fastest_gait.card.md").is_file()
    assert "fastest walk that held" in capsys.readouterr().out


def test_a_tfs_walk_starts_a_tfs_plus_search_with_its_additions_at_zero(tmp_path: Path) -> None:
    out = tmp_path / "plus"
    argv = [str(_start_file(tmp_path)), "--family", "tfs-plus", *SMALL, "--out", str(out)]
    assert refine_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    episodes = _episodes(out)
    assert {len(e["genes"]) for e in episodes} == {13}
    first = next(e for e in episodes if e["key"] == f"{START_KEY}/i000")
    assert first["genes"] == [*load_gait().genes, *NEUTRAL]
    assert load_gait(out / "fastest_gait.json").family is TFS_PLUS
    genes = np.array([e["genes"] for e in episodes])
    assert np.all(genes >= TFS_PLUS.bounds[:, 0]) and np.all(genes <= TFS_PLUS.bounds[:, 1])


def test_a_tfs_walk_starts_a_tfs_start_search_that_holds_it_as_the_start_gait(tmp_path: Path) -> None:
    """Every refined gait keeps the file's gait as its start gait and moves only the cruise gait."""
    out = tmp_path / "started"
    argv = [str(_start_file(tmp_path)), "--family", "tfs-start", *SMALL, "--out", str(out)]
    assert refine_command.main(argv, make_evaluator=lambda s: FakeEvaluator()) == 0
    shipped = list(load_gait().genes)
    episodes = _episodes(out)
    first = next(e for e in episodes if e["key"] == f"{START_KEY}/i000")
    assert first["genes"] == shipped + shipped
    refined = [e["genes"] for e in episodes if e["key"].startswith("refine")]
    assert len(refined) >= 40 and all(g[7:] == shipped for g in refined)
    assert len({tuple(g[:7]) for g in refined}) > 20
    handed = load_gait(out / "fastest_gait.json")
    assert handed.family is TFS_START and list(handed.genes[7:]) == shipped


def test_a_refined_gait_is_scored_by_its_worst_walk_unless_told_and_a_resumed_run_keeps_its_own(
    tmp_path: Path,
) -> None:
    """The command's whole run is a refinement: by default its gaits are scored by their worst walk
    (``--robust-quantile 0``); a run made with another quantile resumes with it."""
    start = _start_file(tmp_path)
    for name, flags, quantile in (("worst", [], 0.0), ("second", ["--robust-quantile", "0.25"], 0.25)):
        out = tmp_path / name
        assert (
            refine_command.main(
                [str(start), *SMALL, *flags, "--out", str(out)], make_evaluator=lambda s: FakeEvaluator()
            )
            == 0
        )
        assert json.loads((out / "manifest.json").read_text())["settings"]["robust_quantile"] == quantile
    assert (
        refine_command.main(["--resume", str(tmp_path / "second"), "--quiet"], make_evaluator=lambda s: FakeEvaluator())
        == 0
    )
    assert json.loads((tmp_path / "second" / "manifest.json").read_text())["settings"]["robust_quantile"] == 0.25


def test_a_refinement_killed_midway_resumes_to_the_same_result(tmp_path: Path) -> None:
    start = _start_file(tmp_path)
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    assert refine_command.main([str(start), *SMALL, "--out", str(whole)], make_evaluator=lambda s: FakeEvaluator()) == 0
    with pytest.raises(Killed):
        refine_command.main([str(start), *SMALL, "--out", str(cut)], make_evaluator=lambda s: FakeEvaluator(25))
    assert refine_command.main(["--resume", str(cut), "--quiet"], make_evaluator=lambda s: FakeEvaluator()) == 0
    assert (cut / "fastest_gait.json").read_text() == (whole / "fastest_gait.json").read_text()


@pytest.mark.parametrize(
    "argv, words",
    [
        ([], "GAIT: a gait file to start from is needed"),
        (["nowhere.json"], "GAIT: cannot read gait file nowhere.json"),
        (["PLUS", "--family", "tfs"], "--family tfs: a tfs-plus gait cannot start a tfs search"),
        (["START", "--sigma", "0"], "--sigma"),
        (["START", "--budget", "0"], "--budget"),
    ],
)
def test_bad_command_lines_are_refused_with_the_reason(tmp_path: Path, capsys, argv: list[str], words: str) -> None:
    plus = save_gait(TFS_PLUS.gait([*load_gait().genes, 1, 2, 3, 4, 5, 6]), tmp_path / "plus.json")
    files = {"PLUS": str(plus), "START": str(_start_file(tmp_path))}
    with pytest.raises(SystemExit) as exit_info:
        refine_command.main([files.get(a, a) for a in argv] + ["--out", str(tmp_path / "x")])
    assert exit_info.value.code == 2
    assert words in capsys.readouterr().err


def test_the_drift_penalty_is_a_stored_setting_every_walk_of_the_run_gets(tmp_path: Path) -> None:
    setups = []

    def fake(setup):
        setups.append(setup)
        return FakeEvaluator()

    out = tmp_path / "straight"
    argv = [str(_start_file(tmp_path)), *SMALL, "--drift-penalty", "1.5", "--out", str(out)]
    assert refine_command.main(argv, make_evaluator=fake) == 0
    assert setups[0].drift_penalty == 1.5
    assert json.loads((out / "manifest.json").read_text())["settings"]["drift_penalty"] == 1.5


def test_the_refinement_races_its_runs_and_the_leader_walks_the_rest(tmp_path: Path) -> None:
    """Two runs (steps 0.05 and 0.1) walk a heat of 80 gaits each (4 generations of 20, a quarter of
    320 over two), then the one with the higher best score walks the other 160; --no-race shares
    the 320 evenly. A run stopped in the heat and resumed hands over the same gait."""
    argv = ["--budget", "320", "--check-repeats", "2", "--seed", "3", "--quiet"]
    counts = {}
    for name, extra in (("race", []), ("shared", ["--no-race"])):
        out = tmp_path / name
        assert (
            refine_command.main(
                [str(_start_file(tmp_path)), *argv, *extra, "--out", str(out)],
                make_evaluator=lambda s: FakeEvaluator(),
            )
            == 0
        )
        firsts = [e for e in _episodes(out) if e["key"].startswith("refine") and e["key"].count("/") == 2]
        counts[name] = {p: sum(1 for e in firsts if e["key"].startswith(p + "/")) for p in ("refine0", "refine1")}
        if name == "race":
            heat = {
                p: max(e["fitness"] for e in firsts if e["key"].startswith(p + "/") and int(e["key"][9:12]) < 4)
                for p in ("refine0", "refine1")
            }
            leader = max(sorted(heat), key=heat.__getitem__)
    assert counts["shared"] == {"refine0": 160, "refine1": 160}
    assert counts["race"][leader] == 240 and sum(counts["race"].values()) == 320
    cut = tmp_path / "cut"
    with pytest.raises(Killed):
        refine_command.main(
            [str(_start_file(tmp_path)), *argv, "--out", str(cut)], make_evaluator=lambda s: FakeEvaluator(150)
        )
    assert refine_command.main(["--resume", str(cut), "--quiet"], make_evaluator=lambda s: FakeEvaluator()) == 0
    assert (cut / "fastest_gait.json").read_text() == (tmp_path / "race" / "fastest_gait.json").read_text()


def test_a_start_outside_the_box_is_refused_before_any_run_folder_is_made(tmp_path: Path, capsys) -> None:
    genes = list(load_gait().genes)
    genes[0] += 100.0  # the hip's offset far beyond its box
    wide = TFS.gait(genes)
    start = save_gait(wide, tmp_path / "wide.json")
    out = tmp_path / "x"
    with pytest.raises(SystemExit) as exit_info:
        refine_command.main([str(start), "--out", str(out)])
    assert exit_info.value.code == 2
    assert "the start gait lies outside the tfs family's search box" in capsys.readouterr().err
    assert not out.exists()
