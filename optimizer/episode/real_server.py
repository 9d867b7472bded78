"""Real rcssserver3d servers the optimizer starts and stops itself (``--real N``).

A real server is found through ``RCSSSERVER3D`` (the binary itself, or a wrapper that applies a
profile, such as ``rcss-sync``), then ``rcssserver3d`` on PATH. It is started on free loopback
ports with a sync profile generated here, in a temporary HOME, from the installed defaults: the
installed files are never edited. A wrapper that sets HOME itself keeps its own profile.

Stopping is the delicate part: SIGTERM and SIGINT only close rcssserver3d's sockets, and it goes
on spinning at 100% CPU. So a server is stopped with ``(killsim)`` on its monitor port, then
SIGKILL. It runs in a process group of its own (a Ctrl-C at the terminal does not reach it, the
owner stops it), and on Linux the kernel kills it when the process that started it dies, however
that process died.
"""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from optimizer.episode.servers import ServerAddress, ServerProcess, ServerStartError
from protocol.framing import encode_frame

#: Environment variable naming the real server's command.
RCSSSERVER3D_ENV = "RCSSSERVER3D"
#: The server's name on PATH.
RCSSSERVER3D_NAME = "rcssserver3d"


class RealServerError(ServerStartError):
    """A real server cannot be found or started; the message says what to do."""


def find_rcssserver3d(environ: dict[str, str] | None = None) -> str:
    """The real server's command: ``$RCSSSERVER3D``, else ``rcssserver3d`` on PATH."""
    env = os.environ if environ is None else environ
    named = env.get(RCSSSERVER3D_ENV, "").strip()
    if named:
        found = shutil.which(named, path=env.get("PATH"))
        if found is None:
            raise RealServerError(f"{RCSSSERVER3D_ENV}={named!r} is not an executable file")
        return found
    found = shutil.which(RCSSSERVER3D_NAME, path=env.get("PATH"))
    if found is None:
        raise RealServerError(
            f"no real rcssserver3d found: set {RCSSSERVER3D_ENV} to the server binary or to a wrapper such as "
            f"rcss-sync, or put {RCSSSERVER3D_NAME} on PATH"
        )
    return found


@dataclass(frozen=True)
class ProfileSetting:
    """One line of an installed init script that the sync profile changes."""

    file: str
    pattern: str
    replacement: str


#: What the sync profile changes in the installed defaults (rcssserver3d 0.7.3), and why:
#: the server steps only when every agent has sent ``(syn)`` and never waits for the wall clock
#: (episodes run as fast as the machine allows); single-threaded, because with Ruby 3 the
#: multi-threaded loop dies with signal 11 as soon as a client connects; no beam noise (an
#: episode starts where it is put; the stability check moves starts itself, seeded); ``mypos`` on,
#: so agents that localise from it work as on a test field.
SYNC_PROFILE: tuple[ProfileSetting, ...] = (
    ProfileSetting("spark.rb", r"^\$agentSyncMode\s*=\s*\w+", "$agentSyncMode = true"),
    ProfileSetting("spark.rb", r"^\$threadedAgentControl\s*=\s*\w+", "$threadedAgentControl = false"),
    ProfileSetting("spark.rb", r"^\$serverMultiThreadedMode\s*=\s*\w+", "$serverMultiThreadedMode = false"),
    ProfileSetting("rcssserver3d.rb", r"^\$enableRealTimeMode\s*=\s*\w+", "$enableRealTimeMode = false"),
    ProfileSetting("naosoccersim.rb", r"^addSoccerVar\('BeamNoiseXY',[^)]*\)", "addSoccerVar('BeamNoiseXY',0.0)"),
    ProfileSetting("naosoccersim.rb", r"^addSoccerVar\('BeamNoiseAngle',[^)]*\)", "addSoccerVar('BeamNoiseAngle',0.0)"),
    ProfileSetting("rsg/agent/nao/naoneckhead.rsg", r"\(setSenseMyPos \w+\)", "(setSenseMyPos true)"),
    ProfileSetting("rsg/agent/nao/naoneckhead.rsg", r"\(setSenseMyOrien \w+\)", "(setSenseMyOrien true)"),
    ProfileSetting("rsg/agent/nao/naoneckhead.rsg", r"\(setSenseBallPos \w+\)", "(setSenseBallPos true)"),
)

#: Where each profile file is installed, below the install prefix's ``share/``.
_INSTALLED = {
    "spark.rb": "simspark/spark.rb",
    "kerosin.rb": "simspark/kerosin.rb",  # copied unchanged, or the server copies it into HOME itself
    "rcssserver3d.rb": "rcssserver3d/rcssserver3d.rb",
    "naosoccersim.rb": "rcssserver3d/naosoccersim.rb",
    "rsg/agent/nao/naoneckhead.rsg": "rcssserver3d/rsg/agent/nao/naoneckhead.rsg",
}


def installed_defaults(command: str) -> Path | None:
    """The ``share/`` folder of the installation ``command`` belongs to (``PREFIX/bin/x`` ->
    ``PREFIX/share``), when it holds every file the profile is made from."""
    share = Path(os.path.realpath(command)).parent.parent / "share"
    return share if all((share / path).is_file() for path in _INSTALLED.values()) else None


