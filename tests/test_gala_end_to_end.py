"""A tiny GALA on the embedded stub, end to end: every output file, and kill -9 + --resume."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gait import TFS, family_named, load_gait

REPO = Path(__file__).resolve().parents[1]
TINY = [
    "--crossover",
    "0.8",
    "--population",
    "4",
    "--iterations",
    "3",
    "--generations",
    "2",
    "--walk-time",
    "2",
    "--workers",
    "2",
    "--seed",
    "4",
    "--check-repeats",
    "3",
    "--check-confirm",
    "2",
    "--hand-over-walks",
    "8",
    "--robust-walks",
    "3",
    "--refine-lead-walks",
    "5",
    "--refine",
    "8",
    "--quiet",
]


def _gala(*args: str, timeout: float = 600, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """``python -m optimizer.gala ARGS`` from the repository, as a user runs it (``env``: its environment)."""
    return subprocess.run(
        [sys.executable, "-m", "optimizer.gala", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
    )


def _log(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines() if line.strip()]


def _planned() -> int:
    """The search's gaits, each walked once (raced ones walk twice more; the checks' walks depend
    on which walks fall)."""
    # initial population + 3 iterations x 1 generation (elite carried, 3 new) + final GA (4 + 3)
    # + the refinement's 8
    return 4 + 3 * 3 + 4 + 3 + 8


def _score(walks: list[dict]) -> float:
    """A gait's score as the run's defaults compute it: one walk's fitness, else the 0.25 quantile."""
    values = sorted(w["fitness"] for w in walks)
    if len(values) == 1:
        return values[0]
    position = 0.25 * (len(values) - 1)
    low = int(position)
    return values[low] + (position - low) * (values[min(low + 1, len(values) - 1)] - values[low])


