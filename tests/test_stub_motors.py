"""The compiled motor rule (server_stub.physics.motors) joint by joint, on any state."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from server_stub.physics.motors import motor_step

LIMIT, ERP, BOUNCE, CYCLE, STOP = 10.0, 0.8, 1.0, 0.02, 1e4
N = 6
LOWER = np.radians([-120.0, -45.0, -90.0, 0.0, -130.0, -25.0])
UPPER = np.radians([120.0, 45.0, 90.0, 130.0, 0.0, 45.0])

angles_st = st.lists(st.floats(-2.6, 2.6), min_size=N, max_size=N)
speeds_st = st.lists(st.floats(-7.0, 7.0), min_size=N, max_size=N)
due_st = st.lists(st.one_of(st.just(math.nan), st.floats(-6.0, 6.0)), min_size=N, max_size=N)


@settings(max_examples=300, deadline=None)
@given(angles_st, speeds_st, due_st, speeds_st)
def test_each_joint_follows_the_servers_rule(angles, rates, due, motor):
    angles, rates, due = map(np.array, (angles, rates, due))
    motor_before = np.array(motor)
    motor_now = motor_before.copy()
    target, force = motor_step(angles, rates, LOWER, UPPER, due, motor_now, LIMIT, ERP, BOUNCE, CYCLE, STOP)
    for i in range(N):
        inside = LOWER[i] < angles[i] < UPPER[i]
        # a command reaches the sticky motor only while the joint is strictly inside its range
        expected_motor = due[i] if inside and not math.isnan(due[i]) else motor_before[i]
        assert motor_now[i] == expected_motor
        if inside:
            assert (target[i], force[i]) == (expected_motor, LIMIT)
        else:  # the stop drives it back towards the range with a force that always wins
            assert force[i] == STOP
            below = angles[i] <= LOWER[i]
            correction = ERP * ((LOWER[i] - angles[i]) if below else (angles[i] - UPPER[i])) / CYCLE
            bounce = BOUNCE * max((-rates[i]) if below else rates[i], 0.0)
            assert target[i] == pytest.approx((1.0 if below else -1.0) * max(correction, bounce), abs=1e-12)
