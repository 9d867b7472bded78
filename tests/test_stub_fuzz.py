"""A bounded fuzzing run (``server_stub.fuzz``) against the stub as a process, in sync mode and in
real time: mutated captures of the real server's traffic on both ports, framing abuse, clients
leaving by FIN, RST or mid-frame, and connect/reset storms. The stub must never stop serving a
well-behaved agent, and its log must stay small, short-lined and free of control bytes. The long
run is ``python -m bench.bench_fuzz``."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from server_stub import fuzz


@pytest.mark.parametrize("sync", [True, False], ids=["sync", "realtime"])
def test_a_bounded_fuzzing_run_finds_no_crash(fixtures_dir: Path, tmp_path: Path, sync: bool) -> None:
    log = tmp_path / "stub.log"
    report = fuzz.run(
        2500, seed=16 + sync, fixtures=fixtures_dir, sync=sync, log_path=log, canary_every=40, storm_every=40
    )
    assert report.crashes == 0, report.crash_logs
    assert report.messages >= 2500 and report.resets >= 50
    text = log.read_bytes()
    assert b"Traceback" not in text
    assert report.longest_log_line < 400
    assert not any(b < 0x20 for line in text.splitlines() for b in line)
    assert report.log_bytes < 200 * report.messages  # about 1 warning line per 10 messages at most


def test_the_mutator_is_seeded() -> None:
    corpus = [b"(scene rsg/agent/nao/nao.rsg)", b"(he1 0.5)(syn)"]
    first, again = fuzz.Mutator(random.Random(4)), fuzz.Mutator(random.Random(4))
    first = [first.mutate(m, corpus) for m in corpus * 20]
    again = [again.mutate(m, corpus) for m in corpus * 20]
    assert first == again and first != corpus * 20
