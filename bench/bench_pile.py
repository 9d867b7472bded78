"""A pile of robots: the cost of one physics cycle when several NAOs lie on top of each other.

A real game has piles (robots falling over each other at the ball); the stand-in solves every group
of touching bodies as one island (``server_stub.physics.stepper``), so a pile is its worst cycle.
Robots are added and stepped once apart (each one's model read: that step is printed on its
own), then beamed around one spot (a ring of radius ``--spread``, facing its centre, the ball in
the middle) and driven with random joint speeds, changed every 10 cycles, so they flail into a
tangle. Prints the percentiles of the wall time of ``World.step`` per cycle and the most touching
points a cycle had; issue 28's target is <= 20 ms a cycle for a pile of 6.

    python -m bench.bench_pile                 # 6 robots, 250 cycles
    python -m bench.bench_pile --robots 4 --cycles 500 --seed 2
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from protocol.nao import JOINTS
from server_stub.kernels import warm_up
from server_stub.physics.world import World


def pile(robots: int, cycles: int, spread: float, seed: int) -> tuple[np.ndarray, int, float]:
    """Wall seconds of each cycle's step, the most contact points any robot saw in a cycle
    summed over the robots, and the wall seconds of the robots' first step (before the pile)."""
    rng = np.random.default_rng(seed)
    times = np.empty(cycles)
    most = 0
    with World() as world:
        bodies = [world.add_robot() for _ in range(robots)]
        # the robots' first step, apart: where the step reads each one's model from pybullet, once
        # a robot, as a game's players join (one at a time) before they beam
        started = time.perf_counter()
        world.step()
        joined = time.perf_counter() - started
        for k, robot in enumerate(bodies):
            angle = 2.0 * math.pi * k / robots
            robot.beam(spread * math.cos(angle), spread * math.sin(angle), math.degrees(angle) + 180.0)
        world.set_ball((0.0, 0.0, 0.042))
        for cycle in range(cycles):
            if cycle % 10 == 0:
                for robot in bodies:
                    for joint, speed in zip(JOINTS, rng.normal(size=len(JOINTS)) * 3.0):
                        robot.command(joint.effector, float(speed))
            started = time.perf_counter()
            world.step()
            times[cycle] = time.perf_counter() - started
            most = max(most, sum(len(robot.contact_points()) for robot in bodies))
    return times, most, joined


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.bench_pile", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robots", type=int, default=6, help="robots in the pile (default 6)")
    parser.add_argument("--cycles", type=int, default=250, help="cycles to step (default 250)")
    parser.add_argument("--spread", type=float, default=0.15, help="radius of the ring they are beamed on (m)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the random joint speeds")
    args = parser.parse_args(argv)
    if args.robots < 1 or args.cycles < 1 or args.spread < 0.0:
        parser.error("--robots and --cycles must be >= 1 and --spread >= 0")
    warm_up()
    times, most, joined = pile(args.robots, args.cycles, args.spread, args.seed)
    ms = times * 1000.0
    p50, p90, p99 = np.percentile(ms, [50, 90, 99])
    print(
        f"{args.robots} robots, {args.cycles} cycles: step p50 {p50:.2f} ms, p90 {p90:.2f} ms, "
        f"p99 {p99:.2f} ms, max {ms.max():.2f} ms; cycles over 20 ms: {int(np.sum(ms > 20.0))}; "
        f"most contact points in a cycle: {most}; the robots' first step, before the pile: {joined * 1000.0:.2f} ms"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
