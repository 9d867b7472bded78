"""The localization's errors and per-cycle cost (agent.localization).

Run: ``python -m bench.bench_localization`` (from the repository root); with
``RCSSSERVER3D=/opt/rcss/bin/rcss-sync`` (a server with the sync profile: mypos on, beam noise 0)
it also measures on a live real server. Errors are torso position (cm) and heading (deg),
median and worst, at every vision cycle after the first three of a scene:

- stand-in, standing, beamed at the course's poses and four more, with the server's beam noise
  (the estimator starts from the asked-for pose, up to 0.05 m and 10 deg off);
- stand-in, the course (the robot placed along it each cycle, odometry the true motion with
  10 % errors, the turn from odometry: a placed robot's gyro reads nothing);
- stand-in, the fastest gait walked from five poses (beam noise on), odometry a rough 1 m/s
  forward, and again with no odometry at all;
- the real server's recorded walks (tests/data/rcssserver3d/walk_calibration), against its
  ``mypos`` moved to the torso (``TruePose``), and that against the monitor's torso track;
- the live real server: standing at the same poses as on the stand-in (``VisionPose`` against
  ``TruePose``), the course (beamed to each cycle's pose), and the fastest gait walked from
  three of the starts (in BeforeKickOff, with no trainer: a robot that crosses the halfway line
  is moved back 2.5 m by the referee);
- the cost of ``update``: a cycle without vision, a vision cycle (the See already read), and the
  See's reading itself (the parser's, paid on first use of ``perception.vision``).
"""

from __future__ import annotations

import math
import os
import re
import socket
import struct
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from agent.behaviour import Phase, WalkBehaviour
from agent.config import AgentConfig
from agent.localization import LocalizationConfig, PoseSource, TruePose, VisionPose
from gait import Command, load_gait
from protocol.errors import ProtocolError
from protocol.perception import Perception, parse_perception
from server_stub.config import ServerConfig
from server_stub.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
WALKS = ROOT / "tests" / "data" / "rcssserver3d" / "walk_calibration"
FASTEST = ROOT / "gait" / "walks" / "fastest.json"
Pose = tuple[float, float, float]
COURSE: list[Pose] = [
    (-12, 0, 0),
    (-6, 0, 0),
    (-6, 3, 0),
    (-6, 3, 180),
    (-10, 3, 180),
    (-10, -2, 90),
    (-7, -2, 90),
    (-9, -2, 90),
    (-9, -5, 90),
]
MORE: list[Pose] = [(-3, 5, 45), (-14, -8, -90), (-1, 9, 135), (-7, -6, -120)]
WALK_STARTS: list[Pose] = [(-12, 0, 0), (-6, 3, 180), (-9, -2, 90), (-9, -5, 90), (-6, 3, 0)]


def error(estimate: Pose, truth: Pose) -> tuple[float, float]:
    return math.hypot(estimate[0] - truth[0], estimate[1] - truth[1]), abs((estimate[2] - truth[2] + 180) % 360 - 180)


def line(name: str, errors: list[tuple[float, float]]) -> str:
    e = np.array(errors)
    return (
        f"{name:<46} n {len(e):4d}  position median {100 * np.median(e[:, 0]):4.1f} cm, worst "
        f"{100 * e[:, 0].max():5.1f} cm; heading median {np.median(e[:, 1]):4.2f}, worst {e[:, 1].max():5.2f} deg"
    )


#: Sees the parser refused (the real server's occasional nan), each kept for a look
UNREADABLE: list[str] = []


def _seen(perception: Perception) -> bool:
    """Whether the perception carries a readable See (an unreadable one is kept in
    ``UNREADABLE``: the estimators take it as a cycle without vision)."""
    try:
        return perception.vision is not None
    except ProtocolError:
        UNREADABLE.append(str(perception._vision[0]) if isinstance(perception._vision, tuple) else "")
        return False


def warn(problem: str, key: str) -> None:
    raise RuntimeError(problem)


def stand_in_robot(seed: int, beam_noise: bool = False) -> tuple[Simulation, object]:
    sim = Simulation(ServerConfig(sync=True, realtime=False, beam_noise=beam_noise, sense_mypos=True, seed=seed))
    state = sim.join()
    sim.apply_frame(state, b"(scene rsg/agent/nao/nao.rsg)", warn)
    sim.step()
    sim.apply_frame(state, b"(init (unum 1)(teamname Loc))", warn)
    sim.step()
    return sim, state


