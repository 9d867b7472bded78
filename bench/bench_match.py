"""A match's load: two teams of 11 of our agents on the stand-in in real time, and what each cycle
costs the server.

Starts ``python -m server_stub --cycle-times FILE`` (real time, 50 cycles a second) and 22
``python -m agent`` processes, 11 a side, each beamed on its own half in two lines. Once every
robot has its number and has beamed, a trainer connection sets play on, and they walk the
shipped gait towards the other team, so that they meet, bump and fall near the centre line (the
referee lifts and puts outside those that stay down). After ``--minutes`` of play the server is
stopped (SIGTERM; the second half is started as the first ends, at 300 s) and writes every
cycle's wall time of the physics step and of the whole cycle (perceptions, vision and the monitor
included) and its play mode; this prints their percentiles
and the cycles over 20 ms, for the players joining and for the play. Issue 28's target: on 2
cores, 10 minutes of play with no cycle's physics over 20 ms.

    python -m bench.bench_match                 # 10 minutes
    python -m bench.bench_match --minutes 1 --players 4
    python -m bench.bench_match --types 0,1,2,3,0,1,2,3,4,4,4   # every robot type, the toes on 9-11
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from protocol.framing import encode_frame
from protocol.monitor import MonitorReader
from protocol.nao import PLAY_MODES

ROOT = Path(__file__).resolve().parents[1]


def start_server(times: Path) -> tuple[subprocess.Popen, int, int]:
    """The stand-in on free ports, in real time, writing its cycle times to ``times``."""
    server = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "server_stub",
            "--agent-port",
            "0",
            "--monitor-port",
            "0",
            "--cycle-times",
            str(times),
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    assert server.stdout is not None
    found = re.search(r"agent port (\d+), monitor port (\d+)", server.stdout.readline())
    if found is None:
        server.kill()
        raise SystemExit("the stand-in did not start")
    return server, int(found.group(1)), int(found.group(2))


def start_players(
    port: int,
    players: int,
    seconds: float,
    extra: tuple[str, ...] = (),
    start_now: bool = True,
    types: tuple[int, ...] = (0,) * 11,
) -> list[subprocess.Popen]:
    """``players`` agents a side: beamed in two lines on their own half (each team's beam is in
    its own frame, its goal at -x), facing the other half, walking at once (``start_now``) or
    from play on; number k on robot type ``types[k - 1]``; ``extra``: more flags for each."""
    agents = []
    for team in ("Home", "Away"):
        for unum in range(1, players + 1):
            x = -1.0 - 1.2 * ((unum - 1) // 2)
            y = -4.0 + 8.0 * ((unum - 1) % 2) + 0.3 * (unum - 1) / max(players, 1)
            agents.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "agent",
                        "--port",
                        str(port),
                        "--team",
                        team,
                        "--unum",
                        str(unum),
                        "--beam",
                        f"{x:.2f}",
                        f"{y:.2f}",
                        "0",
                        *(["--start-now"] if start_now else []),
                        "--type",
                        str(types[unum - 1]),
                        "--duration",
                        f"{seconds:.0f}",
                        *extra,
                    ],
                    cwd=ROOT,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        time.sleep(1.0)  # the first team to connect takes the left side
    return agents


def monitor_frames(sock: socket.socket, quiet: float = 180.0) -> Iterator[str]:
    """The monitor stream's messages, as text, until the server closes it or goes quiet ``quiet``
    seconds (in sync mode it waits for every agent that has connected, and players take a while)."""
    sock.settimeout(quiet)
    buffer = b""
    while True:
        try:
            data = sock.recv(1 << 16)
        except TimeoutError:
            return
        if not data:
            return
        buffer += data
        while len(buffer) >= 4 and len(buffer) >= 4 + (size := int.from_bytes(buffer[:4], "big")):
            yield buffer[4 : 4 + size].decode("latin-1")
            buffer = buffer[4 + size :]


def play_when_joined(trainer: socket.socket, messages: Iterator[str], robots: int) -> None:
    """Read the monitor stream until ``robots`` robots have their team and number, then 50
    messages more (100 cycles: their beams), and set play on: a beam in play is ignored, and a
    robot would walk from where ``init`` put it, by its goal line."""
    reader = MonitorReader()
    for message in messages:
        state = reader.feed(message)
        if sum(robot.unum is not None for robot in state.robots) >= robots:
            break
    for _ in zip(range(50), messages):
        pass
    trainer.sendall(encode_frame("(playMode PlayOn)"))


def percentiles(ms: np.ndarray) -> str:
    p50, p90, p99, p999 = np.percentile(ms, [50, 90, 99, 99.9])
    return (
        f"p50 {p50:.2f}, p90 {p90:.2f}, p99 {p99:.2f}, p99.9 {p999:.2f}, max {ms.max():.2f} ms; "
        f"over 20 ms: {int(np.sum(ms > 20.0))}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.bench_match", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--minutes", type=float, default=10.0, help="minutes of play in real time (default 10)")
    parser.add_argument("--players", type=int, default=11, help="agents a side (default 11)")
    parser.add_argument(
        "--types",
        default="0,0,0,0,0,0,0,0,0,0,0",
        help="robot types of numbers 1-11, comma-separated (default all 0)",
    )
    args = parser.parse_args(argv)
    if args.minutes <= 0.0 or not 1 <= args.players <= 11:
        parser.error("--minutes must be > 0 and --players 1-11")
    try:
        types = tuple(int(t) for t in args.types.split(","))
    except ValueError:
        parser.error(f"--types must be 11 comma-separated integers 0-4, got {args.types!r}")
    if len(types) != 11 or not all(0 <= t <= 4 for t in types):
        parser.error(f"--types must be 11 comma-separated integers 0-4, got {args.types!r}")
    with tempfile.TemporaryDirectory(prefix="bench_match_") as folder:
        times_file = Path(folder) / "cycle_times.json"
        started = time.monotonic()
        server, agent_port, monitor_port = start_server(times_file)
        seconds = args.minutes * 60.0
        agents = start_players(agent_port, args.players, seconds + 60.0, start_now=False, types=types)
        trainer = socket.create_connection(("127.0.0.1", monitor_port))
        messages = monitor_frames(trainer)
        play_when_joined(trainer, messages, 2 * args.players)
        deadline = time.monotonic() + seconds
        for message in messages:  # read and dropped, so that the server never waits on the trainer
            if time.monotonic() >= deadline:
                break
            if "(play_mode 0)" in message:  # the first half is over (300 s): play the second
                trainer.sendall(encode_frame("(playMode PlayOn)"))
        alive = sum(agent.poll() is None for agent in agents)
        server.send_signal(signal.SIGTERM)
        server.wait(60)
        served = time.monotonic() - started
        trainer.close()
        for agent in agents:
            agent.kill()
            agent.wait()
        times = json.loads(times_file.read_text())
    physics, cycle = np.array(times["physics"]), np.array(times["cycle"])
    modes = np.array(times["play_mode"])
    first = int(np.argmax(modes != PLAY_MODES.index("BeforeKickOff")))
    playing = np.arange(modes.size) >= first  # from the first cycle of play (half time included)
    print(
        f"{2 * args.players} agents (types {args.types}; {alive} still connected at the end), "
        f"{args.minutes:g} min of play in real time, {physics.size} cycles in {served:.0f} s of the server's life"
    )
    print(f"joining ({int(np.sum(~playing))} cycles before play): physics {percentiles(physics[~playing])}")
    print(f"joining: whole cycle {percentiles(cycle[~playing])}")
    print(f"play ({int(np.sum(playing))} cycles): physics {percentiles(physics[playing])}")
    print(f"play: whole cycle {percentiles(cycle[playing])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
