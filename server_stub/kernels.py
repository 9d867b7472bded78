"""Every compiled kernel of the stand-in, compiled (or loaded from numba's disk cache) at once.

numba compiles a kernel when it is first called. A server calls ``warm_up`` before it accepts
agents, so that no agent's cycle stalls on a compile (a real-time server would miss its pace);
an in-process episode (the optimizer's direct path) does not, and compiles only the kernels it
uses, when it first uses them: on a fresh clone its first episode pays for less.
"""

from __future__ import annotations

from server_stub.physics import island_step, motors, robot_step, rotations
from server_stub.physics.world import World
from server_stub.sensors import number_text, vision


def warm_up() -> None:
    """Compile every kernel the server may call: the step's (a robot alone and an island), the
    motor rule, the monitor's poses, vision and the number formatting of perceptions."""
    robot_step.warm_up()
    island_step.warm_up()
    rotations.warm_up()
    motors.warm_up()
    vision.warm_up()
    number_text.warm_up()
    with World() as world:  # the check that skips Bullet's collision pass
        world.step()
