"""A seeded fuzzer for the stand-in server: mutated real messages on both ports, framing abuse and
connect/reset storms, against a stub running as its own process.

Why a process and sockets: the crashes this hunts (docs/fidelity.md, robustness) ended the whole server, and some lay
in the socket code itself (a connection reset before it was accepted), which an in-process call of
a handler never reaches. A crash is the stub exiting or no longer serving a well-behaved agent
(the canary, checked every ``canary_every`` sessions); the stub is then restarted and the run
goes on, so one run counts every crash it finds.

The corpus is the real server's captured traffic (``agent_commands_sent.txt``,
``monitor_commands_sent.txt``, perceptions and monitor messages, sent to the wrong port too);
``tests/test_stub_fuzz.py`` runs a bounded run, ``bench/bench_fuzz.py`` a long one.
"""

from __future__ import annotations

import random
import re
import socket
import struct
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

_REPO = Path(__file__).resolve().parents[1]
_PREFIX = struct.Struct("!I")
#: Used when no fixtures folder is given: the shapes every session starts from.
_SEED_AGENT = [
    b"(scene rsg/agent/nao/nao.rsg)",
    b"(init (unum 1)(teamname Fuzz))",
    b"(beam -1 0 0)",
    b"(he1 0.5)(lle3 -0.2)(syn)",
    b"(say hello)",
    b"(syn)",
]
_SEED_MONITOR = [
    b"(playMode PlayOn)",
    b"(agent (unum 1) (team Left) (pos -4.0 -1.0 0.5))",
    b"(ball (pos 1.0 0.5 0.042) (vel 0.0 0.0 0.0))",
    b"(time 0)",
    b"(reqfullstate)",
]
#: ``(killsim)`` is a trainer's way to end the server, not a crash: the fuzzer never sends it.
_KILLSIM = re.compile(rb"killsim", re.IGNORECASE)
#: Atoms a mutation swaps in: numbers a parser or the physics may choke on, names of the protocol.
_ATOMS = [
    b"nan",
    b"inf",
    b"-inf",
    b"1e400",
    b"-0",
    b"1e-320",
    b"9" * 40,
    b"0x10",
    b"1_0",
    b"",
    b"\x00",
    b"\xff\xfe",
    b"\x1b[2J",
    b"rsg/agent/nao/nao_hetero.rsg",
    b"4",
    b"-1",
    b"Left",
    b"Right",
    b"PlayOn",
    b"kill",
    b"scene",
    b"init",
    b"beam",
    b"say",
    b"syn",
    b"unum",
    b"team",
]


def load_corpus(fixtures: Path | None) -> tuple[list[bytes], list[bytes]]:
    """(agent messages, monitor messages): each fixture line one message; perceptions and the
    monitor stream join both lists, as what a confused client might send to either port."""
    if fixtures is None:
        return list(_SEED_AGENT), list(_SEED_MONITOR)

    def lines(name: str, limit: int) -> list[bytes]:
        path = fixtures / name
        if not path.exists():
            return []
        return [line.rstrip(b"\r\n") for line in path.read_bytes().splitlines()[:limit] if line.strip()]

    agent = lines("agent_commands_sent.txt", 2000) + _SEED_AGENT
    monitor = lines("monitor_commands_sent.txt", 100) + _SEED_MONITOR
    other = lines("agent_perceptions_first20.txt", 40) + lines("monitor_messages.txt", 5)
    return agent + other, monitor + other


