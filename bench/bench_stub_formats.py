"""Cost of the stub's wire text: perception, vision (See) and monitor messages.

Run: ``python -m bench.bench_stub_formats`` from the repository. Prints microseconds per call.
"""

from __future__ import annotations

import math
import timeit

import numpy as np

from protocol.nao import JOINTS
from server_stub.physics import nao_model
from server_stub.physics.rotations import body_poses
from server_stub.sensors.monitor_scene import GameHeader, MonitorScene, RobotView
from server_stub.sensors.perception_text import GameStateText, format_perception
from server_stub.sensors.vision import SeenRobot, VisionSensor

_PARTS = nao_model.part_names()


def _us(fn, number: int) -> float:
    return min(timeit.repeat(fn, number=number, repeat=5)) / number * 1e6


def _robot(rng: np.random.Generator, k: int) -> RobotView:
    # turned every which way, as a walking robot's parts are: all 16 numbers of each pose vary
    quaternions = rng.normal(size=(len(_PARTS), 4))
    links = np.hstack(
        [
            (k, 0.0, 0.4) + rng.normal(0, 0.1, (len(_PARTS), 3)),
            quaternions / np.linalg.norm(quaternions, axis=1, keepdims=True),
        ]
    )
    poses = body_poses(links[0, :3], np.eye(3), links)[1:]
    return RobotView("left" if k % 2 == 0 else "right", k // 2 + 1, 0, tuple(_PARTS), poses)


def main() -> None:
    rng = np.random.default_rng(0)
    joints = {j.perceptor: float(rng.uniform(-90, 90)) for j in JOINTS}
    gs = GameStateText(0, 0, 12.34, "PlayOn")
    contact = ((0.001, -0.06, -0.01), (0.0, 14.17, 104.85))
    feet = {"lf": contact, "rf": contact}
    print(
        f"format_perception, no See, both FRP : "
        f"{_us(lambda: format_perception(552.9, gs, (1.0, 2.0, 3.0), (0.1, 0.2, 9.8), joints, feet), 20000):7.2f} us"
    )
    print(
        f"format_perception, no See, no FRP   : "
        f"{_us(lambda: format_perception(552.9, gs, (1.0, 2.0, 3.0), (0.1, 0.2, 9.8), joints, {}), 20000):7.2f} us"
    )

    a = math.radians(20.0)
    rot = np.array([[math.sin(a), math.cos(a), 0.0], [-math.cos(a), math.sin(a), 0.0], [0.0, 0.0, 1.0]])
    sensor = VisionSensor(rng, noise=True, sense_mypos=True)
    for n in (1, 22):
        robots = [
            SeenRobot(
                "T",
                k + 1,
                {
                    p: tuple(rng.uniform(-5, 5, 2)) + (0.3,)
                    for p in ("head", "rlowerarm", "llowerarm", "rfoot", "lfoot")
                },
            )
            for k in range(n)
        ]
        seen = _us(lambda robots=robots: sensor.see((-1.0, 0.0, 0.55), rot, "left", (0, 0, 0.042), robots), 500)
        print(f"VisionSensor.see, {n:2d} robot(s)        : {seen:7.2f} us")

    ball = (0, 0, 0.042)
    for n in (1, 22):
        robots = [_robot(rng, k) for k in range(n)]
        header = GameHeader(1.0, "PlayOn", team_left="A", team_right="B")
        scene = MonitorScene()
        full = _us(lambda scene=scene, header=header, robots=robots: scene.full(header, robots, ball), 200)
        print(f"MonitorScene.full, {n:2d} robot(s)       : {full:7.1f} us")
        still = _us(lambda scene=scene, header=header, robots=robots: scene.delta(header, robots, ball), 2000)
        print(f"MonitorScene.delta, {n:2d} still         : {still:7.1f} us")
        moving = [[_robot(rng, k) for k in range(n)] for _ in range(2)]
        flip = iter(range(10**9))

        def delta(scene=scene, header=header, moving=moving, flip=flip):
            return scene.delta(header, moving[next(flip) % 2], ball)

        print(f"MonitorScene.delta, {n:2d} all moving    : {_us(delta, 200):7.1f} us")


if __name__ == "__main__":
    main()
