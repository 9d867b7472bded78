"""Long fuzzing run of the stand-in server (``server_stub.fuzz``): mutated real messages on both
ports, framing abuse, connect/reset storms, against a stub in sync mode and one in real time.

    python -m bench.bench_fuzz [--messages 1000000] [--seed 0] [--realtime-share 0.2] [--fixtures DIR]

Prints, per mode and in total: messages sent (and survived: a crash is counted when the stub
exits or stops serving a well-behaved agent, and the stub is then restarted), sessions, reset
connections, crashes, the stub's peak RSS, and the size of its warning log.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from server_stub import fuzz

#: The real server's captured traffic, kept with the tests.
FIXTURES = Path(__file__).resolve().parents[1] / "tests" / "data" / "rcssserver3d"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_fuzz", description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=1_000_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--realtime-share",
        type=float,
        default=0.2,
        help="share of the messages sent to a real-time stub (the rest: sync)",
    )
    parser.add_argument("--fixtures", type=Path, default=FIXTURES)
    parser.add_argument("--log-dir", type=Path, default=Path("."))
    args = parser.parse_args(argv)
    fixtures = args.fixtures if args.fixtures.is_dir() else None
    total = fuzz.FuzzReport()
    started = time.perf_counter()
    realtime = int(args.messages * args.realtime_share)
    for sync, count in ((True, args.messages - realtime), (False, realtime)):
        if count <= 0:
            continue
        mode = "sync" if sync else "realtime"
        mode_started = time.perf_counter()

        def progress(report: fuzz.FuzzReport, mode: str = mode, t0: float = mode_started) -> None:
            if report.sessions % 1000 == 0:
                rate = report.messages / (time.perf_counter() - t0)
                print(
                    f"  {mode}: {report.messages} messages, {report.crashes} crashes, "
                    f"peak RSS {report.peak_rss_mib:.1f} MiB, {rate:.0f} messages/s",
                    flush=True,
                )

        report = fuzz.run(
            count,
            seed=args.seed,
            fixtures=fixtures,
            sync=sync,
            log_path=args.log_dir / f"fuzz-stub-{mode}.log",
            progress=progress,
        )
        survived = report.messages if not report.crashes else f"{report.messages} (with restarts)"
        print(
            f"{mode}: messages {survived}, sessions {report.sessions}, reset connections "
            f"{report.resets}, crashes {report.crashes}, peak RSS {report.peak_rss_mib:.1f} MiB, "
            f"log {report.log_bytes / 1e6:.1f} MB (longest line {report.longest_log_line} chars), "
            f"{time.perf_counter() - mode_started:.0f} s",
            flush=True,
        )
        for crash in report.crash_logs:
            print(f"--- crash log tail ({mode}) ---\n{crash}")
        total.messages += report.messages
        total.sessions += report.sessions
        total.resets += report.resets
        total.crashes += report.crashes
        total.peak_rss_mib = max(total.peak_rss_mib, report.peak_rss_mib)
    elapsed = time.perf_counter() - started
    print(
        f"total: messages {total.messages}, sessions {total.sessions}, reset connections {total.resets}, "
        f"crashes {total.crashes}, peak RSS {total.peak_rss_mib:.1f} MiB, {elapsed:.0f} s "
        f"({total.messages / elapsed:.0f} messages/s)"
    )
    return 1 if total.crashes else 0


if __name__ == "__main__":
    sys.exit(main())