class Mutator:
    """Seeded mutations of messages: byte edits, atom swaps, splices, deep nesting, truncation."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng

    def mutate(self, message: bytes, corpus: list[bytes]) -> bytes:
        rng = self.rng
        data = bytearray(message)
        for _ in range(rng.choice((1, 1, 1, 2, 3, 8))):
            kind = rng.randrange(9)
            pos = rng.randrange(len(data) + 1)
            if kind == 0 and data:
                data[min(pos, len(data) - 1)] ^= 1 << rng.randrange(8)
            elif kind == 1:
                data[pos:pos] = bytes([rng.randrange(256)])
            elif kind == 2 and data:
                del data[pos : pos + rng.randrange(1, 8)]
            elif kind == 3:
                tokens = re.split(rb"([()\s])", bytes(data))
                atoms = [i for i, t in enumerate(tokens) if t and t not in b"() \t\n"]
                if atoms:
                    tokens[rng.choice(atoms)] = rng.choice(_ATOMS)
                    data = bytearray(b"".join(tokens))
            elif kind == 4:
                other = rng.choice(corpus)
                cut = rng.randrange(len(other) + 1)
                data[pos:] = other[cut:]
            elif kind == 5:
                depth = rng.choice((10, 63, 64, 65, 200, 1000, 5000))
                data[pos:pos] = b"(" * depth + rng.choice((b"", b"a")) + b")" * rng.choice((depth, depth // 2, 0))
            elif kind == 6:
                data = data[:pos]
            elif kind == 7:
                data[pos:pos] = rng.choice((b"(", b")", b"((", b"))", b" ", b"\t", b"\n"))
            else:
                data[pos:pos] = rng.choice((b"x", b"(say ", b"1")) * rng.choice((100, 5000, 300_000))
        return bytes(data)


@dataclass
class FuzzReport:
    """What a run did and found."""

    messages: int = 0
    sessions: int = 0
    resets: int = 0
    crashes: int = 0
    peak_rss_mib: float = 0.0
    log_bytes: int = 0
    longest_log_line: int = 0
    crash_logs: list[str] = field(default_factory=list)


class _Stub:
    """``python -m server_stub`` on free ports, its log in a file."""

    def __init__(self, args: list[str], log_path: Path) -> None:
        self.log_path = log_path
        self._log = log_path.open("ab")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "server_stub", "--agent-port", "0", "--monitor-port", "0", *args],
            cwd=_REPO,
            stdout=subprocess.PIPE,
            stderr=self._log,
            text=True,
        )
        assert self.proc.stdout is not None  # stdout=PIPE
        match = re.search(r"agent port (\d+), monitor port (\d+)", self.proc.stdout.readline())
        if not match:
            self.stop()
            raise RuntimeError(f"stub did not start; see {log_path}")
        self.agent_port, self.monitor_port = int(match.group(1)), int(match.group(2))

    def peak_rss_mib(self) -> float:
        try:
            status = Path(f"/proc/{self.proc.pid}/status").read_text()
        except OSError:
            return 0.0
        found = re.search(r"VmHWM:\s+(\d+) kB", status)
        return int(found.group(1)) / 1024 if found else 0.0

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._log.close()


def _send_quietly(sock: socket.socket, data: bytes) -> bool:
    """False once the stub has closed this connection (it may drop a fuzzing client any time)."""
    try:
        sock.sendall(data)
        return True
    except OSError:
        return False


def _reset(sock: socket.socket) -> None:
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _LINGER_0)
    sock.close()


_LINGER_0 = struct.pack("ii", 1, 0)


class Fuzzer:
    """Sessions against one stub: an agent or a trainer sending a run of messages, each framed
    right or abused, then leaving by FIN, RST or in the middle of a frame; now and then a storm
    of connections reset at once."""

    def __init__(self, seed: int, fixtures: Path | None, session_messages: int = 40) -> None:
        self.rng = random.Random(seed)
        self.mutator = Mutator(self.rng)
        self.agent_corpus, self.monitor_corpus = load_corpus(fixtures)
        self.session_messages = session_messages

    def _frames(self, message: bytes) -> bytes:
        """The message framed, usually right; else with a prefix that lies, twice, or empty."""
        rng = self.rng
        roll = rng.random()
        if roll < 0.85:
            return _PREFIX.pack(len(message)) + message
        if roll < 0.90:
            return _PREFIX.pack(max(0, len(message) - rng.randrange(1, 5))) + message
        if roll < 0.93:
            return _PREFIX.pack(len(message) + rng.randrange(1, 5)) + message
        if roll < 0.96:
            return (_PREFIX.pack(len(message)) + message) * 2 + _PREFIX.pack(0)
        if roll < 0.98:
            return _PREFIX.pack(rng.choice(((1 << 20) + 1, 0xFFFFFFFF, 0x7FFFFFFF)))
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 12)))

    def session(self, stub: _Stub, report: FuzzReport) -> bool:
        """One client's session; False if the stub could not be reached."""
        rng = self.rng
        agent = rng.random() < 0.6
        corpus = self.agent_corpus if agent else self.monitor_corpus
        try:
            sock = socket.create_connection(("127.0.0.1", stub.agent_port if agent else stub.monitor_port), timeout=5)
        except OSError:
            return False
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        report.sessions += 1
        script = list(_SEED_AGENT[:3]) if agent and rng.random() < 0.7 else []
        for _ in range(rng.randrange(1, self.session_messages)):
            message = rng.choice(corpus)
            message = self.mutator.mutate(message, corpus) if rng.random() < 0.8 else message
            script.append(_KILLSIM.sub(b"killsym", message))
            if agent and rng.random() < 0.5:
                script.append(b"(syn)")
        for message in script:
            data = self._frames(message)
            if rng.random() < 0.1:  # split anywhere, as TCP may deliver it
                cut = rng.randrange(len(data) + 1)
                ok = _send_quietly(sock, data[:cut]) and _send_quietly(sock, data[cut:])
            else:
                ok = _send_quietly(sock, data)
            report.messages += 1
            if not ok:
                break
            if agent and rng.random() < 0.05:
                self._drain(sock)
        ending = rng.random()
        if ending < 0.3:
            _reset(sock)
        elif ending < 0.4:
            _send_quietly(sock, _PREFIX.pack(100) + b"(half")
            sock.close()
        else:
            sock.close()
        return True

    @staticmethod
    def _drain(sock: socket.socket) -> None:
        sock.settimeout(0.0)
        try:
            while sock.recv(1 << 16):
                pass
        except OSError:
            pass
        finally:
            sock.settimeout(5)

    def storm(self, stub: _Stub, report: FuzzReport, count: int) -> None:
        """``count`` connections to either port, each reset at once (some after a few bytes)."""
        for _ in range(count):
            port = stub.agent_port if self.rng.random() < 0.5 else stub.monitor_port
            try:
                sock = socket.create_connection(("127.0.0.1", port), timeout=5)
            except OSError:
                continue
            if self.rng.random() < 0.3:
                _send_quietly(sock, _PREFIX.pack(10) + b"(sc")
            _reset(sock)
            report.resets += 1


