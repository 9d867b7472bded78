"""``python -m server_stub``: the stand-in for rcssserver3d on the agent and monitor ports."""

from __future__ import annotations

import argparse
import gc
import logging
import os
import signal
import sys

from protocol.cli_values import listening_port, positive_float, whole
from server_stub.config import ServerConfig


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m server_stub", description=__doc__)
    p.add_argument("--host", default="127.0.0.1", help="listen address (default 127.0.0.1)")
    p.add_argument("--agent-port", type=listening_port, default=3100, help="agent port (default 3100; 0 = free port)")
    p.add_argument(
        "--monitor-port", type=listening_port, default=3200, help="monitor/trainer port (default 3200; 0 = free port)"
    )
    p.add_argument("--sync", action="store_true", help="step once every agent has sent (syn)")
    p.add_argument(
        "--realtime",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="pace cycles at 50 Hz (default: on, off with --sync)",
    )
    p.add_argument("--sense-mypos", action="store_true", help="add mypos/myorien/ballpos to vision")
    p.add_argument(
        "--vision-noise",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="noise on vision (default on, as on the real server)",
    )
    p.add_argument(
        "--beam-noise",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="move each beam by up to 0.05 m and 10 deg at random (default on, as on the real server)",
    )
    p.add_argument("--seed", type=whole, default=0, help="seed of every random choice (vision and beam noise)")
    p.add_argument(
        "--agent-timeout",
        type=positive_float,
        default=10.0,
        help="sync mode: disconnect an agent silent this many wall seconds (default 10)",
    )
    p.add_argument(
        "--exit-with-parent",
        action="store_true",
        help="exit when the process that started the server dies (for optimizer workers)",
    )
    p.add_argument(
        "--cycle-times",
        metavar="FILE",
        default="",
        help="when stopping, write every cycle's wall times (physics step and whole cycle, ms) and play mode "
        "(its index in the monitor's play_modes) to FILE as JSON",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="log connections")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="server_stub %(levelname)s: %(message)s",
        stream=sys.stderr,
    )
    # pybullet's C code prints banners to file descriptor 1; keep our stdout for the one line a
    # parent process reads (the ports) and send everything native to stderr
    ports_out = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    from server_stub.net.server import StubServer

    realtime = (not args.sync) if args.realtime is None else args.realtime
    config = ServerConfig(
        host=args.host,
        agent_port=args.agent_port,
        monitor_port=args.monitor_port,
        sync=args.sync,
        realtime=realtime,
        sense_mypos=args.sense_mypos,
        vision_noise=args.vision_noise,
        beam_noise=args.beam_noise,
        seed=args.seed,
        agent_timeout=args.agent_timeout,
        parent_pid=os.getppid() if args.exit_with_parent else 0,
        cycle_times=args.cycle_times,
    )
    try:
        server = StubServer(config)
    except OSError as exc:
        print(f"server_stub: error: cannot listen on {args.host}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    # a parent that started us on free ports reads this line to learn them
    print(
        f"server_stub listening: agent port {server.agent_port}, monitor port {server.monitor_port}",
        file=ports_out,
        flush=True,
    )
    # SIGTERM and Ctrl-C end the loop after the cycle in hand (``StubServer.stop``), so neither
    # lands inside a physics kernel as an exception
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: server.stop())
    # Everything made so far (the compiled kernels' and the modules' objects: about 120,000)
    # lives as long as the process; frozen out of the cyclic collector, a full collection no
    # longer walks them: it took 43-52 ms, a stalled cycle every few hundred cycles of a
    # 22-player match (bench/bench_match.py)
    gc.freeze()
    server.serve_forever()
    return 0


if __name__ == "__main__":
    sys.exit(main())
