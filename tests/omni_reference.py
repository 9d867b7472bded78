"""A frozen record of the omni walker's outputs (``tests/data/omni_reference.npz``), and the
inputs it was made from: 30 genes in the box, each walked 300 control cycles with changing
commands (stops and starts among them), clock jitter (repeated, late, backward and over-long
cycles), gyro and accelerometer readings (some missing).

The record was written by the numpy implementation of commit 7d68050 (``python -m
tests.omni_reference``) before the per-cycle math was compiled; ``tests/test_omni_reference.py``
checks that the walker still reproduces it. Writing it again records the code as it is now.

The record has the 19 genes of its time; those added since (``lag_comp``, the calibration) are
walked at the values a gait file of that time loads with (``gait.gait_file.ADDED_GENES``:
``walked``), which leave the walk as it was.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gait import OMNI, Command
from gait.gait_file import ADDED_GENES
from gait.omni import EFFECTORS, OmniWalker
from protocol.nao import JOINTS

PATH = Path(__file__).resolve().parent / "data" / "omni_reference.npz"
LIMITS = {j.effector: (j.min_deg, j.max_deg) for j in JOINTS}
GENES, CYCLES, EVERY = 30, 300, 5  # all targets every EVERY-th cycle, a weighted sum every cycle
#: The genes recorded: the omni family's first 19 (``lag_comp`` and the calibration came after).
RECORDED = 19


def walked(genes: np.ndarray) -> np.ndarray:
    """The recorded genes (GENES, 19) as walked now: the genes added since appended, each at
    the value an old file loads with."""
    added = [ADDED_GENES[OMNI.name][name] for name in OMNI.gene_names[RECORDED:]]
    return np.concatenate([genes, np.tile(added, (len(genes), 1))], axis=1)


def inputs(seed: int = 2026) -> dict[str, Any]:
    """The genes (GENES, RECORDED) and, per gene and cycle, the time, command, gyro and accelerometer
    reading (NaN rows: nothing sensed)."""
    rng = np.random.default_rng(seed)
    low, high = OMNI.bounds[:RECORDED, 0], OMNI.bounds[:RECORDED, 1]
    genes = low + rng.random((GENES, len(low))) * (high - low)
    steps = rng.choice([0.02, 0.0, 0.04, -0.01, 0.6], p=[0.85, 0.04, 0.06, 0.02, 0.03], size=(GENES, CYCLES))
    times = 0.04 + np.cumsum(steps, axis=1)
    tops = np.stack([genes[:, 8], genes[:, 10], genes[:, 11]], axis=-1)
    commands = np.empty((GENES, CYCLES, 3))
    for g in range(GENES):
        k = 0
        while k < CYCLES:
            length = int(rng.integers(10, 80))
            kind = rng.integers(5)
            if kind == 0:
                command = np.zeros(3)  # stop
            elif kind == 1:
                command = np.zeros(3)
                axis = rng.integers(3)
                command[axis] = rng.choice([-1.0, 1.0]) * rng.uniform(0.2, 1.3) * tops[g, axis]
            else:  # any mix, sometimes outside the top speeds' ellipsoid
                command = rng.uniform(-1.5, 1.5, 3) * tops[g]
            commands[g, k : k + length] = command
            k += length
    gyros = rng.normal(0.0, 40.0, (GENES, CYCLES, 3))
    gyros[rng.random((GENES, CYCLES)) < 0.1] = np.nan
    lean = np.radians(rng.normal(0.0, 15.0, (GENES, CYCLES, 2)))
    accs = 9.81 * np.stack(
        [-np.sin(lean[..., 1]), -np.sin(lean[..., 0]), np.cos(lean[..., 0]) * np.cos(lean[..., 1])], axis=-1
    )
    accs += rng.normal(0.0, 1.0, accs.shape)
    missing = rng.random((GENES, CYCLES))
    accs[missing < 0.05] = np.nan
    accs[(missing >= 0.05) & (missing < 0.08)] = 0.0
    weights = rng.normal(0.0, 1.0, len(EFFECTORS))
    return {"genes": genes, "times": times, "commands": commands, "gyros": gyros, "accs": accs, "weights": weights}


def run(data: dict[str, Any]) -> dict[str, np.ndarray]:
    """Each gene's walker through its inputs: the targets (EFFECTORS order) of every EVERY-th
    cycle, a weighted sum of every cycle's, the odometry collected every EVERY-th cycle and
    whether it stood."""
    genes = walked(data["genes"])
    targets = np.empty((GENES, CYCLES // EVERY, len(EFFECTORS)))
    sums = np.empty((GENES, CYCLES))
    moved = np.empty((GENES, CYCLES // EVERY, 3))
    stood = np.empty((GENES, CYCLES), dtype=bool)
    for g in range(GENES):
        walker = OMNI.gait(genes[g]).walker()
        assert isinstance(walker, OmniWalker)
        for k in range(CYCLES):
            walker.command = Command(*data["commands"][g, k])
            gyro, acc = data["gyros"][g, k], data["accs"][g, k]
            walker.sense(None if np.isnan(gyro[0]) else tuple(gyro), None if np.isnan(acc[0]) else tuple(acc), {})
            out = walker.joint_targets(float(data["times"][g, k]), LIMITS)
            row = np.array([out[name] for name in EFFECTORS])
            sums[g, k] = row @ data["weights"]
            stood[g, k] = walker.standing
            if k % EVERY == EVERY - 1:
                targets[g, k // EVERY] = row
                moved[g, k // EVERY] = walker.moved()
    return {"targets": targets, "sums": sums, "moved": moved, "stood": stood}


if __name__ == "__main__":
    data = inputs()
    record = {"genes": data["genes"], "first_times": data["times"][:, :5], **run(data)}
    np.savez_compressed(PATH, **record)
    print(PATH, PATH.stat().st_size, "bytes")
