"""Run folders: the manifest, and an episode log that survives a kill mid-write and never counts twice."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer.evaluation.record import EpisodeRecord, RecordError, WalkKind
from optimizer.run.folder import (
    EpisodeLog,
    RunFolder,
    RunFolderError,
    new_run_path,
    read_episode_log,
    repair_episode_log,
)

REPO = Path(__file__).resolve().parents[1]


def document(key: str, fitness: float = 1.0) -> dict:
    """A log line's object, as the optimizer writes it."""
    return {
        "key": key,
        "genes": [0.5, 1.5],
        "seed": 7,
        "worker": 0,
        "fitness": fitness,
        "distance": fitness / 10,
        "fell": False,
        "time": 15.0,
        "mean_speed": fitness / 150,
        "status": "ok",
        "reason": "",
        "wall": 0.3,
    }


def record(key: str, fitness: float = 1.0) -> EpisodeRecord:
    return EpisodeRecord.from_json(document(key, fitness))


def test_manifest_records_what_was_run_and_reopens(tmp_path: Path) -> None:
    RunFolder.create(
        tmp_path / "run",
        "gala",
        {"population": 10, "crossover": [0.8]},
        42,
        ["--population", "10"],
        {"workers": 2, "servers": []},
    )
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
    path.write_text(json.dumps(document("a")) + "\n{not json\n" + json.dumps(document("b")) + "\n")
    with pytest.raises(RunFolderError, match="line 2"):
        read_episode_log(path)


def test_a_key_logged_twice_keeps_the_first_and_warns(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in (document("a", 1.0), document("b"), document("a", 9.0))))
    records, warnings, _ = read_episode_log(path)
    assert records["a"].fitness == 1.0
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


def _lines(*records: dict) -> list[bytes]:
    return [json.dumps(r).encode() for r in records]


@pytest.mark.parametrize(
    "bad, problem",
    [
        (b"garbage{", "line 2: not JSON"),
        (
            json.dumps(document("x", 1.0) | {"fitness": "oops"}).encode(),
            'line 2: "fitness" must be a finite number, found "oops"',
        ),
        (
            json.dumps(document("x", 1.0) | {"key": ["x"]}).encode(),
            'line 2: "key" must be a non-empty string, found ["x"]',
        ),
        (json.dumps(document("x", 1.0) | {"genes": [1, "a"]}).encode(), 'line 2: "genes" must be a list of numbers'),
        (b'{"key": "\xff\xfe"}', "line 2: not UTF-8 text"),
        (b"[1, 2]", "line 2: expected a JSON object"),
    ],
)
def test_a_damaged_line_is_one_line_error_naming_file_line_and_problem(
    tmp_path: Path, bad: bytes, problem: str
) -> None:
    path = tmp_path / "episodes.jsonl"
    good = _lines(document("a"), document("b"))
    path.write_bytes(b"\n".join([good[0], bad, good[1]]) + b"\n")
    with pytest.raises(RunFolderError) as caught:
        read_episode_log(path)
    message = str(caught.value)
    assert str(path) in message and problem in message and "\n" not in message
    assert "--skip-bad-lines" in message