def torso_pose(state) -> Pose:
    (x, y, _), rot = state.robot.torso_position(), state.robot.torso_rotation()
    return x, y, math.degrees(math.atan2(rot[1, 1], rot[0, 1]))


def stand_in_standing(pose: Pose, seed: int) -> list[tuple[float, float]]:
    sim, state = stand_in_robot(seed, beam_noise=True)
    try:
        sim.apply_frame(state, f"(beam {pose[0]} {pose[1]} {pose[2]})".encode(), warn)
        estimator = VisionPose(pose)
        errors = []
        for _ in range(60):
            sim.step()
            perception = parse_perception(sim.perception(state, sim.vision_due))
            estimator.update(perception, Command())
            if _seen(perception):
                errors.append(error(estimator.pose, torso_pose(state)))
        return errors[3:]
    finally:
        sim.close()


def course_poses(speed: float = 0.5, sideways: float = 0.3, turning: float = 60.0) -> Iterator[Pose]:
    for (x0, y0, h0), (x1, y1, h1) in zip(COURSE, COURSE[1:]):
        turn = 180.0 if h1 - h0 == 180 else (h1 - h0 + 180) % 360 - 180
        length = math.hypot(x1 - x0, y1 - y0)
        cycles = max(1, math.ceil(max(length / min(speed, sideways), abs(turn) / turning) / 0.02))
        for k in range(1, cycles + 1):
            f = k / cycles
            yield x0 + f * (x1 - x0), y0 + f * (y1 - y0), h0 + f * turn


def stand_in_course(seed: int) -> tuple[list[tuple[float, float]], VisionPose]:
    """The robot carried along the course (placed each cycle: the stand-in has no walk that turns
    or steps sideways), odometry the true motion with 10 % errors; the gyro reads nothing of a
    placed robot, so the odometry turns it. Every vision cycle's error, and the estimator."""
    sim, state = stand_in_robot(seed, beam_noise=False)
    rng = np.random.default_rng(seed)
    try:
        sim.apply_frame(state, b"(beam -12 0 0)", warn)
        for _ in range(10):
            sim.step()
        previous = torso_pose(state)
        estimator = VisionPose(previous, LocalizationConfig(use_gyro=False))
        errors = []
        for x, y, heading in course_poses():
            state.robot.place(x, y, 0.384, heading)
            sim.step()
            now = torso_pose(state)
            h = math.radians(previous[2])
            dx, dy = now[0] - previous[0], now[1] - previous[1]
            scale = 1.0 + 0.1 * rng.standard_normal(3)
            moved = Command(
                (math.cos(h) * dx + math.sin(h) * dy) * scale[0],
                (-math.sin(h) * dx + math.cos(h) * dy) * scale[1],
                ((now[2] - previous[2] + 180) % 360 - 180) * scale[2],
            )
            previous = now
            perception = parse_perception(sim.perception(state, sim.vision_due))
            estimator.update(perception, moved)
            if _seen(perception):
                errors.append(error(estimator.pose, now))
        return errors, estimator
    finally:
        sim.close()


def _walk(
    exchange: Callable[[bytes], Perception],
    truth: Callable[[], Pose],
    pose: Pose,
    speed: float,
    initialised: bool,
    started: Callable[[], None] = lambda: None,
) -> list[tuple[float, float]]:
    """Walk the fastest gait for 6 s from ``pose``: ``exchange`` sends a reply (none at first)
    and returns the next perception. The estimator starts after the behaviour's second beam
    (which draws the beam's noise again), when ``started`` is called."""
    behaviour = WalkBehaviour(AgentConfig(beam=pose, sync=True, start_now=True), load_gait(FASTEST).walker())
    if initialised:  # the robot has been through init already
        behaviour.phase = Phase.BEAMING
    estimator: VisionPose | None = None
    errors = []
    reply = b""
    for _ in range(round(6.0 / 0.02) + 45):
        perception = exchange(reply)
        reply = behaviour.reply(perception).encode()
        if estimator is None:
            if behaviour.phase is Phase.SETTLING and behaviour.settle_cycle > 13:
                estimator = VisionPose(pose)
                started()
            continue
        walking = behaviour.phase is Phase.WALKING
        estimator.update(perception, Command(speed * 0.02 if walking else 0.0, 0.0, 0.0))
        if behaviour.fell_at is not None:  # a falling robot's heading means nothing: the last 0.6 s go
            return errors[3:-10]
        if _seen(perception):
            errors.append(error(estimator.pose, truth()))
    return errors[3:]


