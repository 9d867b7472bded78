"""State hashes of the stand-in's physics: proof that a change to the physics code changes no result.

Each scenario drives the physics through its public interfaces (``World``, ``Robot``, the
optimizer's embedded episodes) and folds the state after every step into a SHA-256: every robot's
torso position and rotation, joint angles, gyro, accelerometer, foot pressure and contact points
(with their solved forces), the ball's position, and each episode's score. Equal hashes before
and after a redesign mean the same numbers, bit for bit, at every step.

    python -m bench.physics_hashes --write bench/physics_hashes.json   # record (before a change)
    python -m bench.physics_hashes --check bench/physics_hashes.json   # compare (after it)
    python -m bench.physics_hashes --only walker,ball                  # some scenarios
    python -m bench.physics_hashes --without-ball --write F            # robots and scores only

Scenarios: the shipped walker, the fast gait (``gait/walks/fastest.json``), the ball (rolled,
bounced off a post, walked into), two robots (beamed into each other, walking into each other),
four robots flailing in a heap, a robot in a goal's side box and one walking into a border wall,
six robots in a pile, the calibration walk, and the 50 gaits of the fidelity sets plus the
shipped gait, each from two starts. The hashes depend on the machine's floating-point
(numba compiles for the CPU it runs on): compare on one machine.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import struct
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from bench.fidelity import gait_set
from gait import load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner
from protocol.nao import JOINTS
from server_stub.physics import calibration_walk
from server_stub.physics.world import World

ROOT = Path(__file__).resolve().parents[1]

#: Two starts of the fidelity walks: the default one and one moved and turned.
SHIPPED = ROOT / "gait" / "default_gait.json"
STARTS = ((-10.0, 0.0, 0.0), (-8.0, 3.0, 20.0))


class Digest:
    """A SHA-256 of floats, fed the world's state after each step."""

    def __init__(self, ball: bool = True) -> None:
        self._hash = hashlib.sha256()
        self.steps = 0
        self.ball = ball

    def floats(self, values) -> None:
        array = np.asarray(values, dtype=np.float64).ravel()
        self._hash.update(struct.pack(f"<{array.size}d", *array.tolist()))

    def world(self, world: World) -> None:
        self.steps += 1
        for robot in world.robots:
            self.floats(robot.torso_position())
            self.floats(robot.torso_rotation())
            self.floats(robot.joint_degrees())
            self.floats(robot.gyro())
            self.floats(robot.accelerometer())
            for foot, (centre, force) in sorted(robot.foot_pressure().items()):
                self._hash.update(foot.encode())
                self.floats(centre)
                self.floats(force)
            for point in robot.contact_points():
                self.floats([point[2], point[3], point[4], *point[5], *point[6], *point[7], *point[8:11], *point[11]])
                self.floats([point[12], *point[13]])
        if self.ball:
            self.floats(world.ball_position())

    def hexdigest(self) -> str:
        return self._hash.hexdigest()


@contextmanager
def watched(digest: Digest) -> Iterator[None]:
    """Every ``World.step`` in this block feeds ``digest`` (the embedded episodes' worlds too)."""
    step = World.step

    def hooked(self: World) -> None:
        step(self)
        digest.world(self)

    World.step = hooked  # type: ignore[method-assign]
    try:
        yield
    finally:
        World.step = step  # type: ignore[method-assign]


def _walk(robot, cycles: int, world: World, start: int = 0) -> None:
    for cycle in range(start, start + cycles):
        calibration_walk._act(robot, cycle * 0.02)
        world.step()


def _episodes(digest: Digest, walks: list[tuple[object, tuple[float, float, float]]]) -> None:
    with EpisodeRunner(EpisodeConfig(family="tfs")) as runner:
        for gait, start in walks:
            result = runner.evaluate(gait, start=start)
            digest.floats([result.distance, float(result.fell), result.time, result.fitness])


def walker(digest: Digest) -> None:
    """The shipped TFS gait, one embedded episode from the default start."""
    _episodes(digest, [(load_gait(SHIPPED), STARTS[0])])


def fast_gait(digest: Digest) -> None:
    """The committed fast walk (tfs-plus), one embedded episode."""
    gait = load_gait(ROOT / "gait" / "walks" / "fastest.json")
    with EpisodeRunner(EpisodeConfig(family=gait.family.name)) as runner:
        result = runner.evaluate(gait, start=STARTS[0])
        digest.floats([result.distance, float(result.fell), result.time, result.fitness])


def ball(digest: Digest) -> None:
    """The ball rolled, thrown into a goal's side box, and walked into by a robot."""
    with World() as world:
        world.set_ball((0.0, 0.0, 0.042), (2.0, 0.0, 0.0))
        for _ in range(40):
            world.step()
        world.set_ball((14.5, 1.07, 0.042), (4.0, 0.0, 0.0))
        for _ in range(40):
            world.step()
        robot = world.add_robot()
        world.step()
        robot.beam(-3.0, 0.0, 0.0)
        for _ in range(20):
            world.step()
        foot = robot.part_positions(["rfoot"])["rfoot"]
        world.set_ball((foot[0] + 0.25, foot[1], 0.042))
        _walk(robot, 300, world)
        chest = robot.torso_position()
        world.set_ball((chest[0] + 0.3, chest[1], chest[2] + 0.05), (-3.0, 0.0, 0.0))
        for _ in range(30):
            world.step()


