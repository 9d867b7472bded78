"""Raw speed of the stub's physics core: World.step() plus reading every sensor of every robot.

Prints steps per second and the multiple of real time (one step = 0.02 s simulated) for:
one standing NAO, one NAO walking the real calibration gait (the controller's own time is left
out), and 11 and 22 NAOs standing spread over the field. Run: ``python -m bench.bench_physics``.
"""

from __future__ import annotations

import time

from protocol.nao import CYCLE
from server_stub.physics import calibration_walk
from server_stub.physics.robot import Robot
from server_stub.physics.world import World


def read_all(robot: Robot) -> None:
    """Everything the server sends each cycle (vision poses every third cycle are left out)."""
    robot.joint_angles()
    robot.gyro()
    robot.accelerometer()
    robot.foot_pressure()
    robot.torso_position()


def timed_steps(world: World, steps: int) -> float:
    start = time.perf_counter()
    for _ in range(steps):
        world.step()
        for robot in world.robots:
            read_all(robot)
    return time.perf_counter() - start


def standing(count: int, steps: int) -> float:
    with World() as world:
        for i in range(count):
            robot = world.add_robot()
            robot.beam(-13.0 + 2.5 * (i % 11), -6.0 + 6.0 * (i // 11), 0.0)
        for _ in range(50):  # land and settle before timing
            world.step()
        return timed_steps(world, steps) / steps


def walking() -> float:
    """Seconds per step of physics + sensors while the calibration gait walks (15 s)."""
    with World() as world:
        robot = world.add_robot()
        robot.beam(*calibration_walk.BEAM)
        for _ in range(25):
            world.step()
        physics = 0.0
        for cycle in range(calibration_walk.WALK_CYCLES):
            angles = {n: round(a, 2) for n, a in robot.joint_angles().items()}
            for effector, v in calibration_walk.velocities(cycle * CYCLE, angles).items():
                robot.command(effector, v)
            start = time.perf_counter()
            world.step()
            read_all(robot)
            physics += time.perf_counter() - start
        return physics / calibration_walk.WALK_CYCLES


def report(label: str, seconds_per_step: float) -> None:
    print(
        f"{label:28s} {1.0 / seconds_per_step:9.0f} steps/s  {CYCLE / seconds_per_step:7.1f}x real time"
        f"  ({seconds_per_step * 1e3:.3f} ms/step)"
    )


def main() -> None:
    report("1 NAO standing", standing(1, 3000))
    report("1 NAO calibration walk", walking())
    report("11 NAOs standing", standing(11, 500))
    report("22 NAOs standing", standing(22, 300))


if __name__ == "__main__":
    main()
