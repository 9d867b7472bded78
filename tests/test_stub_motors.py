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
torques_st = st.lists(st.floats(-10.0, 10.0), min_size=N, max_size=N)
due_st = st.lists(st.one_of(st.just(math.nan), st.floats(-6.0, 6.0)), min_size=N, max_size=N)


@settings(max_examples=300, deadline=None)
@given(
    angles_st, speeds_st, torques_st, due_st, speeds_st, st.booleans(), st.lists(st.booleans(), min_size=N, max_size=N)
)
def test_each_joint_follows_the_servers_rule(angles, rates, torques, due, motor, first, stopped_before):
    angles, rates, torques, due = map(np.array, (angles, rates, torques, due))
    motor_before = np.array(motor)
    motor_now = motor_before.copy()
    last_target = np.zeros(0) if first else np.zeros(N)
    last_force = np.zeros(0) if first else np.where(stopped_before, STOP, LIMIT)
    target, force, yielding, load, changed = motor_step(
        angles, rates, torques, LOWER, UPPER, due, motor_now, last_target, last_force, LIMIT, ERP, BOUNCE, CYCLE, STOP
    )
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
        # only a motor (not a stop) of the last step yields, at 99% of its torque limit
        was_motor = not first and not stopped_before[i]
        assert yielding[i] == (was_motor and abs(torques[i]) >= 0.99 * LIMIT)
        assert load[i] == (torques[i] if was_motor else 0.0)
    if not first:
        assert changed == (not (np.array_equal(target, last_target) and np.array_equal(force, last_force)))
    else:
        assert changed


def test_an_unchanged_command_set_is_not_sent_again():
    angles = np.zeros(N) + 0.01
    motor = np.full(N, 0.5)
    args = (angles, np.zeros(N), np.zeros(N), LOWER, UPPER, np.full(N, np.nan), motor)
    target, force, _, _, changed = motor_step(*args, np.zeros(0), np.zeros(0), LIMIT, ERP, BOUNCE, CYCLE, STOP)
    assert changed
    *_, again = motor_step(*args, target, force, LIMIT, ERP, BOUNCE, CYCLE, STOP)
    assert not again
