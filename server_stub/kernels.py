"""Every compiled kernel of the stand-in, compiled (or loaded from numba's disk cache) at once, in
two processes when the cache is cold.

numba compiles a kernel when it is first called, and keeps it in its disk cache. A server calls
``warm_up`` before it accepts agents, so that no agent's cycle stalls on a compile (a real-time
server would miss its pace); the optimizer's in-process episodes call it for the kernels a walk
takes (``WALK``) before their first episode. On a fresh clone, compiling is most of a first run's
time (``bench/bench_cold_start.py``), and it is one core's work: so a helper process
(``python -m server_stub.kernels PART...``) compiles the other parts into the cache while this
process compiles a robot's step, then this process loads them. The solver's and integrator's
kernels, which both halves call, would be compiled in both: the helper compiles them first, from
the one a robot's step calls last, while this process meets them from the first; each loads what
the other has put in the cache, and they meet in the middle.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numba import types

from server_stub.physics import (
    collision,
    gauss_seidel,
    integrate,
    island_step,
    lanes,
    motors,
    robot_step,
    rotations,
    rows,
    solver,
)
from server_stub.sensors import number_text, vision


def _sensors() -> None:
    rotations.warm_up()
    vision.warm_up()
    number_text.warm_up()


def _field() -> None:
    """The check that skips Bullet's collision pass, on one robot's body and the ball, with the
    argument types ``stepper.Stepper`` gives it (no world made: a world's step is the physics')."""
    lo = np.zeros((1, 3))
    collision.far_apart(np.zeros((1, 3)), np.zeros(1, dtype=np.int64), 1, np.ones(3), 0.25, 0.3, lo, lo + 1.0)


#: Argument types by short name: float64 (f) or int64 (i) scalars and C arrays of 1-3 dimensions,
#: a bool (b), and a factored forest (tree).
_TYPES: dict[str, types.Type] = {
    "f": types.float64,
    "i": types.int64,
    "b": types.boolean,
    "f1": types.float64[::1],
    "f2": types.float64[:, ::1],
    "f3": types.float64[:, :, ::1],
    "i1": types.int64[::1],
    "i2": types.int64[:, ::1],
}
#: The factored forest ``solver.tree_solve`` takes (``solver.factor``'s tree and inverted blocks).
_TYPES["tree"] = types.Tuple(tuple(_TYPES[name] for name in "i1 i1 i1 i1 f3 f3 f3 f3 f3 f3".split()))
#: The kernels both a robot's step and an island's call, with the argument types they call them
#: with (``tests/test_kernels.py`` checks them), in the order a robot's step first calls them (the
#: solver's with ``hinged`` either way: one compiled version for both), so that the helper process
#: compiles those while this one compiles a robot's step.
SHARED: tuple[tuple[Callable[[], Any], str], ...] = (
    (lambda: integrate.body_terms, "f1 f2 f2 f2 f1 f1 f1 f2 f2 f b"),
    (lambda: rows.hinge_nodes, "i1 i1 i f3 f2 f2 f2 f2 f1 f2 f f"),
    (lambda: rows.contact_nodes, "i i1 f2 f2 f2"),
    (lambda: integrate.free_velocities, "f2 f2 f2 f1 f3 f"),
    (lambda: solver.factor, "i1 i1 i1 i1 f3 f3 f3 f3 f1 f b"),
    (lambda: solver.unbounded_rhs, "i1 i1 i1 f3 f3 f3 f2 f2 b"),
    (lambda: rows.bounded_rows, "i f1 f1 f1 f"),
    (lambda: solver.tree_solve, "i i tree f2 f2 f2 b"),
    (lambda: solver.schur_complement, "i1 i1 f3 f3 f3 f3 i2 i1 f3 f1 b"),
    (lambda: solver.box_qp, "f2 f1 f1 f1 i1"),
    (lambda: integrate.advance, "f2 f2 f2 f"),
    (lambda: solver.contact_forces, "f1 i f2"),
)


def shared_signature(spec: str) -> tuple[types.Type, ...]:
    """The numba argument types a ``SHARED`` entry's spec names."""
    return tuple(_TYPES[name] for name in spec.split())


def _shared_backwards() -> None:
    """Compile (or load) the shared kernels from the one a robot's step calls last, by their
    signatures: nothing is run."""
    for kernel, spec in reversed(SHARED):
        kernel().compile(shared_signature(spec))


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
    "shared": _shared_backwards,
}
#: The parts an in-process walk takes (``optimizer.episode.inprocess``).
WALK: tuple[str, ...] = ("robot", "island", "motors", "field")
#: The parts a server takes: all (the shared kernels are a robot's and an island's).
SERVER: tuple[str, ...] = tuple(name for name in PARTS if name != "shared")
#: With two processes, the parts compiled here while a helper compiles the others (the shared
#: kernels first, then the island's): the halves of a walk's compile then take about as long.
_HERE: tuple[str, ...] = ("robot", "motors", "field")
#: One kernel of each part: a part whose kernel numba's cache holds is taken as compiled.
_PROBES: dict[str, Callable[[], Any]] = {
    "robot": lambda: lanes.step_lanes,
    "island": lambda: solver.schur_of_rows,
    "motors": lambda: motors.motor_step,
    "large_islands": lambda: gauss_seidel.block_gauss_seidel,
    "sensors": lambda: number_text.format_rows,
    "field": lambda: collision.far_apart,
    "shared": lambda: solver.contact_forces,
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
    process. With two, when a part is not in the cache, a helper process compiles the parts not
    in ``_HERE`` (after the shared kernels, when both a robot and an island are asked for) while
    this one compiles those in it; this one then loads the helper's from the cache (or compiles
    them, if the helper failed). Not ``eager`` (an in-process walk, which may wait for a
    load): nothing is done when every part is in the cache, each kernel is loaded when first
    called; a server is eager, so that no agent's cycle waits."""
    unknown = [name for name in parts if name not in PARTS]
    if unknown:
        raise ValueError(f"unknown kernel parts {unknown}; known: {sorted(PARTS)}")
    cached = all(_cached(name) for name in parts)
    if cached and not eager:
        return
    here = [name for name in parts if name in _HERE]
    delegated = [name for name in parts if name not in _HERE]
    if processes > 1 and delegated and not cached:
        first = ["shared"] if "robot" in parts and "island" in parts else []
        helper = subprocess.Popen(
            [sys.executable, "-m", "server_stub.kernels", *first, *delegated],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for name in here:
            PARTS[name]()
        helper.wait()
        parts = delegated
    for name in parts:
        PARTS[name]()


if __name__ == "__main__":
    warm_up(sys.argv[1:], processes=1)
