"""Run folders: the manifest, and an episode log that survives a kill mid-write and never counts twice."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.run_folder import EpisodeLog, RunFolder, RunFolderError, new_run_path, read_episode_log


def record(key: str, fitness: float = 1.0) -> dict:
    return {"key": key, "genes": [0.5, 1.5], "seed": 7, "worker": 0, "fitness": fitness, "distance": fitness / 10,
            "fell": False, "time": 15.0, "mean_speed": fitness / 150, "status": "ok", "reason": "", "wall": 0.3}


def test_manifest_records_what_was_run_and_reopens(tmp_path: Path) -> None:
    RunFolder.create(tmp_path / "run", "gala", {"population": 10, "crossover": [0.8]}, 42,
                     ["--population", "10"], {"workers": 2, "servers": []})
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["command"] == "gala" and manifest["seed"] == 42
    assert manifest["settings"] == {"population": 10, "crossover": [0.8]}
    assert manifest["command_line"] == "python -m optimizer.gala --population 10"
    assert set(manifest["versions"]) >= {"python", "numpy", "pybullet", "gala-nao", "git_commit"}
    assert manifest["versions"]["gala-nao"] is not None and manifest["versions"]["numpy"] is not None
    assert manifest["started"]
    reopened = RunFolder.open(tmp_path / "run")
    assert reopened.manifest == manifest
    reopened.note_resume(["--resume", "x"], {"workers": 1, "servers": []})
    assert RunFolder.open(tmp_path / "run").manifest["resumed"][0]["runtime"] == {"workers": 1, "servers": []}


def test_a_folder_that_is_not_a_run_is_refused(tmp_path: Path) -> None:
    with pytest.raises(RunFolderError, match="no manifest.json"):
        RunFolder.open(tmp_path)
    RunFolder.create(tmp_path / "run", "ga", {}, 1, [])
    with pytest.raises(RunFolderError, match="already holds a run"):
        RunFolder.create(tmp_path / "run", "ga", {}, 1, [])
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("x")
    with pytest.raises(RunFolderError, match="not empty"):
        RunFolder.create(tmp_path / "other", "ga", {}, 1, [])


def test_new_run_paths_do_not_collide(tmp_path: Path) -> None:
    first = new_run_path("gala", tmp_path)
    first.mkdir()
    second = new_run_path("gala", tmp_path)
    assert first.name.startswith("gala-") and second != first


def test_log_round_trips_and_is_flushed_per_record(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    with EpisodeLog(path) as log:
        log.append(record("a", 1.0))
        # read by another reader while the log is still open: what a kill -9 now would leave
        assert list(read_episode_log(path)[0]) == ["a"]
        log.append(record("b", -2.5))
    records, warnings, _ = read_episode_log(path)
    assert records == {"a": record("a", 1.0), "b": record("b", -2.5)}
    assert warnings == []


def test_a_truncated_last_line_is_ignored_and_cut_before_appending(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    with EpisodeLog(path) as log:
        log.append(record("a"))
        log.append(record("b"))
    whole = path.read_bytes()
    path.write_bytes(whole[:-17])  # killed in the middle of writing "b"
    log = EpisodeLog(path)
    assert list(log.records) == ["a"]
    assert any("incomplete last line" in w for w in log.warnings)
    log.append(record("c"))
    log.close()
    records, warnings, _ = read_episode_log(path)
    assert list(records) == ["a", "c"] and warnings == []


def test_a_garbled_line_before_the_end_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    path.write_text(json.dumps(record("a")) + "\n{not json\n" + json.dumps(record("b")) + "\n")
    with pytest.raises(RunFolderError, match="line 2"):
        read_episode_log(path)


def test_a_key_logged_twice_keeps_the_first_and_warns(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in (record("a", 1.0), record("b"), record("a", 9.0))))
    records, warnings, _ = read_episode_log(path)
    assert records["a"]["fitness"] == 1.0
    assert len(warnings) == 1 and "'a'" in warnings[0] and "line 3" in warnings[0]
    with EpisodeLog(path) as log, pytest.raises(ValueError, match="already in the log"):
        log.append(record("b"))


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.data())
def test_cutting_the_log_anywhere_keeps_exactly_the_complete_records(tmp_path_factory, count, data) -> None:
    path = tmp_path_factory.mktemp("log") / "episodes.jsonl"
    with EpisodeLog(path) as log:
        for k in range(count):
            log.append(record(f"k{k}", float(k)))
    whole = path.read_bytes()
    cut = data.draw(st.integers(0, len(whole)))
    path.write_bytes(whole[:cut])
    complete_lines = whole[:cut].count(b"\n")
    assert list(read_episode_log(path)[0]) == [f"k{k}" for k in range(complete_lines)]
