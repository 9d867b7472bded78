"""The omni walk engine's cost per control cycle: one robot's ``OmniWalker`` (``sense``,
``joint_targets``, ``moved``, as an agent calls them each cycle), and 64 robots stepped at once
through the robot-axis functions (``clip_command``, ``advance``, ``joint_angles``), per robot.

Run: ``python -m bench.bench_omni_cycle``. The first cycles (compiling or loading the kernels)
are not timed.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from gait import OMNI, Command, load_gait
from gait.omni import OmniWalker, joint_angles
from gait.omni_steps import OmniParams, advance, clip_command, standing
from protocol.nao import JOINTS

LIMITS = {j.effector: (j.min_deg, j.max_deg) for j in JOINTS}
CYCLE = 0.02
OMNI_START = Path(__file__).resolve().parents[1] / "gait" / "walks" / "omni_start.json"


def one_robot(cycles: int = 3000) -> float:
    """Microseconds per cycle of one walker."""
    gait = load_gait(OMNI_START)
    walker = gait.walker()
    assert isinstance(walker, OmniWalker)
    walker.command = Command(0.3, 0.05, 10.0)
    gyro, acc = (3.0, -2.0, 0.5), (0.3, -0.8, 9.7)
    for k in range(50):
        walker.sense(gyro, acc, {})
        walker.joint_targets(0.04 + k * CYCLE, LIMITS)
        walker.moved()
    t0 = time.perf_counter()
    for k in range(50, 50 + cycles):
        walker.sense(gyro, acc, {})
        walker.joint_targets(0.04 + k * CYCLE, LIMITS)
        walker.moved()
    return (time.perf_counter() - t0) / cycles * 1e6


def many_robots(n: int = 64, cycles: int = 300) -> float:
    """Microseconds per robot per cycle of ``n`` robots stepped together."""
    rng = np.random.default_rng(1)
    low, high = OMNI.bounds[:, 0], OMNI.bounds[:, 1]
    params = OmniParams(*(low + rng.random((n, len(low))) * (high - low)).T)
    commands = rng.uniform(-0.3, 0.3, (n, 3)) * [1.0, 1.0, 100.0]
    gyros, tilts = rng.normal(0.0, 10.0, (n, 3)), rng.normal(0.0, 5.0, (n, 2))
    state = standing(n)

    def cycle(state):
        clipped = clip_command(commands, params)
        state, _ = advance(state, CYCLE, clipped, params)
        joint_angles(state, clipped, params, gyros, tilts)
        return state

    for _ in range(20):
        state = cycle(state)
    t0 = time.perf_counter()
    for _ in range(cycles):
        state = cycle(state)
    return (time.perf_counter() - t0) / cycles / n * 1e6


def main() -> None:
    print(f"1 robot:   {one_robot():8.2f} us per cycle (sense + joint_targets + moved)")
    print(f"64 robots: {many_robots():8.2f} us per robot per cycle (clip_command + advance + joint_angles)")


if __name__ == "__main__":
    main()
