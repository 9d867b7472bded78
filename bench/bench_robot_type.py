"""A heterogeneous robot type on the stand-in against a real rcssserver3d: standing and walking.

Standing: a robot of ``--type`` (default 4, the toes) is created, initialised, beamed to
(-3, 2, 0) with every joint at 0 and left for 200 cycles in sync mode, on each server; printed:
the torso's resting height (the monitor's), every ``FRP`` of the last perception, and that
perception's order of ``HJ`` and ``FRP`` entries.

Walking: the calibration walk (the shipped gait) and ``--gaits`` of the fidelity set, ``--walks``
walks each on each server, walk k with seed k of a 0.001 rad/s command dither (as
``bench/bench_fidelity.py`` walks them), compared as it compares them.

    RCSSSERVER3D=/opt/rcss/bin/rcss-sync python -m bench.bench_robot_type --type 4 --walks 5 \\
        --gaits line-01,line-10 --out /tmp/type4 [--data tests/data/rcssserver3d/robot_type4.json]

``--data FILE`` writes the real server's figures (standing, the perception, each gait's walks)
for the tests to compare the stand-in with when no real server is at hand
(``tests/test_robot_type4.py``). Exit status 1 when no real server is found.
"""

from __future__ import annotations

import argparse
import json
import re
import select
import socket
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from bench.fidelity import (
    FidelityConfig,
    FidelityGait,
    GaitComparison,
    compare,
    gait_set,
    print_progress,
    real_server_or_none,
    report,
    summarize,
    write_tracks,
)
from gait import DEFAULT_GAIT_PATH, load_gait
from optimizer.episode.monitor_link import MonitorLink
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs
from optimizer.episode.servers import ServerProcess, StubProcess
from protocol import commands, trainer
from protocol.cli_values import positive_int
from protocol.framing import FrameDecoder, encode_frame
from protocol.nao import ROBOT_TYPES
from protocol.perception import parse_perception

#: Where the robot stands and for how long (cycles after the beam).
STAND_AT = (-3.0, 2.0, 0.0)
STAND_CYCLES = 200
#: Cycles after asking for a full scene: the monitor updates every second cycle.
_FULL_STATE_CYCLES = 4
#: The dither of the walks (rad/s), as the fidelity benchmark's.
COMMAND_NOISE = 0.001
_ENTRY = re.compile(r"\((HJ|FRP) \(n (\w+)\)")


class _Agent:
    """A bare agent connection: frames in and out, a ``(syn)`` with every message."""

    def __init__(self, port: int, nudge: bool) -> None:
        self._sock = socket.create_connection(("127.0.0.1", port), timeout=10.0)
        self._decoder = FrameDecoder()
        self._frames: list[bytes] = []
        #: the real server answers a silent new agent only after about 2 s (robot_and_server.md 11)
        self._nudge = nudge

    def send(self, text: str) -> None:
        self._sock.sendall(encode_frame(text + commands.syn()))

    def receive(self) -> str:
        while not self._frames:
            ready, _, _ = select.select([self._sock], [], [], 0.01 if self._nudge else 10.0)
            if not ready:
                if not self._nudge:
                    raise TimeoutError("no perception")
                self._sock.sendall(encode_frame(commands.syn()))
                continue
            data = self._sock.recv(1 << 16)
            if not data:
                raise ConnectionError("the server closed the agent connection")
            self._frames.extend(self._decoder.feed(data))
        self._nudge = False
        return self._frames.pop(0).decode("ascii")

    def close(self) -> None:
        self._sock.close()


def stand(server: ServerProcess, robot_type: int, nudge: bool) -> dict:
    """A robot of ``robot_type`` left standing on ``server`` (module docstring): its resting torso
    height, the last perception's FRPs and order of entries, and that perception's text."""
    address = server.ensure_running()
    link = MonitorLink(address, 10.0)
    agent = _Agent(address.agent_port, nudge)
    try:
        agent.send(commands.scene(robot_type or None))
        agent.receive()
        agent.send(commands.init(9, "Stand"))
        agent.receive()
        agent.send(commands.beam(*STAND_AT))
        for cycle in range(STAND_CYCLES + _FULL_STATE_CYCLES):
            if cycle == STAND_CYCLES:
                # a delta resends a torso only when it moved by more than 0.005 (section 9): the
                # resting height needs a full scene, which comes with a later update
                link.poll()
                link.send(trainer.req_full_state())
            message = agent.receive()
            agent.send("")
        # the monitor stream may lag the agent's: read it until it stops (the server waits for a syn)
        states = link.poll(wait=1.0)
        while more := link.poll(wait=0.5):
            states += more
        torso = states[-1].robots[0].position
    finally:
        agent.close()
        link.close()
    perception = parse_perception(message)
    return {
        "torso_height": torso[2],
        "frp": {name: [list(f.centre), list(f.force)] for name, f in perception.frp.items()},
        "order": [f"{kind} {name}" for kind, name in _ENTRY.findall(message)],
        "perception": message,
    }


