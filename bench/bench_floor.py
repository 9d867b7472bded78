"""The cost floor of this stack: one optimizer cycle's CPU time if all of our Python were free.

An optimizer worker is two processes on loopback TCP: a stub server and the worker (agent plus
the episode's judge reading the monitor). Whatever our own code does, each cycle still pays for:

1. physics: ``pb.stepSimulation`` of the stub's world while the real calibration gait walks
   (the stub's settings: exact solver, 22 motors, foot contacts);
2. the pybullet calls the server cannot skip: joint states (HJ, motor rule), link states (FRP,
   slip model, monitor poses), contact points, torso pose and velocity, motor targets and
   ~1.5 slip forces, each timed on that walking robot;
3. the sockets: two processes swap an episode's frames over loopback TCP as they do in a run
   (the server receives a 300-B command frame and sends an 885-B perception, plus a 3.6-kB
   monitor update every other cycle; the worker does the mirror image), the CPU time of each.

floor s = 1 + 2 + 3 (server side), floor w = 3 (worker side). Two workers on two cores run at
most 2 / (s + w) cycles a second, i.e. 2 / (s + w) x 3600 / 750 fifteen-second episodes an
hour; one worker at most 1 / max(s, w). One NAO driven over sockets (``bench_stub.py``) runs at
most at 0.02 / s times real time, and the sockets alone cost server sockets / s of the raw rate.
Compare with ``bench_episodes.py``, which measures s and w of the real code. Run: ``python bench/bench_floor.py [--cycles 20000]``.
"""

from __future__ import annotations

import argparse
import multiprocessing
import socket
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import pybullet as pb  # noqa: E402

from protocol.framing import encode_frame  # noqa: E402
from server_stub.physics import calibration_walk  # noqa: E402
from server_stub.physics import world as world_module
from server_stub.physics.world import World  # noqa: E402

#: Mean frame sizes of a walking episode on the stub (measured: 781 perceptions, 393 monitor
#: updates of the default gait's episode; the command frame of 22 hinges and (syn)).
PERCEPTION_BYTES = 885
MONITOR_BYTES = 3600
COMMAND_BYTES = 300
EPISODE_CYCLES = 750


def physics_and_calls() -> tuple[float, float]:
    """(stepSimulation, unavoidable pybullet calls) in seconds per cycle of the calibration walk."""
    stepping = [0.0]
    real_step = pb.stepSimulation

    def timed_step(*args, **kwargs):
        start = time.perf_counter()
        real_step(*args, **kwargs)
        stepping[0] += time.perf_counter() - start

    world_module.pb.stepSimulation = timed_step
    calls = 0.0
    cycles = 0
    try:
        with World() as world:
            real_world_step = world.step

            def step_and_read() -> None:
                nonlocal calls, cycles
                real_world_step()
                cycles += 1
                (robot,) = world.robots
                body, client, joints = robot.body_id, world._client, list(range(22))
                target, force = (values.tolist() for values in robot._sent)
                start = time.perf_counter()
                pb.getJointStates(body, joints, physicsClientId=client)
                pb.getLinkStates(body, joints, computeLinkVelocity=1, physicsClientId=client)
                pb.getContactPoints(bodyA=body, physicsClientId=client)
                pb.getBasePositionAndOrientation(body, physicsClientId=client)
                pb.getBaseVelocity(body, physicsClientId=client)
                # the two writes are repeated with no effect on the state: the motor targets
                # Bullet already has, and zero forces (1.5 slip forces a cycle on average)
                pb.setJointMotorControlArray(
                    body, joints, pb.VELOCITY_CONTROL, targetVelocities=target, forces=force, physicsClientId=client
                )
                calls += time.perf_counter() - start
                start = time.perf_counter()
                for _ in range(2):
                    pb.applyExternalForce(
                        body, 0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), pb.WORLD_FRAME, physicsClientId=client
                    )
                calls += 0.75 * (time.perf_counter() - start)

            world.step = step_and_read  # type: ignore[method-assign]
            result = calibration_walk.run(world)
            if result.fell:
                raise RuntimeError("the calibration walk fell: the physics timed is not a walk")
            return stepping[0] / cycles, calls / cycles
    finally:
        world_module.pb.stepSimulation = real_step