def test_repair_moves_bad_lines_aside_and_keeps_every_intact_line(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    good = _lines(document("a"), document("b"), document("c"))
    bad = [b"garbage", json.dumps(document("x") | {"fitness": "oops"}).encode(), b"\xff\xfe"]
    tail = b'{"key": "d", "gen'  # a torn last write stays for EpisodeLog to cut, as before
    path.write_bytes(b"\n".join([good[0], bad[0], good[1], bad[1], bad[2], good[2]]) + b"\n" + tail)
    assert repair_episode_log(path) == 3
    assert path.read_bytes() == b"\n".join(good) + b"\n" + tail
    assert (tmp_path / "episodes.jsonl.rejected").read_bytes() == b"\n".join(bad) + b"\n"
    records, warnings, _ = read_episode_log(path)
    assert list(records) == ["a", "b", "c"] and "incomplete last line" in warnings[0]
    assert repair_episode_log(path) == 0


def _ga(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "optimizer.ga",
            "--population",
            "2",
            "--generations",
            "1",
            "--walk-time",
            "0.2",
            "--check-repeats",
            "0",
            "--workers",
            "1",
            "--quiet",
            *args,
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_resume_of_a_damaged_log_stops_with_one_line_then_goes_on_with_skip_bad_lines(tmp_path: Path) -> None:
    run = tmp_path / "run"
    assert _ga("--seed", "1", "--out", str(run)).returncode == 0
    log = run / "episodes.jsonl"
    intact = log.read_bytes().splitlines()
    log.write_bytes(b"\n".join([intact[0], b'{"key": ["x"], "fitness": "oops"}', *intact[1:]]) + b"\n")
    refused = _ga("--resume", str(run))
    assert refused.returncode == 1
    assert "Traceback" not in refused.stderr
    error = [line for line in refused.stderr.splitlines() if "error:" in line]
    assert len(error) == 1 and f'{log}, line 2: "key" must be a non-empty string' in error[0], refused.stderr
    resumed = _ga("--resume", str(run), "--skip-bad-lines")
    assert resumed.returncode == 0, resumed.stderr
    assert "moved 1 bad line(s) to episodes.jsonl.rejected" in resumed.stderr
    assert log.read_bytes().splitlines() == intact  # nothing re-run, nothing lost
    assert (run / "episodes.jsonl.rejected").read_bytes() == b'{"key": ["x"], "fitness": "oops"}\n'


def test_a_record_round_trips_and_says_what_kind_of_walk_it_was() -> None:
    walk = EpisodeRecord.from_json(document("check/a/r00") | {"kind": "check", "start": [-5, 0.1, 2]})
    assert walk.kind is WalkKind.CHECK and not walk.is_search and walk.start == (-5.0, 0.1, 2.0)
    assert EpisodeRecord.from_json(walk.to_json()) == walk
    assert json.loads(json.dumps(walk.to_json())) == walk.to_json()


def test_a_log_from_before_records_had_their_kind_reads_check_walks_by_their_key() -> None:
    """Older logs have no "kind": check walks were always keyed check/..., a comparison's robust
    walks (a search's, with a start of their own) were not."""
    assert EpisodeRecord.from_json(document("check/pc0.8/i001/r03") | {"start": [0, 0, 0]}).kind is WalkKind.CHECK
    robust = EpisodeRecord.from_json(document("gala/s00/g01/i002/k1") | {"start": [0, 0, 0]})
    assert robust.kind is WalkKind.SEARCH and robust.is_search


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        ({"kind": "warmup"}, '"kind" must be one of search, check'),
        ({"fell": 1}, '"fell" must be true or false'),
        ({"seed": 1.5}, '"seed" must be an integer'),
        ({"start": [0, 0]}, '"start" must be 3 numbers'),
        ({"distance": float("nan")}, '"distance" must be a finite number'),
        ({"family": 7}, '"family" must be a family\'s name'),
        # a course walk's fields: all three or none, each of its kind, one time per pose reached, in order
        ({"finished": True, "reached": 2}, 'lacks "legs"'),
        ({"legs": [1.0]}, 'lacks "finished", "reached"'),
        ({"finished": 1, "reached": 1, "legs": [1.0]}, '"finished" must be true or false'),
        ({"finished": False, "reached": 1.0, "legs": [1.0]}, '"reached" must be a whole number >= 0'),
        ({"finished": False, "reached": -1, "legs": []}, '"reached" must be a whole number >= 0'),
        ({"finished": False, "reached": 1, "legs": "1"}, '"legs" must be a list of numbers'),
        ({"finished": False, "reached": 2, "legs": [1.0]}, '"legs" must hold the 2 poses\' times in order'),
        ({"finished": False, "reached": 2, "legs": [3.0, 1.0]}, '"legs" must hold the 2 poses\' times in order'),
        ({"finished": True, "reached": 0, "legs": []}, '"finished" with no pose "reached"'),
    ],
)
def test_a_record_with_a_wrong_field_is_refused_naming_it(change: dict, problem: str) -> None:
    with pytest.raises(RecordError, match=re.escape(problem)):
        EpisodeRecord.from_json(document("a") | change)


def test_a_course_walks_record_keeps_its_outcome_and_another_walks_leaves_it_out() -> None:
    course = document("check/a/r00") | {"finished": False, "reached": 2, "legs": [3.5, 7.25]}
    walk = EpisodeRecord.from_json(course)
    assert walk.on_course and walk.finished is False and walk.reached == 2 and walk.legs == (3.5, 7.25)
    assert EpisodeRecord.from_json(walk.to_json()) == walk
    assert json.loads(json.dumps(walk.to_json())) == walk.to_json()
    assert walk.to_json()["legs"] == [3.5, 7.25] and walk.to_json()["finished"] is False
    plain = EpisodeRecord.from_json(document("a"))
    assert not plain.on_course and plain.finished is None and plain.legs is None
    assert not {"finished", "reached", "legs"} & plain.to_json().keys()  # a line as it always was