def write_sync_profile(share: Path, home: Path) -> Path:
    """Write the sync profile into ``home/.simspark`` (where the server looks first), made from
    the installed files under ``share``; returns that folder. A setting whose line is not found
    is an error naming it: a server started without it would not run in sync mode."""
    target = home / ".simspark"
    for name, installed in _INSTALLED.items():
        text = (share / installed).read_text()
        for setting in (s for s in SYNC_PROFILE if s.file == name):
            text, count = re.subn(setting.pattern, setting.replacement, text, flags=re.MULTILINE)
            if count == 0:
                raise RealServerError(
                    f"cannot make the sync profile: {share / installed} has no line "
                    f"matching {setting.pattern!r} (another rcssserver3d version?)"
                )
        path = target / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return target


def free_port() -> int:
    """A TCP port free on the loopback interface now (the server binds it a moment later)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _die_with_parent() -> Callable[[], None] | None:
    """A ``preexec_fn`` that has the kernel SIGKILL the child when its parent dies (Linux
    ``PR_SET_PDEATHSIG``), so no server outlives an optimizer killed with -9; None elsewhere."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    parent = os.getpid()
    pr_set_pdeathsig = 1

    def set_death_signal() -> None:
        prctl(pr_set_pdeathsig, signal.SIGKILL)
        if os.getppid() != parent:  # the parent died before the request took effect
            os._exit(1)

    return set_death_signal


def kill_sim(address: ServerAddress, timeout: float = 1.0) -> bool:
    """Ask a server to quit through its monitor port; False when the port does not answer."""
    try:
        with socket.create_connection((address.host, address.monitor_port), timeout=timeout) as link:
            link.sendall(encode_frame("(killsim)"))
        return True
    except OSError:
        return False


#: Seconds a real server may take to open its ports (it loads Ruby scripts and the scene first).
START_TIMEOUT = 30.0
#: Seconds a server has to quit after ``(killsim)`` before it is killed.
KILLSIM_GRACE = 3.0


class RealServerProcess(ServerProcess):
    """One real rcssserver3d in the sync profile on free loopback ports, owned by one worker, as
    ``optimizer.episode.servers.StubProcess`` is a stub."""

    def __init__(self, command: str, start_timeout: float = START_TIMEOUT) -> None:
        super().__init__()
        self.command = command
        self.start_timeout = start_timeout
        self._home: tempfile.TemporaryDirectory[str] | None = None

    def restart(self) -> None:
        self.stop()
        last = ""
        for _ in range(3):  # a free port can be taken between the probe and the server's bind
            try:
                self._start()
                return
            except RealServerError as exc:
                last = str(exc)
                self.stop()
        raise RealServerError(last)

    def _start(self) -> None:
        self._home = tempfile.TemporaryDirectory(prefix="gala_rcss_")
        home = Path(self._home.name)
        share = installed_defaults(self.command)
        if share is not None:
            write_sync_profile(share, home)
        address = ServerAddress("127.0.0.1", free_port(), free_port())
        env = {**os.environ, "HOME": str(home)}
        env.pop("SPARK_DIR", None)  # it would move the server's share/ lookup away from its install
        log = (home / "server.log").open("wb")
        try:
            self._process = subprocess.Popen(
                [self.command, "--agent-port", str(address.agent_port), "--server-port", str(address.monitor_port)],
                cwd=home,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                process_group=0,
                preexec_fn=_die_with_parent(),
            )
        finally:
            log.close()
        self.address = address
        deadline = time.monotonic() + self.start_timeout
        while not _listening(address):
            if self._process.poll() is not None:
                raise RealServerError(
                    f"{self.command} exited with code {self._process.returncode} before "
                    f"opening ports {address.agent_port}/{address.monitor_port}: "
                    f"{_tail(home / 'server.log')}"
                )
            if time.monotonic() > deadline:
                raise RealServerError(
                    f"{self.command} did not open ports {address.agent_port}/"
                    f"{address.monitor_port} within {self.start_timeout:g} s"
                )
            time.sleep(0.1)

    def stop(self) -> None:
        """``(killsim)``, then SIGKILL to its process group if it is still there."""
        process, self._process = self._process, None
        if process is not None:
            if process.poll() is None and self.address is not None and kill_sim(self.address):
                try:
                    process.wait(KILLSIM_GRACE)
                except subprocess.TimeoutExpired:
                    pass
            if process.poll() is None:
                try:
                    os.killpg(process.pid, signal.SIGKILL)
                except (ProcessLookupError, PermissionError):
                    process.kill()
                process.wait()
        self.address = None
        if self._home is not None:
            self._home.cleanup()
            self._home = None


def _listening(address: ServerAddress) -> bool:
    """Both ports accept a connection (each probe is closed at once: an agent that connects and
    leaves before ``scene`` is forgotten by the server)."""
    for port in (address.agent_port, address.monitor_port):
        try:
            socket.create_connection((address.host, port), timeout=0.5).close()
        except OSError:
            return False
    return True


def _tail(path: Path, lines: int = 5) -> str:
    try:
        return " | ".join(path.read_text(errors="replace").strip().splitlines()[-lines:])
    except OSError:
        return "(no output)"