def _read_exact(sock: socket.socket, view: memoryview, size: int) -> None:
    got = 0
    while got < size:
        got += sock.recv_into(view[got:size])


def _worker_side(agent_port: int, monitor_port: int, cycles: int, result) -> None:
    agent = socket.create_connection(("127.0.0.1", agent_port))
    monitor = socket.create_connection(("127.0.0.1", monitor_port))
    for sock in (agent, monitor):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    buffer = memoryview(bytearray(1 << 16))
    command = encode_frame(b"x" * COMMAND_BYTES)
    start = time.process_time()
    for cycle in range(cycles):
        _read_exact(agent, buffer, 4 + PERCEPTION_BYTES)
        if cycle % 2 == 1:
            _read_exact(monitor, buffer, 4 + MONITOR_BYTES)
        agent.sendall(command)
    result.value = (time.process_time() - start) / cycles


def sockets(cycles: int) -> tuple[float, float]:
    """(server side, worker side) CPU seconds per cycle of the episode's socket traffic."""
    listeners = []
    for _ in range(2):
        listener = socket.socket()
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        listeners.append(listener)
    result = multiprocessing.Value("d", 0.0)
    worker = multiprocessing.Process(
        target=_worker_side, args=(listeners[0].getsockname()[1], listeners[1].getsockname()[1], cycles, result)
    )
    worker.start()
    agent, _ = listeners[0].accept()
    monitor, _ = listeners[1].accept()
    for sock in (agent, monitor):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    buffer = memoryview(bytearray(1 << 16))
    perception = encode_frame(b"p" * PERCEPTION_BYTES)
    update = encode_frame(b"m" * MONITOR_BYTES)
    agent.sendall(perception)  # as the stub does: the next perception goes out before the reply
    start = time.process_time()
    for cycle in range(cycles):
        if cycle % 2 == 1:
            monitor.sendall(update)
        _read_exact(agent, buffer, 4 + COMMAND_BYTES)
        if cycle + 1 < cycles:
            agent.sendall(perception)
    server = (time.process_time() - start) / cycles
    worker.join()
    for sock in (agent, monitor, *listeners):
        sock.close()
    return server, result.value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=20000, help="socket cycles to time (default 20000)")
    args = parser.parse_args()
    step, calls = physics_and_calls()
    server_io, worker_io = sockets(args.cycles)
    s = step + calls + server_io
    w = worker_io
    print(f"physics (stepSimulation)          {step * 1e6:7.1f} us/cycle")
    print(f"pybullet calls the server needs   {calls * 1e6:7.1f} us/cycle")
    print(f"sockets, server side              {server_io * 1e6:7.1f} us/cycle")
    print(f"sockets, worker side              {worker_io * 1e6:7.1f} us/cycle")
    print(f"floor s = {s * 1e3:.3f} ms, w = {w * 1e3:.3f} ms per cycle")
    raw = step + calls
    print(
        f"1 NAO with its agent, sync mode: at most {0.02 / s:.0f}x real time; the sockets alone cost "
        f"{server_io / s:.0%} of the raw rate ({0.02 / raw:.0f}x)"
    )
    per_hour = 3600.0 / EPISODE_CYCLES
    print(f"at most, 1 worker:  {per_hour / max(s, w):8.0f} 15-s episodes/h  ({0.02 / max(s, w):.0f}x real time)")
    print(
        f"at most, 2 workers: {2 * per_hour / (s + w):8.0f} 15-s episodes/h  "
        f"(parallel efficiency at most {max(s, w) / (s + w):.0%})"
    )


if __name__ == "__main__":
    main()
