"""Does a walk survive how it starts? The shipped gait with the agent's repeated beam at several
settle cycles, on the stand-in or on a real rcssserver3d.

On the real server the shipped gait from (-5, 0, 0) falls within 1.5 s when the beam is repeated at
settle cycle 8 or 10, or not at all, and walks about 3 m otherwise; a stand-in should do the same
(``tests/test_fidelity_start.py`` holds the real server's walks and checks the stand-in against
them). One JSON line per re-beam cycle: distances, falls and walk times.

    python -m bench.bench_start_timing [--real] [--repeats R]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from bench.fidelity import real_server_or_none
from gait import load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs
from protocol.cli_values import positive_int

#: Settle cycles of the repeated beam to try (None: no repeated beam).
CASES = (8, 10, 11, 12, 13, 14, 16, None)


def main() -> int:
    p = argparse.ArgumentParser(prog="python -m bench.bench_start_timing", description=__doc__)
    p.add_argument("--real", action="store_true", help="on a real server (RCSSSERVER3D, then PATH)")
    p.add_argument("--repeats", type=positive_int, default=1, help="walks per case (default 1)")
    args = p.parse_args()
    quiet_agent_logs()
    server = None
    if args.real:
        command = real_server_or_none()
        if command is None:
            print("no real server: set RCSSSERVER3D or put rcssserver3d on PATH", file=sys.stderr)
            return 1
        server = RealServerProcess(command)
    with EpisodeRunner(EpisodeConfig(), server=server) as runner:
        for rebeam in CASES:
            runner.config = dataclasses.replace(EpisodeConfig(), rebeam_cycle=rebeam)
            walks = [runner.evaluate(load_gait()) for _ in range(args.repeats)]
            row = {
                "rebeam_cycle": rebeam,
                "distance": [round(w.distance, 3) for w in walks],
                "fell": [w.fell for w in walks],
                "time": [round(w.time, 2) for w in walks],
            }
            print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