def canary(stub: _Stub, timeout: float = 20.0) -> bool:
    """Whether the stub still serves a well-behaved agent: scene, then a perception back."""
    try:
        with socket.create_connection(("127.0.0.1", stub.agent_port), timeout=timeout) as sock:
            body = b"(scene rsg/agent/nao/nao.rsg)(syn)"
            sock.sendall(_PREFIX.pack(len(body)) + body)
            buffer = b""
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                chunk = sock.recv(1 << 16)
                if not chunk:
                    return False
                buffer += chunk
                if len(buffer) >= 4 and len(buffer) >= 4 + _PREFIX.unpack_from(buffer)[0]:
                    return buffer[4:].startswith(b"(time (now ")
    except OSError:
        return False
    return False


def run(
    messages: int,
    seed: int = 0,
    fixtures: Path | None = None,
    sync: bool = True,
    log_path: Path = Path("fuzz-stub.log"),
    canary_every: int = 200,
    storm_every: int = 100,
    progress=None,
) -> FuzzReport:
    """Fuzz one stub (``--sync`` or real time) until ``messages`` messages were sent."""
    fuzzer = Fuzzer(seed, fixtures)
    report = FuzzReport()
    args = ["--sync", "--no-realtime", "--agent-timeout", "2"] if sync else ["--realtime"]
    args += ["--seed", str(seed)]
    log_path.unlink(missing_ok=True)
    stub = _Stub(args, log_path)
    try:
        while report.messages < messages:
            reached = fuzzer.session(stub, report)
            if report.sessions % storm_every == 0:
                fuzzer.storm(stub, report, 50)
            if not reached or report.sessions % canary_every == 0 or report.messages >= messages:
                report.peak_rss_mib = max(report.peak_rss_mib, stub.peak_rss_mib())
                if stub.proc.poll() is not None or not canary(stub):
                    report.crashes += 1
                    stub.stop()
                    report.crash_logs.append(log_path.read_text(errors="replace")[-3000:])
                    stub = _Stub(args, log_path)
                if progress is not None:
                    progress(report)
    finally:
        stub.stop()
    text = log_path.read_bytes()
    report.log_bytes = len(text)
    report.longest_log_line = max((len(line) for line in text.splitlines()), default=0)
    return report