def two_robots(digest: Digest) -> None:
    """Beamed 0.25 m apart face to face, then walking into each other from 0.6 m."""
    for gap, cycles in ((0.25, 60), (0.6, 300)):
        with World() as world:
            a, b = world.add_robot(), world.add_robot()
            a.beam(-gap / 2, 0.0, 0.0)
            b.beam(gap / 2, 0.0, 180.0)
            for cycle in range(cycles):
                calibration_walk._act(a, cycle * 0.02)
                calibration_walk._act(b, cycle * 0.02)
                world.step()


def _random_speeds(robots, rng: np.random.Generator) -> None:
    """Every hinge of every robot told a random speed (3 rad/s spread): a robot flailing."""
    for robot in robots:
        for joint, speed in zip(JOINTS, rng.normal(size=22) * 3.0):
            robot.command(joint.effector, float(speed))


def heap(digest: Digest) -> None:
    """Four robots beamed 0.3 m apart around the ball, random motor speeds: a tangle."""
    rng = np.random.default_rng(5)
    with World() as world:
        robots = [world.add_robot() for _ in range(4)]
        for robot, (x, y, heading) in zip(
            robots, ((-0.15, -0.15, 0), (0.15, -0.15, 90), (0.15, 0.15, 180), (-0.15, 0.15, 270))
        ):
            robot.beam(x, y, heading)
        world.set_ball((0.0, 0.0, 0.042))
        for step in range(120):
            if step % 10 == 0:
                _random_speeds(robots, rng)
            world.step()


def goal(digest: Digest) -> None:
    """A robot beamed with its chest into the right goal's side box, flailing, and another
    walking into the border wall (0.5 m thick, its face at x -24.49): a robot's contacts with the
    field's boxes."""
    rng = np.random.default_rng(7)
    with World() as world:
        post, wall = world.add_robot(), world.add_robot()
        world.step()
        post.beam(15.0 - 0.03, 1.07, 0.0)
        wall.beam(-24.35, 3.0, 180.0)
        for step in range(150):
            if step % 10 == 0:
                _random_speeds([post], rng)
            calibration_walk._act(wall, step * 0.02)
            world.step()


def pile(digest: Digest) -> None:
    """Six robots beamed onto one spot around the ball, random motor speeds (``bench_pile.py``'s
    pile): islands large enough for the block Gauss-Seidel solve."""
    rng = np.random.default_rng(1)
    with World() as world:
        robots = [world.add_robot() for _ in range(6)]
        for k, robot in enumerate(robots):
            angle = 2.0 * np.pi * k / 6
            robot.beam(0.15 * np.cos(angle), 0.15 * np.sin(angle), float(np.degrees(angle)) + 180.0)
        world.set_ball((0.0, 0.0, 0.042))
        for step in range(60):
            if step % 10 == 0:
                _random_speeds(robots, rng)
            world.step()


def calibration(digest: Digest) -> None:
    """The real-server calibration walk, replayed."""
    with World() as world:
        result = calibration_walk.run(world)
    digest.floats([result.dx, result.dy, float(result.fell)])


def gait_sets(digest: Digest) -> None:
    """The 50 gaits of the fidelity sets and the shipped gait, from two starts each."""
    gaits = [g.gait for g in gait_set("all")] + [load_gait(SHIPPED)]
    _episodes(digest, [(gait, start) for gait in gaits for start in STARTS])


SCENARIOS: dict[str, Callable[[Digest], None]] = {
    "walker": walker,
    "fast_gait": fast_gait,
    "ball": ball,
    "two_robots": two_robots,
    "heap": heap,
    "goal": goal,
    "pile": pile,
    "calibration": calibration,
    "gait_sets": gait_sets,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.physics_hashes", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--write", type=Path, help="record the hashes in this JSON file")
    parser.add_argument("--check", type=Path, help="compare with the hashes in this JSON file; exit 1 on a difference")
    parser.add_argument("--only", default="", help="comma-separated scenarios (default: all)")
    parser.add_argument(
        "--without-ball",
        action="store_true",
        help="leave the ball's position out of the hashes: to show that a change which moves only the "
        "ball (where a trainer parks it) leaves every robot's step and every score as it was",
    )
    args = parser.parse_args(argv)
    names = [n for n in args.only.split(",") if n] or list(SCENARIOS)
    unknown = sorted(set(names) - set(SCENARIOS))
    if unknown:
        parser.error(f"unknown scenario(s) {', '.join(unknown)}: choose from {', '.join(SCENARIOS)}")
    hashes = {}
    for name in names:
        digest = Digest(ball=not args.without_ball)
        started = time.monotonic()
        with watched(digest):
            SCENARIOS[name](digest)
        hashes[name] = digest.hexdigest()
        print(f"{name:12s} {digest.steps:7d} steps {time.monotonic() - started:7.1f} s  {hashes[name]}", flush=True)
    if args.write:
        args.write.write_text(json.dumps(hashes, indent=2) + "\n")
    if args.check:
        recorded = json.loads(args.check.read_text())
        differ = [n for n in names if recorded.get(n) != hashes[n]]
        print("all equal" if not differ else f"DIFFERENT: {', '.join(differ)}")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
