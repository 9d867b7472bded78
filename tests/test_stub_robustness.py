"""One client must never take the stand-in down: each input that once ended the whole
server is sent over a real socket, and a well-behaved agent is served afterwards; the error
boundary, the log limits and the parser's depth cap are checked where they live."""

from __future__ import annotations

import logging
import os
import socket
import struct
import threading
import time

import numpy as np
import pytest

from protocol.errors import ProtocolError
from protocol.sexp import MAX_DEPTH, parse_sexp
from server_stub.config import ServerConfig
from server_stub.net.server import StubServer
from server_stub.physics.world import World
from tests.stub_client import RawClient, StubProcess

NEST = "(" * 5000 + ")" * 5000


@pytest.fixture()
def stub():
    with StubProcess("--sync", "--no-realtime", "--agent-timeout", "3") as server:
        yield server


def _served(port: int, cycles: int = 5) -> None:
    """A well-behaved agent: scene, init, beam, a few cycles with joint commands."""
    client = RawClient(port)
    client.send("(scene rsg/agent/nao/nao.rsg)(syn)")
    assert client.receive().startswith("(time (now ")
    client.send("(init (unum 1)(teamname Good))(syn)")
    client.receive()
    for _ in range(cycles):
        client.send("(he1 1.0)(syn)")
        assert "(HJ (n hj1)" in client.receive()
    client.close()


def _alive_and_clean(stub: StubProcess) -> str:
    _served(stub.agent_port)
    assert stub.proc.poll() is None, "the server exited"
    log = stub.stop()
    assert "Traceback" not in log
    return log


def _with_robot(port: int) -> RawClient:
    """An agent whose robot exists, after its first perception."""
    client = RawClient(port)
    client.send("(scene rsg/agent/nao/nao.rsg)(syn)")
    client.receive()
    return client


def _reset(sock: socket.socket) -> None:
    """Close with SO_LINGER 0: the kernel sends RST instead of FIN."""
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    sock.close()


def test_the_parser_refuses_nesting_past_its_cap_with_a_protocol_error() -> None:
    assert len(parse_sexp("(" * MAX_DEPTH + ")" * MAX_DEPTH)) == 1
    with pytest.raises(ProtocolError, match=f"at most {MAX_DEPTH} nested"):
        parse_sexp("(a " * (MAX_DEPTH + 1) + ")" * (MAX_DEPTH + 1))
    with pytest.raises(ProtocolError):  # a ValueError, which every caller already handles
        parse_sexp(NEST)


@pytest.mark.parametrize(
    "message",
    [
        NEST,
        f"(agent (unum 1) (team Left) {NEST})",
        f"(ball (pos {NEST}))",
        f"(time {NEST})",
    ],
)
def test_deep_nesting_on_the_monitor_port(stub: StubProcess, message: str) -> None:
    trainer = RawClient(stub.monitor_port)
    trainer.send(message)
    trainer.send("(playMode PlayOn)")  # the monitor itself is still served
    trainer.receive()
    log = _alive_and_clean(stub)
    assert "nested parentheses" in log


@pytest.mark.parametrize("message", [f"(scene {NEST})(syn)", f"(say {NEST})(syn)"])
def test_deep_nesting_on_the_agent_port(stub: StubProcess, message: str) -> None:
    other = _with_robot(stub.agent_port)
    bad = RawClient(stub.agent_port)
    bad.send(message)
    other.send("(syn)")
    other.receive()
    log = _alive_and_clean(stub)
    assert "nested parentheses" in log


def test_say_before_scene_while_another_robot_exists(stub: StubProcess) -> None:
    listener = _with_robot(stub.agent_port)
    speaker = RawClient(stub.agent_port)
    speaker.send("(say hello)")
    for _ in range(3):  # the listener's perceptions after the say are where hearing once failed
        listener.send("(syn)")
        assert "(hear " not in listener.receive()
    log = _alive_and_clean(stub)
    assert "say before scene" in log


def test_a_speaker_that_leaves_before_it_is_heard(stub: StubProcess) -> None:
    listener = _with_robot(stub.agent_port)
    speaker = RawClient(stub.agent_port)
    speaker.send("(scene rsg/agent/nao/nao.rsg)(syn)")
    listener.send("(syn)")
    listener.receive()
    speaker.receive()
    speaker.send("(say bye)(syn)")
    speaker.close()
    for _ in range(3):
        listener.send("(syn)")
        listener.receive()
    _alive_and_clean(stub)


def test_connect_and_reset_before_accept_in_the_accept_path() -> None:
    """Deterministic: the connection is reset before the server accepts it."""
    server = StubServer(ServerConfig(agent_port=0, monitor_port=0, sync=True, realtime=False))
    try:
        for kind, listener in (("agent", server._agent_listener), ("monitor", server._monitor_listener)):
            client = socket.create_connection(("127.0.0.1", listener.getsockname()[1]))
            _reset(client)
            time.sleep(0.05)
            server._accept(listener, kind)  # once: getpeername() raised ENOTCONN here
        for client in [*server._agents, *server._monitors]:
            server._read(client)  # the reset is seen and the connection dropped
        assert not server._agents and not server._monitors
    finally:
        server.close()


def test_a_storm_of_connect_and_reset_on_both_ports(stub: StubProcess) -> None:
    for i in range(400):
        port = stub.agent_port if i % 2 else stub.monitor_port
        _reset(socket.create_connection(("127.0.0.1", port)))
    _alive_and_clean(stub)


