"""Agent cycle budget: parse + gait + control + send, per perception (target: p99 <= 1 ms).

Replays every perception of the real-server captures through the agent's cycle (the same
``WalkBehaviour`` the agent runs, walking from the first cycle) and sends each reply over a
loopback socket pair with TCP-like framing. Run: ``python -m bench.bench_agent_cycle``.
"""

from __future__ import annotations

import logging
import platform
import socket
import statistics
import time
from pathlib import Path

from agent.behaviour import WalkBehaviour
from agent.config import AgentConfig
from gait import load_gait
from protocol.framing import encode_frame
from protocol.perception import parse_perception

FIXTURES = Path(__file__).resolve().parents[1] / "tests" / "data" / "rcssserver3d"


def main() -> None:
    logging.disable(logging.WARNING)  # the replayed robot falls; its log line is not the point
    files = [FIXTURES / "agent_perceptions_full_run.txt"] + sorted(
        (FIXTURES / "walk_calibration").glob("run*_perceptions.txt")
    )
    messages = [line for f in files for line in f.read_text().splitlines()]
    send, recv = socket.socketpair()
    recv.setblocking(False)
    samples: list[float] = []
    for _ in range(3):
        behaviour = WalkBehaviour(AgentConfig(sync=True, start_now=True, settle_cycles=0), load_gait().walker())
        for text in messages:
            t0 = time.perf_counter()
            reply = behaviour.reply(parse_perception(text)) + "(syn)"
            send.sendall(encode_frame(reply))
            samples.append(time.perf_counter() - t0)
            try:
                recv.recv(1 << 16)
            except BlockingIOError:
                pass
    samples.sort()
    p50 = statistics.median(samples) * 1e6
    p99 = samples[int(0.99 * len(samples))] * 1e6
    print(f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}")
    print(
        f"agent cycle over {len(samples)} perceptions: median {p50:.1f} us, p99 {p99:.1f} us, "
        f"max {samples[-1] * 1e6:.1f} us (target p99 <= 1000 us)"
    )


if __name__ == "__main__":
    main()
