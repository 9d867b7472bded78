"""How often the real server's fouls fire in a game of the project's agents.

Starts the real server's sync wrapper of the shared build (``RCSSSERVER3D``, which takes
AGENT_PORT MONITOR_PORT: ``/opt/rcss/bin/rcss-sync``; a server started the optimizer's way, with
its own sync profile, stalled at game time 0 with 8 agents connecting) and ``--players`` agents
a side beamed as in ``bench/bench_match.py``; once every robot has beamed, the trainer sets play
on and they walk at each other; it reads the monitor stream for ``--seconds`` of game time. The
real server sends each foul it records as ``(foul INDEX TYPE TEAM UNUM)`` (SimSpark's
soccerruleitem.cpp), again every cycle while it holds the player in the air; this counts one
event per player and type (a new one after 0.5 s without a record) and prints them by type. With
``--stand-in`` the same game is played on the stand-in, which has the "incapable" foul only
(docs/robot_and_server.md section 8).

    RCSSSERVER3D=/opt/rcss/bin/rcss-sync python -m bench.real_fouls            # 4 a side, 60 s
    RCSSSERVER3D=/opt/rcss/bin/rcss-sync python -m bench.real_fouls --players 2 --seconds 20
    python -m bench.real_fouls --stand-in                                      # the same game on the stand-in
"""

from __future__ import annotations

import argparse
import collections
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

from bench.bench_match import monitor_frames, play_when_joined, start_players
from bench.record_referee import foul_runs
from optimizer.episode.real_server import find_rcssserver3d, free_port, kill_sim
from optimizer.episode.servers import ServerAddress

ROOT = Path(__file__).resolve().parents[1]

#: SimSpark 0.7.3's EFoulType, in order (soccerruleaspect.h).
FOULS = (
    "crowding",
    "touching",
    "illegal defence",
    "illegal attack",
    "incapable",
    "kick-off",
    "charging",
    "self-collision",
)
_FOUL = re.compile(r"\(foul (\d+) (\d+) (\d+) (\d+)\)")
_TIME = re.compile(r"\(time ([0-9.]+)\)")


def fouls(messages, seconds: float) -> tuple[list[tuple[float, str, int, int]], float]:
    """The foul events (game time, type, team 1 left / 2 right, unum) until ``seconds`` of game
    time, and the last game time seen."""
    records: dict[int, tuple[float, int, int, int]] = {}
    now = 0.0
    for message in messages:
        found = _TIME.search(message)
        if found:
            now = float(found.group(1))
        for foul in _FOUL.finditer(message):
            index, kind, team, unum = map(int, foul.groups())
            records.setdefault(index, (now, kind, team, unum))
        if now >= seconds:
            break
    runs = foul_runs([records[index] for index in sorted(records)])
    return [(t, FOULS[kind], team, unum) for kind, team, unum, t, _, _ in runs], now


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.real_fouls", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--players", type=int, default=4, help="agents a side (default 4)")
    parser.add_argument("--seconds", type=float, default=60.0, help="game seconds of play (default 60)")
    parser.add_argument("--stand-in", action="store_true", help="play on the stand-in (sync mode) instead")
    args = parser.parse_args(argv)
    if not 1 <= args.players <= 11 or args.seconds <= 0.0:
        parser.error("--players must be 1-11 and --seconds > 0")
    address = ServerAddress("127.0.0.1", free_port(), free_port())
    ports = [str(address.agent_port), str(address.monitor_port)]
    command = (
        [sys.executable, "-m", "server_stub", "--sync", "--no-realtime", "--agent-port", ports[0]]
        + ["--monitor-port", ports[1], "--exit-with-parent"]
        if args.stand_in
        else [find_rcssserver3d(), *ports]
    )
    server = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    agents: list[subprocess.Popen] = []
    try:
        time.sleep(3.0)  # the server's start (the stand-in's, with its kernels in numba's cache)
        monitor = socket.create_connection((address.host, address.monitor_port))
        started = time.monotonic()
        extra = ("--sync", "--timeout", "180")
        agents = start_players(address.agent_port, args.players, args.seconds + 60.0, extra, start_now=False)
        messages = monitor_frames(monitor)
        play_when_joined(monitor, messages, 2 * args.players)
        events, reached = fouls(messages, args.seconds)
        monitor.close()
        print(
            f"{2 * args.players} agents, {reached:.1f} s of game time in {time.monotonic() - started:.0f} s: "
            f"{len(events)} fouls, by type {dict(collections.Counter(e[1] for e in events))}"
        )
        for t, kind, team, unum in events:
            print(f"  {t:7.2f} s  {kind}  {'left' if team == 1 else 'right'} {unum}")
    finally:
        for agent in agents:
            agent.kill()
            agent.wait()
        if not args.stand_in:
            kill_sim(address)
        server.kill()
        server.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