def _standing_line(label: str, figures: dict) -> str:
    forces = ", ".join(f"{name} {force[2]:.2f} N" for name, (_, force) in figures["frp"].items())
    return f"{label:9s} torso {figures['torso_height']:.4f} m; FRP z {forces}"


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m bench.bench_robot_type",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--type", dest="robot_type", type=int, choices=ROBOT_TYPES, default=4)
    p.add_argument("--walks", type=positive_int, default=5, metavar="K", help="walks per gait on each server")
    p.add_argument(
        "--gaits", default="", metavar="NAME,...", help="gaits of the fidelity sets (all) besides the shipped gait"
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR")
    p.add_argument("--data", type=Path, default=None, metavar="FILE", help="write the real server's figures here")
    return p


def _gaits(names: str) -> list[FidelityGait]:
    shipped = load_gait(DEFAULT_GAIT_PATH)  # a TFS gait, as the sets' are
    calibration = FidelityGait("shipped", "calibration", tuple(shipped.genes), "gait/default_gait.json")
    wanted = [name.strip() for name in names.split(",") if name.strip()]
    chosen = {g.name: g for g in gait_set("all") if g.name in wanted}
    missing = sorted(set(wanted) - set(chosen))
    if missing:
        raise SystemExit(f"error: not in the fidelity sets: {', '.join(missing)}")
    return [calibration, *(chosen[name] for name in wanted)]


def _real_figures(robot_type: int, real: dict, comparisons: Sequence[GaitComparison]) -> dict:
    """What the tests keep of the real server: standing, its perception, every walk's outcome."""
    return {
        "format": "robot-type-real/1",
        "robot_type": robot_type,
        "server": "rcssserver3d 0.7.3 (rcss-sync profile)",
        "standing": {k: real[k] for k in ("torso_height", "frp", "order", "perception")},
        "walks": {
            "command_noise": COMMAND_NOISE,
            "gaits": {
                c.gait.name: {
                    "genes": list(c.gait.genes),
                    "distances": [round(w.distance, 4) for w in c.real.walks],
                    "fell": [w.fell for w in c.real.walks],
                }
                for c in comparisons
            },
        },
    }


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    command = real_server_or_none()
    if command is None:
        return 1
    quiet_agent_logs()
    started = time.monotonic()
    stub_server, real_server = StubProcess(), RealServerProcess(command)
    try:
        stub = stand(stub_server, args.robot_type, nudge=False)
    finally:
        stub_server.stop()
    try:
        real = stand(real_server, args.robot_type, nudge=True)
    finally:
        real_server.stop()
    print(_standing_line("stand-in", stub))
    print(_standing_line("real", real))
    print("perception order equal:", stub["order"] == real["order"])
    gaits = _gaits(args.gaits)
    config = FidelityConfig(
        real_repeats=args.walks,
        stand_in_repeats=args.walks,
        command_noise=COMMAND_NOISE,
        robot_type=args.robot_type,
    )
    comparisons = compare(gaits, command, config, print_progress)
    summary = summarize(comparisons, config.targets)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "standing.json").write_text(json.dumps({"stand_in": stub, "real": real}, indent=1) + "\n")
    about = {"set": "robot type", "real_command": command, "command_line": " ".join(sys.argv)}
    write_tracks(comparisons, summary, config, args.out / "fidelity.json", about)
    print(report(comparisons, summary, config.targets))
    if args.data is not None:
        args.data.write_text(json.dumps(_real_figures(args.robot_type, real, comparisons), indent=1) + "\n")
    print(f"({time.monotonic() - started:.0f} s; written to {args.out})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
