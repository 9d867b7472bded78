"""The server's motor rule for one step (docs/robot_and_server.md section 3), compiled.

Every cycle each robot's 22 hinges go through the same few comparisons: which commands may act
(only while the joint is strictly inside its range) and which joints a stop drives back. Written
with numpy these were a dozen calls on 22-element arrays, about 30 us a cycle in numpy's per-call
cost alone; here they are one compiled loop. ``server_stub.physics.robot`` owns the state and
calls this once per step; the step turns its targets and forces into motor rows (``rows``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def motor_step(angles, rates, lower, upper, due, motor, torque_limit, stop_erp, stop_bounce, cycle, stop_force):
    """This step's (target velocities, forces) of the 22 motor rows.

    ``due`` holds the commands that act now (NaN: none for that joint); a command reaches the
    sticky ``motor`` (updated in place) only for a joint strictly inside (``lower``, ``upper``).
    A joint outside is driven back by its stop, as ODE's limit rows are: at the larger of the ERP
    correction and the bounced incoming speed, with a force that always wins
    (docs/robot_and_server.md section 3: hj1 at 100 rad/s into +120 alternates 119.5 / 126.5 deg).
    """
    n = angles.shape[0]
    target = np.empty(n)
    force = np.empty(n)
    for i in range(n):
        if lower[i] < angles[i] < upper[i]:
            if not np.isnan(due[i]):
                motor[i] = due[i]
            target[i] = motor[i]
            force[i] = torque_limit
        elif angles[i] - upper[i] >= 0.0:
            correction = stop_erp * (angles[i] - upper[i]) / cycle
            bounce = stop_bounce * max(rates[i], 0.0)
            target[i] = -(bounce if bounce > correction else correction)
            force[i] = stop_force
        elif lower[i] - angles[i] >= 0.0:
            correction = stop_erp * (lower[i] - angles[i]) / cycle
            bounce = stop_bounce * max(-rates[i], 0.0)
            target[i] = bounce if bounce > correction else correction
            force[i] = stop_force
        else:  # not a number: the motor keeps its target
            target[i] = motor[i]
            force[i] = torque_limit
    return target, force


def warm_up() -> None:
    """Compile (or load from numba's disk cache) before the first step needs it."""
    one = np.zeros(1)
    motor_step(one, one, np.full(1, -1.0), np.ones(1), np.full(1, np.nan), np.zeros(1), 10.0, 0.8, 1.0, 0.02, 1e4)