@pytest.fixture()
def threaded_server():
    """An in-process server on free ports, its loop on a thread (``parent_pid`` keeps its select
    from blocking forever when no agent is connected, so ``stop`` is seen)."""
    server = StubServer(ServerConfig(agent_port=0, monitor_port=0, sync=True, realtime=False, parent_pid=os.getppid()))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.stop()
    thread.join(10)
    assert not thread.is_alive()


def test_any_exception_from_one_clients_input_drops_only_that_client(threaded_server, monkeypatch, caplog) -> None:
    server = threaded_server
    original = server.sim._scene

    def buggy(state, args):
        if args and args[0] == "boom":
            raise RuntimeError("a bug this input reached")
        original(state, args)

    monkeypatch.setattr(server.sim, "_scene", buggy)
    with caplog.at_level(logging.WARNING, logger="server_stub"):
        bad = RawClient(server.agent_port)
        bad.send("(scene boom)(syn)")
        bad.sock.settimeout(5)
        with pytest.raises((ConnectionError, OSError)):
            bad.receive()
        _served(server.agent_port)
    lines = [r.getMessage() for r in caplog.records if "RuntimeError" in r.getMessage()]
    assert len(lines) == 1 and "a bug this input reached; disconnected" in lines[0]


def test_warnings_quote_little_escaped_and_a_garbage_stream_is_cut(threaded_server, caplog) -> None:
    server = threaded_server
    with caplog.at_level(logging.WARNING, logger="server_stub"):
        big = RawClient(server.monitor_port)
        big.send(b"(time \x1b[2J" + b"x" * 900_000 + b")")
        garbage = RawClient(server.monitor_port)
        name = garbage_name(garbage)
        garbage.sock.settimeout(10)
        try:  # the socket buffers hold ~200 KB, so whether a send fails first depends on timing
            for n in range(10_000):
                garbage.send(f"(nonsense{n} \x07)".encode())
        except OSError:
            pass
        assert closed_by_server(garbage, within=30.0)
        _served(server.agent_port)
        big.send("(playMode PlayOn)")
    messages = [r.getMessage() for r in caplog.records]
    assert max(len(m) for m in messages) < 400
    assert not any(ch < " " for m in messages for ch in m)
    assert any("\\x1b[2J" in m for m in messages)
    cut = [m for m in messages if name in m]
    assert "keeps sending input that is refused" in cut[-1]
    assert len(cut) <= server.config.warning_burst + 3, cut


def closed_by_server(client: RawClient, within: float) -> bool:
    """Whether the server closes ``client``'s connection within ``within`` seconds: reads (and
    drops) what it sends until the end of the stream, a reset, or the deadline."""
    deadline = time.monotonic() + within
    while (left := deadline - time.monotonic()) > 0:
        client.sock.settimeout(left)
        try:
            if not client.sock.recv(1 << 16):
                return True
        except TimeoutError:
            return False
        except ConnectionError:
            return True
    return False


def garbage_name(client: RawClient) -> str:
    host, port = client.sock.getsockname()
    return f"monitor {host}:{port}"


def _random_walk(world, robot, steps: int, seed: int, beam_at: int) -> list:
    """Joint angles, torso, accelerometer and foot pressure per step under seeded random motor
    speeds, beamed at step ``beam_at``."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(steps):
        if i == beam_at:
            robot.beam(-3.0, 0.0, 0.0)
        for j, v in enumerate(rng.uniform(-3.0, 3.0, 22)):
            robot.command_joint(j, float(v))
        world.step()
        out.append((robot.torso_position(), robot.joint_angles(), robot.accelerometer(), robot.foot_pressure()))
    return out


@pytest.mark.parametrize("beam_at", [0, 10])
def test_a_reused_robot_moves_exactly_as_a_freshly_loaded_one(beam_at: int) -> None:
    """Removed robots' bodies are parked and reused (pybullet leaks what loadURDF takes): the next
    robot of the type must behave bit for bit as a new one, whatever the last one did."""
    with World() as fresh:
        expected = _random_walk(fresh, fresh.add_robot(0), 120, 1, beam_at)
    with World() as used:
        first = used.add_robot(0)
        _random_walk(used, first, 100, 5, 0)  # flails and falls where the next one will stand
        used.remove_robot(first)
        again = used.add_robot(0)
        assert again.body_id == first.body_id
        assert _random_walk(used, again, 120, 1, beam_at) == expected


def test_robots_created_and_removed_do_not_grow_memory() -> None:
    with World() as world:
        for _ in range(20):
            world.remove_robot(world.add_robot(0))
        before = _rss_mib()
        for _ in range(300):
            robot = world.add_robot(0)
            world.step()
            world.remove_robot(robot)
        assert _rss_mib() - before < 1.5  # 300 loads leaked about 5.9 MiB


def _rss_mib() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def test_an_agent_that_floods_messages_without_waiting_is_cut_and_others_are_served(threaded_server, caplog) -> None:
    """In sync mode an agent's messages wait in the server until the next cycle; one that sends
    thousands without waiting for its perception is disconnected once it passes the cap, with
    one clear line, and the server keeps serving others."""
    server = threaded_server
    cap = server.config.agent_inbox_frames
    with caplog.at_level(logging.WARNING, logger="server_stub"):
        flood = _with_robot(server.agent_port)
        flood.sock.settimeout(10)
        try:
            for _ in range(3 * cap):  # valid commands, never a (syn)
                flood.send("(he1 0.5)")
        except OSError:  # cut while sending: the server has closed the connection
            pass
        assert closed_by_server(flood, within=30.0)
        _served(server.agent_port)
    lines = [r.getMessage() for r in caplog.records if "does not wait for its perceptions" in r.getMessage()]
    assert len(lines) == 1 and f"over the cap of {cap}" in lines[0] and lines[0].endswith("; disconnected")
