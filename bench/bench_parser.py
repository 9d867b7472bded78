"""Perception parser speed on every real perception, side by side with ``sexpdata``.

Run: ``python -m bench.bench_parser`` (from the repository root). Prints per-message times:
typical = median over all messages, and the mean for messages with and without vision, for
``parse_perception`` alone and with its lazily read ``.vision`` used; the comparator is
``sexpdata.loads("(" + msg + ")")`` (a tree only, no typed result) on the same messages in the
same run. Also times the monitor reader on ``monitor_full_run.txt``.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from pathlib import Path

import sexpdata

from protocol.monitor import MonitorReader
from protocol.perception import parse_perception

ROOT = Path(__file__).resolve().parents[1]

FIXTURES = ROOT / "tests" / "data" / "rcssserver3d"
PATTERNS = ("agent_perceptions_*.txt", "walk_calibration/run*_perceptions.txt")


def per_message_seconds(parse: Callable[[str], object], messages: list[str], repeats: int) -> list[float]:
    """Best of ``repeats`` timings for each message (the minimum filters scheduler noise)."""
    best = [float("inf")] * len(messages)
    clock = time.perf_counter
    for _ in range(repeats):
        for i, msg in enumerate(messages):
            start = clock()
            parse(msg)
            elapsed = clock() - start
            if elapsed < best[i]:
                best[i] = elapsed
    return best


def summary(times: list[float], has_vision: list[bool]) -> tuple[float, float, float]:
    vision = [t for t, v in zip(times, has_vision) if v]
    plain = [t for t, v in zip(times, has_vision) if not v]
    return statistics.median(times), statistics.fmean(vision), statistics.fmean(plain)


def main() -> None:
    files = [f for pattern in PATTERNS for f in sorted(FIXTURES.glob(pattern))]
    messages = [line for f in files for line in f.read_text().splitlines() if line]
    has_vision = ["(See " in m for m in messages]
    print(f"{len(messages)} perceptions from {len(files)} files, {sum(has_vision)} with vision")

    ours = summary(per_message_seconds(parse_perception, messages, repeats=5), has_vision)
    # a See is read on first use of .vision; this row pays for it in every message
    with_see = summary(per_message_seconds(lambda m: parse_perception(m).vision, messages, repeats=5), has_vision)
    theirs = summary(per_message_seconds(lambda m: sexpdata.loads("(" + m + ")"), messages, repeats=2), has_vision)
    print(f"{'':24}{'typical (median)':>18}{'mean vision':>14}{'mean no vision':>16}")
    for name, (median, vision, plain) in (
        ("parse_perception", ours),
        ("  and .vision read", with_see),
        ("sexpdata.loads", theirs),
    ):
        print(f"{name:24}{median * 1e6:15.1f} us{vision * 1e6:11.1f} us{plain * 1e6:13.1f} us")
    print(f"typical rate: {1 / ours[0]:,.0f} perceptions/s on one core")
    print(
        "speed-up over sexpdata, .vision read: typical {:.1f}x, vision {:.1f}x, no vision {:.1f}x".format(
            *(t / o for t, o in zip(theirs, with_see))
        )
    )

    monitor = (FIXTURES / "monitor_full_run.txt").read_text().splitlines()
    deltas = [i for i, m in enumerate(monitor) if "(RDS " in m]
    runs = []
    for _ in range(5):
        reader = MonitorReader()
        spent = []
        for msg in monitor:
            start = time.perf_counter()
            reader.feed(msg)
            spent.append(time.perf_counter() - start)
        runs.append(spent)
    best = [min(run[i] for run in runs) for i in range(len(monitor))]
    full = [best[i] for i in range(len(monitor)) if i not in set(deltas)]
    print(
        f"monitor reader: delta median {statistics.median(best[i] for i in deltas) * 1e6:.1f} us "
        f"({len(deltas)} deltas), full scene mean {statistics.fmean(full) * 1e6:.0f} us ({len(full)} full)"
    )


if __name__ == "__main__":
    main()