@pytest.mark.slow
def test_tiny_gala_on_the_stub_writes_every_output(tmp_path: Path) -> None:
    out = tmp_path / "run"
    done = _gala(*TINY, "--out", str(out))
    assert done.returncode == 0, done.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["seed"] == 4 and "pybullet" in json.dumps(manifest["versions"])
    logged = _log(out)
    assert all(r["status"] == "ok" for r in logged), [r["reason"] for r in logged if r["status"] != "ok"]
    assert all(r["fitness"] == pytest.approx(10 * r["distance"]) for r in logged)
    keys = [r["key"] for r in logged]
    assert len(keys) == len(set(keys))
    records = [r for r in logged if not r["key"].startswith("check/")]
    checks = [r for r in logged if r["key"].startswith("check/")]
    firsts = [r for r in records if "/k" not in r["key"]]
    walks = {r["key"]: [r] + [e for e in records if e["key"].startswith(r["key"] + "/k")] for r in firsts}
    assert len(firsts) == _planned()
    assert {len(w) for k, w in walks.items() if not k.startswith("refine")} <= {1, 3}
    refined = {k: w for k, w in walks.items() if k.startswith("refine")}
    assert {len(w) for w in refined.values()} <= {1, 3, 5}
    # a refinement's best (scored by its worst walk) is a leader: it walked on to 5 walks
    assert len(max(refined.values(), key=lambda w: min(e["fitness"] for e in w) if len(w) > 1 else -1e9)) == 5
    assert all("start" not in w[0] and all(len(e["start"]) == 3 for e in w[1:]) for w in walks.values())
    assert len({r["seed"] for r in logged}) == len(logged)  # every walk its own dither draw
    assert len(checks) % 3 == 0 and checks
    for r in checks:  # moved by at most the default jitter (the real server's beam noise), traced for the cards
        x, y, heading = r["start"]
        assert abs(x + 5.0) <= 0.05 and abs(y) <= 0.05 and abs(heading) <= 10.0 and (x, y, heading) != (-5, 0, 0)
        assert r["track"] and r["drift"] is not None and r["heading_change"] is not None
        assert r["track"][-1][0] == pytest.approx(r["time"], abs=0.05)
    rows = list(csv.DictReader((out / "table1.csv").open()))
    assert len(rows) == 1 and float(rows[0]["crossover_rate"]) == 0.8
    assert 0.0 <= float(rows[0]["optimal_mutation_rate"]) <= 0.09
    best_key = json.loads((out / "results.json").read_text())["rows"][0]["best_episode"]["key"]
    row_check = [r for r in checks if r["key"].startswith(f"check/{best_key}/")]
    assert len(row_check) == 3 and rows[0]["repeats"] == "3"
    assert int(rows[0]["repeat_falls"]) == sum(r["fell"] for r in row_check)
    best_logged = max(_score(w) for key, w in walks.items() if key.startswith("pc0.8/final"))
    assert float(rows[0]["best_fitness"]) == pytest.approx(best_logged)
    assert "0.8" in (out / "table1.md").read_text()
    for png in ("gala-pc0.8.png", "ga-pc0.8.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    best = load_gait(out / "best_gait.json")  # a gait file the agent takes with --gait
    assert best == load_gait(out / "best_gait-pc0.8.json")
    results = json.loads((out / "results.json").read_text())
    assert json.dumps(results)  # parses and re-serialises
    # the fastest gait: of the checked candidates, those that held walked 2 confirming walks more,
    # then those that held walked on, 3 at a time, towards 8 until one held them all (the rows'
    # walk the refinement started from too, when no refined one did: 3, 6, 8); when none held,
    # the smallest share of falls, then the farthest worst check walk
    checked = {}
    for r in checks:
        checked.setdefault(r["key"][len("check/") :].rsplit("/", 1)[0], []).append(r)
    fastest = results["fastest_check"]["key"]
    assert results["fastest_score"]["key"] == fastest and fastest in checked
    assert all(len(c) == 3 for k, c in checked.items() if k != best_key and any(w["fell"] for w in c[:3]))
    assert all(len(c) in (3, 5, 6, 8) for k, c in checked.items() if k != best_key)
    assert results["fastest_check"]["repeats"] == len(checked[fastest])
    if results["fastest_check"]["falls"] == 0:
        assert results["fastest_check"]["repeats"] == 8
    else:
        verdict = {k: (sum(w["fell"] for w in c) / len(c), -min(w["distance"] for w in c)) for k, c in checked.items()}
        assert verdict[fastest] == min(verdict[k] for k in verdict if k != best_key or k == fastest)
    # a refined walk is a tfs-start gait (the refinement's default family), a rows' walk a TFS gait
    handed = family_named(walks[fastest][0].get("family", TFS.name)).gait(walks[fastest][0]["genes"])
    assert load_gait(out / "fastest_gait.json") == handed
    for card in ("fastest_gait.card.png", "best_gait.card.png", "best_gait-pc0.8.card.png"):
        assert (out / card).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "stand-in" in (out / "fastest_gait.card.md").read_text()


@pytest.mark.slow
def test_killed_run_resumes_with_nothing_lost_or_counted_twice(tmp_path: Path) -> None:
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    assert _gala(*TINY, "--out", str(whole)).returncode == 0
    proc = subprocess.Popen(
        [sys.executable, "-m", "optimizer.gala", *TINY, "--out", str(cut)],
        cwd=REPO,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and (not (cut / "episodes.jsonl").exists() or len(_log(cut)) < 6):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the optimizer, its workers and their stub servers
    proc.wait()
    before = _log(cut)
    assert 6 <= len(before) < len(_log(whole))
    done = _gala("--resume", str(cut), "--quiet")
    assert done.returncode == 0, done.stderr
    after = _log(cut)
    keys = [r["key"] for r in after]
    assert len(keys) == len(set(keys)) == len(_log(whole)), "nothing lost, nothing counted twice"
    assert after[: len(before)] == before, "finished episodes are kept, not re-run"
    fitness = {r["key"]: r["fitness"] for r in _log(whole)}
    assert {r["key"]: r["fitness"] for r in after} == fitness
    assert (cut / "table1.csv").read_text() == (whole / "table1.csv").read_text()
