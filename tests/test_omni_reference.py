"""The omni walker reproduces its frozen record (``tests/omni_reference.py``): the numpy
implementation's targets, odometry and standing, for 30 genes x 300 cycles of changing commands,
clocks and sensors, to 1e-9 deg (and m)."""

from __future__ import annotations

import numpy as np

from tests.omni_reference import PATH, inputs, run


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