def stand_in_walk(pose: Pose, speed: float, seed: int) -> list[tuple[float, float]]:
    sim, state = stand_in_robot(seed, beam_noise=True)

    def exchange(reply: bytes) -> Perception:
        if reply:
            sim.apply_frame(state, reply, warn)
        sim.step()
        return parse_perception(sim.perception(state, sim.vision_due))

    try:
        # PlayOn once beamed: before kick-off the referee moves a robot that crosses the halfway line
        return _walk(exchange, lambda: torso_pose(state), pose, speed, True, lambda: sim.set_play_mode("PlayOn"))
    finally:
        sim.close()


def recorded_real_walks() -> tuple[list[tuple[float, float]], list[float]]:
    errors, offsets = [], []
    for run in (1, 2, 3):
        track = np.loadtxt(WALKS / f"run{run}_torso_track.tsv", skiprows=1)
        monitor: dict[float, tuple[float, float]] = {}
        for t, x, y, *_ in track:
            monitor.setdefault(round(t, 2), (x, y))
        start = (-10.0, 3.0, 0.0)
        vision_pose, true_pose = VisionPose(start), TruePose(start)
        for k, text in enumerate((WALKS / f"run{run}_perceptions.txt").read_text().splitlines()[2:]):
            perception = parse_perception(text)
            vision_pose.update(perception, Command())
            true_pose.update(perception, Command())
            if _seen(perception) and k > 30:
                errors.append(error(vision_pose.pose, true_pose.pose))
                seen_at = round(perception.game.time or 0.0, 2)
                if seen_at in monitor and seen_at > 0.6:
                    offsets.append(math.dist(true_pose.pose[:2], monitor[seen_at]))
    return errors, offsets


