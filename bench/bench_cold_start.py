"""Cold start: how long the first episode takes on a fresh clone, numba's compilation included.

numba compiles the stand-in's kernels and keeps them in its disk cache; a fresh clone (or a new
machine, or a changed kernel) has no cache, so its first episode pays for every compile (in two
processes: ``server_stub.kernels``).
This runs ``python -m optimizer.episode --json`` (the shipped gait on the embedded stand-in) in a
new process with an empty cache directory (cold), then again with the cache it left (warm), and
prints both wall times.

    python -m bench.bench_cold_start             # 3 cold and 3 warm runs
    python -m bench.bench_cold_start --runs 1
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def episode(cache: Path) -> float:
    """Wall seconds of one ``python -m optimizer.episode`` with numba's cache in ``cache``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "optimizer.episode", "--json"], cwd=ROOT, env=env, capture_output=True, text=True
    )
    elapsed = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"the episode failed (exit {done.returncode}):\n{done.stderr[-2000:]}")
    return elapsed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.bench_cold_start",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--runs", type=int, default=3, help="cold runs (each with a new empty cache), default 3")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs must be >= 1, got {args.runs}")
    cold, warm = [], []
    for _ in range(args.runs):
        with tempfile.TemporaryDirectory(prefix="numba_cache_") as cache:
            cold.append(episode(Path(cache)))
            warm.append(episode(Path(cache)))
        print(f"cold {cold[-1]:6.1f} s   warm {warm[-1]:5.1f} s", flush=True)
    print(
        f"first episode on a fresh clone: median {statistics.median(cold):.1f} s (target <= 20 s); "
        f"with numba's cache: {statistics.median(warm):.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
