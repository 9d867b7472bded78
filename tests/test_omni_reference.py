"""The omni walker reproduces its frozen record (``tests/omni_reference.py``): the numpy
implementation's targets, odometry and standing, for 30 genes x 300 cycles of changing commands,
clocks and sensors, to 1e-9 deg (and m); its 19 genes walked with the genes added since at the
values old files load with, which must leave the walk as it was."""

from __future__ import annotations

import numpy as np

from gait.nao_legs import LIMIT_MARGIN_DEG
from gait.omni import EFFECTORS, TILT_SMOOTHING, joint_angles, tilt
from gait.omni_steps import OmniParams, advance, clip_command, standing
from tests.omni_reference import CYCLES, EVERY, GENES, LIMITS, PATH, inputs, run, walked


def test_the_walker_reproduces_the_frozen_record() -> None:
    frozen = np.load(PATH)
    data = inputs()
    # the same inputs as recorded (a changed random stream would fail here, not below)
    assert np.array_equal(data["genes"], frozen["genes"]) and np.array_equal(
        data["times"][:, :5], frozen["first_times"]
    )
    now = run(data)
    assert np.array_equal(now["stood"], frozen["stood"])
    for name in ("targets", "sums", "moved"):
        assert np.allclose(now[name], frozen[name], rtol=0.0, atol=1e-9), name


def test_the_robots_stepped_as_rows_reproduce_the_frozen_record() -> None:
    """The robot axis: the 30 genes as 30 rows of one batch (``clip_command``, ``advance``,
    ``joint_angles`` with one gene array per field), each row fed as its walker was (its clock,
    command, gyro and smoothed tilt), give the recorded targets and standing."""
    frozen = np.load(PATH)
    data = inputs()
    genes = walked(data["genes"])
    p = OmniParams(*genes.T)
    low, high = (np.array([LIMITS[name][k] for name in EFFECTORS]) + (1 - 2 * k) * LIMIT_MARGIN_DEG for k in (0, 1))
    state = standing(GENES)
    last = data["times"][:, 0].copy()
    gyro = np.zeros((GENES, 3))
    tilted = np.stack([genes[:, 4], np.zeros(GENES)], axis=-1)
    for k in range(CYCLES):
        t = data["times"][:, k]
        dt = np.minimum(np.maximum(t - last, 0.0), 0.99 * genes[:, 0]) if k else np.zeros(GENES)
        last = np.maximum(t, last)
        felt = ~np.isnan(data["gyros"][:, k, 0])
        gyro[felt] = data["gyros"][felt, k]
        acc = data["accs"][:, k]
        felt = ~np.isnan(acc[:, 0]) & np.any(acc != 0.0, axis=-1)
        tilted[felt] += TILT_SMOOTHING * (tilt(acc[felt]) - tilted[felt])
        command = clip_command(data["commands"][:, k], p)
        state, _ = advance(state, dt, command, p)
        angles = np.minimum(np.maximum(joint_angles(state, command, p, gyro, tilted), low), high)
        assert np.array_equal(~state.walking, frozen["stood"][:, k])
        assert np.allclose(angles @ data["weights"], frozen["sums"][:, k], rtol=0.0, atol=1e-9)
        if k % EVERY == EVERY - 1:
            assert np.allclose(angles, frozen["targets"][:, k // EVERY], rtol=0.0, atol=1e-9)
