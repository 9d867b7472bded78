"""Whatever an agent or a trainer sends, the stub never raises (a malformed message must not
take the server down): hypothesis drives the server's frame handlers in-process, the way the
socket loop calls them, with command-shaped text and with arbitrary bytes."""

from __future__ import annotations

import math
import socket

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from protocol.nao import JOINTS
from server_stub.config import ServerConfig
from server_stub.net.clients import AgentState, Client
from server_stub.net.server import StubServer

NAMES = [j.effector for j in JOINTS] + ["beam", "say", "scene", "init", "syn", "pass", "xyz9", ""]
ATOMS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["nan", "inf", "-inf", "1e400", "1_0", "0x10", "\xff", "é", "0.5\xe9", "rsg/agent/nao/nao.rsg"]),
    st.text(alphabet=st.characters(blacklist_categories=["Z", "C"], blacklist_characters="()"), min_size=1, max_size=6),
)
VALUES = st.one_of(ATOMS, st.sampled_from(["", "(", ")", " "]), st.text(max_size=6))


@st.composite
def command_texts(draw) -> bytes:
    """Half the time the every-cycle shape, ``(name atom)`` repeated (what the fast reader
    takes), else anything bracket-like; encoded as ASCII, UTF-8 or Latin-1."""
    flat = draw(st.booleans())
    parts = []
    for _ in range(draw(st.integers(0, 6))):
        name = draw(st.sampled_from(NAMES))
        if flat:
            parts.append(f"({name} {draw(ATOMS)})")
            continue
        args = " ".join(draw(st.lists(VALUES, max_size=3)))
        parts.append(draw(st.sampled_from(["({} {})", "({} {}", "{} {})", "(({} {}))"])).format(name, args))
    text = "".join(parts)
    return text.encode(draw(st.sampled_from(["ascii", "utf-8", "latin-1"])), errors="replace")


@pytest.fixture()
def server_and_agent():
    # thousands of refused messages in a second: the limit that disconnects such a client is
    # out of the way here (tests/test_stub_robustness.py tests it)
    config = ServerConfig(agent_port=0, monitor_port=0, sync=True, realtime=False, bad_input_burst=10**9)
    server = StubServer(config)
    listener = socket.create_server(("127.0.0.1", 0))
    peer = socket.create_connection(listener.getsockname())
    sock, _ = listener.accept()
    client = Client(sock, "agent", 1 << 20, 1 << 20, config=config)
    state = AgentState()
    server._agents[client] = state
    server._on_agent_frame(client, state, b"(scene rsg/agent/nao/nao.rsg)(init (unum 1)(teamname T))")
    assert state.robot is not None and state.side == "left"
    yield server, client, state
    for s in (peer, sock, listener):
        s.close()
    server.close()


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.one_of(command_texts(), st.binary(max_size=80)))
@example(b"(he1 \xff)(syn)")  # a non-ASCII byte in the every-cycle shape once took the server down
@example(b"(say \xe9)")
def test_no_frame_makes_the_command_handler_raise(server_and_agent, frame: bytes) -> None:
    server, client, state = server_and_agent
    server._on_agent_frame(client, state, frame)
    server.world.step()
    x, y, z = state.robot.torso_position()
    assert all(math.isfinite(v) for v in (x, y, z))
    state.robot.beam(-3.0, 0.0, 0.0)  # back on the field for the next example


TRAINER_NAMES = [
    "playMode",
    "kickOff",
    "time",
    "agent",
    "ball",
    "dropBall",
    "score",
    "repos",
    "kill",
    "select",
    "reqfullstate",
    "killsim",
    "nonsense",
]
FIELDS = ["team", "unum", "pos", "move", "vel", "left", "right", "battery"]


@st.composite
def trainer_texts(draw) -> bytes:
    """Trainer commands with fields of any arity and atoms of any kind, as another team's trainer
    or a broken one might send them."""
    commands = []
    for _ in range(draw(st.integers(0, 3))):
        fields = "".join(
            f"({draw(st.sampled_from(FIELDS))} {' '.join(draw(st.lists(ATOMS, max_size=5)))})"
            for _ in range(draw(st.integers(0, 3)))
        )
        atoms = " ".join(
            draw(st.lists(st.one_of(ATOMS, st.sampled_from(["Left", "Right", "PlayOn", "1"])), max_size=2))
        )
        commands.append(f"({draw(st.sampled_from(TRAINER_NAMES))} {atoms}{fields})")
    return "".join(commands).encode(draw(st.sampled_from(["ascii", "latin-1"])), errors="replace")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.one_of(trainer_texts(), st.binary(max_size=80)))
def test_no_trainer_message_makes_the_server_raise(server_and_agent, frame: bytes) -> None:
    server, client, _ = server_and_agent
    server._on_trainer_frame(client, frame)
    server.world.step()
