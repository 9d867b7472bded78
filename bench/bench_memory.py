"""Memory of a stand-in server that serves many episodes: RSS against episodes.

Each episode is what an optimizer worker does to its stub, over real sockets: an agent connects,
creates its robot (``scene``), ``init``s, beams, runs a few cycles and disconnects, which removes
the robot. The stub runs as its own process (``python -m server_stub --sync``); its resident set
is read from ``/proc/PID/status`` every ``--every`` episodes.

    python -m bench.bench_memory [--episodes 10000] [--cycles 5] [--every 1000] [--repo DIR]

``--repo`` runs the stub of another checkout (e.g. an older commit unpacked with ``git archive``),
to compare before and after.
"""

from __future__ import annotations

import argparse
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _frame(text: str) -> bytes:
    body = text.encode()
    return struct.pack("!I", len(body)) + body


def _receive(sock: socket.socket, buffer: bytearray) -> bytes:
    """One framed message (the rest stays in ``buffer``)."""
    while True:
        if len(buffer) >= 4:
            (size,) = struct.unpack_from("!I", buffer)
            if len(buffer) >= 4 + size:
                body = bytes(buffer[4 : 4 + size])
                del buffer[: 4 + size]
                return body
        chunk = sock.recv(1 << 16)
        if not chunk:
            raise ConnectionError("stub closed the connection")
        buffer += chunk


def episode(port: int, cycles: int, unum: int) -> None:
    """One agent's life on the stub: scene, init, beam, ``cycles`` cycles, gone."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
        buffer = bytearray()
        sock.sendall(_frame("(scene rsg/agent/nao/nao.rsg)(syn)"))
        _receive(sock, buffer)
        sock.sendall(_frame(f"(init (unum {unum})(teamname Bench))(syn)"))
        _receive(sock, buffer)
        sock.sendall(_frame("(beam -1 0 0)(syn)"))
        for _ in range(cycles):
            _receive(sock, buffer)
            sock.sendall(_frame("(he1 0.5)(lle3 0.2)(syn)"))


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for process {pid}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_memory", description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10_000)
    parser.add_argument("--cycles", type=int, default=5, help="cycles each agent runs (default 5)")
    parser.add_argument("--every", type=int, default=1000, help="print RSS every N episodes")
    parser.add_argument("--repo", type=Path, default=REPO, help="checkout whose server_stub to run")
    args = parser.parse_args(argv)
    stub = subprocess.Popen(
        [sys.executable, "-m", "server_stub", "--sync", "--no-realtime", "--agent-port", "0", "--monitor-port", "0"],
        cwd=args.repo,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        line = stub.stdout.readline()
        port = int(line.split("agent port ")[1].split(",")[0])
        episode(port, args.cycles, 1)  # warm: the first robot loads the model, numba caches load
        start_rss = rss_mib(stub.pid)
        started = time.perf_counter()
        print(f"stub {args.repo}: {args.episodes} episodes of {args.cycles} cycles, RSS in MiB")
        print(f"{'episodes':>9} {'RSS':>8} {'growth':>8} {'per episode':>12}")
        print(f"{0:>9} {start_rss:>8.1f} {0.0:>8.2f} {'':>12}")
        for n in range(1, args.episodes + 1):
            episode(port, args.cycles, 1 + n % 11)
            if n % args.every == 0 or n == args.episodes:
                now = rss_mib(stub.pid)
                growth = now - start_rss
                print(f"{n:>9} {now:>8.1f} {growth:>8.2f} {growth * 1024 / n:>9.2f} KiB", flush=True)
        elapsed = time.perf_counter() - started
        print(f"{args.episodes / elapsed:.0f} episodes/s; stub alive: {stub.poll() is None}")
    finally:
        stub.terminate()
        stub.wait(10)
    return 0


if __name__ == "__main__":
    sys.exit(main())