class _RealServer:
    """One rcssserver3d (sync profile) and one agent connection to it."""

    def __init__(self, command: str, port: int = 3417) -> None:
        self.process = subprocess.Popen(
            [command, str(port), str(port + 1)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        deadline = time.monotonic() + 20.0
        while True:
            try:
                self.sock = socket.create_connection(("127.0.0.1", port), timeout=10.0)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)
        self._buffer = b""

    def send(self, text: bytes) -> None:
        body = text + b"(syn)"
        self.sock.sendall(struct.pack("!I", len(body)) + body)

    def receive(self) -> Perception:
        while len(self._buffer) < 4 or len(self._buffer) < 4 + struct.unpack("!I", self._buffer[:4])[0]:
            chunk = self.sock.recv(1 << 16)
            if not chunk:
                raise ConnectionError("the server closed the connection")
            self._buffer += chunk
        (n,) = struct.unpack("!I", self._buffer[:4])
        body, self._buffer = self._buffer[4 : 4 + n], self._buffer[4 + n :]
        return parse_perception(body)

    def close(self) -> None:
        self.sock.close()
        self.process.kill()
        self.process.wait()


def real_standing(command: str) -> list[tuple[float, float]]:
    server = _RealServer(command)
    try:
        server.send(b"(scene rsg/agent/nao/nao.rsg)")
        server.receive()
        server.send(b"(init (unum 1)(teamname Loc))")
        server.receive()
        errors = []
        for pose in COURSE + MORE:
            server.send(f"(beam {pose[0]} {pose[1]} {pose[2]})".encode())
            vision_pose, true_pose = VisionPose(pose), TruePose(pose)
            for k in range(60):
                perception = server.receive()
                vision_pose.update(perception, Command())
                true_pose.update(perception, Command())
                if _seen(perception) and k > 9:
                    errors.append(error(vision_pose.pose, true_pose.pose))
                server.send(b"")
        return errors
    finally:
        server.close()


def real_course(command: str, seed: int) -> list[tuple[float, float]]:
    """The course on the real server: the robot beamed to each cycle's pose (the sync profile
    has no beam noise), odometry the asked-for motion with 10 % errors, the truth ``mypos``
    moved to the torso (``TruePose``)."""
    server = _RealServer(command)
    rng = np.random.default_rng(seed)
    try:
        server.send(b"(scene rsg/agent/nao/nao.rsg)")
        server.receive()
        server.send(b"(init (unum 1)(teamname Loc))")
        server.receive()
        server.send(b"(beam -12 0 0)")
        for _ in range(10):
            server.receive()
            server.send(b"")
        config = LocalizationConfig(use_gyro=False)
        vision_pose, true_pose = VisionPose(COURSE[0], config), TruePose(COURSE[0], config)
        previous = COURSE[0]
        errors = []
        for x, y, heading in course_poses():
            perception = server.receive()
            h = math.radians(previous[2])
            dx, dy = x - previous[0], y - previous[1]
            scale = 1.0 + 0.1 * rng.standard_normal(3)
            moved = Command(
                (math.cos(h) * dx + math.sin(h) * dy) * scale[0],
                (-math.sin(h) * dx + math.cos(h) * dy) * scale[1],
                ((heading - previous[2] + 180) % 360 - 180) * scale[2],
            )
            previous = (x, y, heading)
            vision_pose.update(perception, moved)
            true_pose.update(perception, Command())
            if _seen(perception):
                errors.append(error(vision_pose.pose, true_pose.pose))
            server.send(f"(beam {x:.4f} {y:.4f} {heading:.3f})".encode())
        return errors[3:]
    finally:
        server.close()


def real_walk(command: str, pose: Pose) -> list[tuple[float, float]]:
    server = _RealServer(command)
    true_pose = TruePose(pose)
    try:
        server.send(b"(scene rsg/agent/nao/nao.rsg)")

        def exchange(reply: bytes) -> Perception:
            if reply:
                server.send(reply)
            perception = server.receive()
            true_pose.update(perception, Command())
            return perception

        return _walk(exchange, lambda: true_pose.pose, pose, 1.0, False, lambda: true_pose.reset(pose))
    finally:
        server.close()


def cost() -> str:
    """Best-of timings of ``update`` over the real server's recorded walk."""
    texts = (WALKS / "run1_perceptions.txt").read_text().splitlines()[2:]
    source: PoseSource = VisionPose((-10.0, 3.0, 0.0))
    perceptions = [parse_perception(t) for t in texts]
    for p in perceptions:
        _ = p.vision
    times: dict[bool, list[float]] = {True: [], False: []}
    for _ in range(3):
        source = VisionPose((-10.0, 3.0, 0.0))
        for p in perceptions:
            start = time.perf_counter()
            source.update(p, Command())
            times[p.vision is not None].append(time.perf_counter() - start)
    reading = []
    for t in texts:
        p = parse_perception(t)
        start = time.perf_counter()
        seen = p.vision is not None
        if seen:
            reading.append(time.perf_counter() - start)
    return (
        f"update without vision: median {1e6 * np.median(times[False]):.1f} us; with vision (See read): median "
        f"{1e6 * np.median(times[True]):.0f} us, 90th percentile {1e6 * np.percentile(times[True], 90):.0f} us; "
        f"reading the See: median {1e6 * np.median(reading):.0f} us"
    )


def main() -> None:
    standing: list[tuple[float, float]] = []
    for seed, pose in enumerate(COURSE + MORE):
        standing += stand_in_standing(pose, seed)
    print(line("stand-in, standing (13 poses, beam noise)", standing))
    print(line("stand-in, the course (odometry 10 % off)", stand_in_course(3)[0][3:]))
    for speed in (1.0, 0.0):
        walked: list[tuple[float, float]] = []
        for seed, pose in enumerate(WALK_STARTS):
            walked += stand_in_walk(pose, speed, seed)
        print(line(f"stand-in, fastest gait, odometry {speed:.0f} m/s", walked))
    errors, offsets = recorded_real_walks()
    print(line("real server, recorded walks (vision vs mypos)", errors))
    print(
        f"{'  mypos moved to the torso vs the monitor torso':<46} n {len(offsets):4d}  median "
        f"{100 * np.median(offsets):.1f} cm, worst {100 * max(offsets):.1f} cm"
    )
    command = os.environ.get("RCSSSERVER3D")
    if command:
        print(line("real server, standing (13 poses)", real_standing(command)))
        print(line("real server, the course (beamed each cycle)", real_course(command, 3)))
        walked = []
        for pose in [WALK_STARTS[0], *WALK_STARTS[2:4]]:  # the ones that stay in the own half
            walked += real_walk(command, pose)
        print(line("real server, fastest gait, odometry 1 m/s", walked))
    if UNREADABLE:
        bad = re.findall(r"\(L [^L]*nan[^L]*\)", UNREADABLE[0])
        print(f"{len(UNREADABLE)} perceptions with a See the parser refused; the first's bad lines: {bad}")
    print(cost())


if __name__ == "__main__":
    main()
