"""server_stub speed: simulated seconds per wall second, end to end and raw, in one run.

1. One NAO driven by the project's agent (in this process) over sockets in sync mode, real time
   off, for 60 simulated seconds of walking;
2. the same model stepped without sockets for as many cycles (World.step + reading every sensor
   the server reads for a perception), i.e. the raw physics rate;
3. 11 and 22 agents (separate ``python -m agent`` processes) on one stub.

Targets (issue): >= 80x real time for 1, and sockets + protocol + agent costing <= 15% of the raw
rate. Run: ``python -m bench.bench_stub [--seconds 60]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

from agent import AgentConfig, NaoAgent
from protocol.nao import CYCLE

REPO = Path(__file__).resolve().parents[1]


def start_stub() -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "server_stub", "--sync", "--no-realtime", "--agent-port", "0", "--monitor-port", "0"],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    port = int(re.search(r"agent port (\d+)", proc.stdout.readline()).group(1))
    return proc, port


def one_agent(port: int, seconds: float) -> tuple[float, int]:
    agent = NaoAgent(AgentConfig(port=port, sync=True, start_now=True, duration=seconds, beam=(-5.0, 0.0, 0.0)))
    t0 = time.perf_counter()
    report = agent.run()
    return time.perf_counter() - t0, report.cycles


def raw_physics(cycles: int) -> float:
    from server_stub.physics import calibration_walk
    from server_stub.physics.world import World

    with World() as world:
        robot = world.add_robot()
        robot.beam(-5.0, 0.0, 0.0)
        t0 = time.perf_counter()
        for k in range(cycles):
            for effector, v in calibration_walk.velocities(k * CYCLE, robot.joint_angles()).items():
                robot.command(effector, v)
            world.step()
            robot.gyro(), robot.accelerometer(), robot.foot_pressure()
            if k % 3 == 0:
                robot.head_pose()
        return time.perf_counter() - t0


def many_agents(port: int, count: int, seconds: float) -> float:
    t0 = time.perf_counter()
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "agent",
                "--port",
                str(port),
                "--sync",
                "--start-now",
                "--team",
                "Bench",
                "--unum",
                str(k + 1),
                "--duration",
                str(seconds),
                "--beam",
                str(-1.0 - k % 11),
                str(-4.0 + 8.0 * (k // 11)),
                "0",
            ],
            cwd=REPO,
            stderr=subprocess.DEVNULL,
        )
        for k in range(count)
    ]
    for p in procs:
        p.wait()
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_stub")
    parser.add_argument("--seconds", type=float, default=60.0)
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    proc, port = start_stub()
    try:
        wall, cycles = one_agent(port, args.seconds)
        end_to_end = cycles * CYCLE / wall
        raw = cycles * CYCLE / raw_physics(cycles)
        print(
            f"1 NAO, agent over sockets (sync): {cycles} cycles in {wall:.2f} s = {end_to_end:.1f}x real time "
            f"(target >= 80x)"
        )
        print(f"same model, raw physics + sensors:  {raw:.1f}x real time")
        print(f"sockets + protocol + agent cost: {100 * (1 - end_to_end / raw):.1f}% of the raw rate (target <= 15%)")
        for count in (11, 22):
            seconds = 10.0
            wall = many_agents(port, count, seconds)
            sim = seconds + 27 * CYCLE  # walking plus handshake and settling
            print(f"{count} agents (processes): {sim / wall:.2f}x real time ({wall:.1f} s wall for {sim:.1f} s)")
    finally:
        proc.terminate()
        proc.wait()


if __name__ == "__main__":
    main()
