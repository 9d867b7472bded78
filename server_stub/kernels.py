"""Every compiled kernel of the stand-in, compiled (or loaded from numba's disk cache) at once, in
two processes when the cache is cold.

numba compiles a kernel when it is first called, and keeps it in its disk cache. A server calls
``warm_up`` before it accepts agents, so that no agent's cycle stalls on a compile (a real-time
server would miss its pace); the optimizer's in-process episodes call it for the kernels a walk
takes (``WALK``) before their first episode. On a fresh clone, compiling is most of a first run's
time (``bench/bench_cold_start.py``), and it is one core's work: so a helper process
(``python -m server_stub.kernels PART...``) compiles the other parts into the cache while this
process compiles a robot's step, then this process loads them. The solver's kernels, which both
halves need, are compiled in both; the halves take about as long.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from server_stub.physics import (
    collision,
    gauss_seidel,
    island_step,
    motors,
    robot_step,
    rotations,
    solver,
    tree_step,
)
from server_stub.sensors import number_text, vision


def _sensors() -> None:
    rotations.warm_up()
    vision.warm_up()
    number_text.warm_up()


def _field() -> None:
    """The check that skips Bullet's collision pass, on one robot's body and the ball, with the
    argument types ``driver.Stepper`` gives it (no world made: a world's step is the physics')."""
    lo = np.zeros((1, 3))
    collision.far_apart(np.zeros((1, 3)), np.zeros(1, dtype=np.int64), 1, np.ones(3), 0.25, 0.3, lo, lo + 1.0)


#: What each part compiles: a robot's step against the ground (its kinematics and colliders too),
#: a small island's (a lone ball's, on every walk), the motor rule, the large islands' solvers,
#: the monitor's poses with vision and the numbers of perceptions, and the field's collision
#: check.
PARTS: dict[str, Callable[[], None]] = {
    "robot": robot_step.warm_up,
    "island": island_step.warm_up,
    "motors": motors.warm_up,
    "large_islands": island_step.warm_up_large,
    "sensors": _sensors,
    "field": _field,
}
#: The parts an in-process walk takes (``optimizer.episode.direct``).
WALK: tuple[str, ...] = ("robot", "island", "motors", "field")
#: The parts a server takes: all.
SERVER: tuple[str, ...] = tuple(PARTS)
#: With two processes, the part compiled here while a helper compiles the others: the two halves
#: of a walk's compile take about as long, though the solver's kernels are in both.
_HERE = "robot"
#: One kernel of each part: a part whose kernel numba's cache holds is taken as compiled.
_PROBES: dict[str, Callable[[], Any]] = {
    "robot": lambda: tree_step.step_tree,
    "island": lambda: solver.schur_of_rows,
    "motors": lambda: motors.motor_step,
    "large_islands": lambda: gauss_seidel.block_gauss_seidel,
    "sensors": lambda: number_text.format_rows,
    "field": lambda: collision.far_apart,
}


def _cached(part: str) -> bool:
    """Whether numba's disk cache holds ``part``'s probe kernel for this source (numba's own
    index, stale entries dropped); any doubt counts as not cached."""
    try:
        return bool(_PROBES[part]()._cache._cache_file._load_index())
    except Exception:  # an internal of numba's that moved: compile in two processes
        return False


def warm_up(parts: Sequence[str] = SERVER, processes: int = 2, eager: bool = True) -> None:
    """Compile (or load) the kernels of ``parts`` (names in ``PARTS``), in that order with one
    process. With two, when a part is not in the cache, a helper process compiles all parts but
    ``_HERE`` while this one compiles that; this one then loads the helper's from the cache (or
    compiles them, if the helper failed). Not ``eager`` (an in-process walk, which may wait for a
    load): nothing is done when every part is in the cache, each kernel is loaded when first
    called; a server is eager, so that no agent's cycle waits."""
    unknown = [name for name in parts if name not in PARTS]
    if unknown:
        raise ValueError(f"unknown kernel parts {unknown}; known: {sorted(PARTS)}")
    cached = all(_cached(name) for name in parts)
    if cached and not eager:
        return
    delegated = [name for name in parts if name != _HERE]
    if processes > 1 and delegated and not cached:
        helper = subprocess.Popen(
            [sys.executable, "-m", "server_stub.kernels", *delegated],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        if _HERE in parts:
            PARTS[_HERE]()
        helper.wait()
        parts = delegated
    for name in parts:
        PARTS[name]()


if __name__ == "__main__":
    warm_up(sys.argv[1:], processes=1)
