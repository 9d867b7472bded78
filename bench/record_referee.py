"""Record what a server's referee makes of scripted trainer scenarios: each play mode with the game
time it began, the score, where the ball was left and where the first robot stood, as the first
agent's perceptions report them. Recorded on a real rcssserver3d 0.7.3, the files in
``tests/data/referee/`` are what ``tests/test_referee_scenarios.py`` replays on the stand-in.

    python -m bench.record_referee                      # every scenario, real server -> tests/data/referee/
    python -m bench.record_referee --only kick_in,say   # some of them
    python -m bench.record_referee --stub               # on the stand-in, printed beside the recording

A scenario is data: its robots (team, number, beam, the cycle it joins at), the trainer's commands
and the robots' ``say`` messages and beams at given cycles, and how many cycles it runs. Cycle k is the agents'
k-th perception; what a robot does at k is its reply to it, and a trainer command due at k acts in
the same step as that reply. The real server reads its monitor port at the start of a cycle,
before it waits for the agents' ``(syn)``, the stand-in whenever a command arrives: so a command
goes to the real server one cycle early (``TRAINER_LEAD``), with the server waiting for the
agents, which makes its cycle certain. The robots stand still (no joint commands): beamed, then
statues.

What is recorded, per play mode in the order they came (``segments``): ``t`` and ``mode`` from the
first perception showing it (the game time after the step that changed it), ``score`` [left,
right], ``ball_in`` (``ballpos``, 2 decimals) from the segment's first vision message at least
two cycles in (``_PLACED_SHOWS``), ``ball``
and ``me`` (``ballpos`` and the first robot's ``mypos``) from its last, ``still`` whether the ball
stood there at the vision message before. Per robot, what it heard (``hear``, with the cycle),
when the referee held it in the air (``lifted``) and where it ended (``end``); and the fouls the
monitor stream reported (``fouls``, as runs: ``foul_runs``).
"""

from __future__ import annotations

import argparse
import json
import re
import select
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from optimizer.episode.real_server import RealServerProcess, find_rcssserver3d
from optimizer.episode.servers import ServerAddress
from protocol.framing import FrameDecoder, encode_frame
from protocol.perception import Perception, parse_perception

ROOT = Path(__file__).resolve().parents[1]

DATA = ROOT / "tests" / "data" / "referee"
#: Cycle at which every robot beams (after ``init`` at its first perception).
BEAM_CYCLE = 3
#: Cycles ahead a trainer command is sent, by server (see the module docstring); and the pause
#: (s) before it, long enough for a real server to have finished its step and wait for the agents.
TRAINER_LEAD = {"real": 1, "stand-in": 0}
_SETTLE = 0.01
#: How long (s) to look for a joining robot's first perception once the others' have come: a
#: server in sync mode sends a cycle's perceptions together.
_JOIN_WAIT = 0.2
#: Cycles after a play mode shows before ``ball_in`` is read: a ball the real referee moves after
#: the step is seen where it was for one more cycle (vision reads the scene graph, which the next
#: step updates).
_PLACED_SHOWS = 2


@dataclass(frozen=True)
class Player:
    team: str
    unum: int
    beam: tuple[float, float, float]
    #: The cycle after which it connects (0: before the first). Robots are created at one spot
    #: until ``init`` moves them; on the real server two created there together collide and are
    #: knocked about (the stand-in hangs the later one beside), so robots that must stand still
    #: join one by one. A robot's ``init`` and beam count from its own first perception.
    joins: int = 0


@dataclass(frozen=True)
class Scenario:
    name: str
    about: str
    players: tuple[Player, ...]
    #: (cycle, trainer command)
    trainer: tuple[tuple[int, str], ...]
    cycles: int
    #: (cycle, index of the player, message): ``(say ...)``; or ``(beam ...)`` text sent as is
    acts: tuple[tuple[int, int, str], ...] = ()


_ONE = (Player("Ref", 1, (-3.0, 0.0, 0.0)),)
#: A roll into the first robot's shins (beamed to (-3, 0)): someone has touched the ball.
_TOUCH = "(ball (pos -2.4 0 0.042) (vel -1.5 0 0))"

SCENARIOS: tuple[Scenario, ...] = (
    Scenario(
        "issue",
        "The issue's scenario: kick-off left, the ball sent into the right goal, then nothing "
        "until the first half ends.",
        _ONE,
        ((10, "(kickOff Left)"), (20, "(ball (pos 14 0 0.2) (vel 8 0 0))")),
        15_120,
    ),
    Scenario(
        "halves",
        "Both halves, fast: the clock set near each half's end; then the game over for 12 s.",
        _ONE,
        ((10, "(kickOff Left)"), (12, "(time 295)"), (600, "(kickOff Right)"), (602, "(time 595)")),
        1_900,
    ),
    Scenario(
        "touch",
        "A kick-off ended by the first touch: the ball rolled into the robot.",
        (Player("Ref", 1, (-0.6, 0.0, 0.0)),),
        ((10, "(kickOff Left)"), (20, "(ball (pos 0.3 0 0.042) (vel -1.5 0 0))")),
        200,
    ),
    Scenario(
        "kick_in",
        "Touched by the left robot, the ball leaves over the side line: kick-in right, held on "
        "the line, dropped after 15 s.",
        _ONE,
        ((10, "(kickOff Left)"), (20, _TOUCH), (150, "(ball (pos 2 9.5 0.042) (vel 0 2 0))")),
        1_100,
    ),
    Scenario(
        "goal_line",
        "Last touched by the left robot, the ball crosses the right goal line wide of the goal "
        "(goal kick right, then its drop ball), then the left goal line (corner right, dropped).",
        _ONE,
        (
            (10, "(kickOff Left)"),
            (20, _TOUCH),
            (150, "(ball (pos 14.5 5 0.042) (vel 2 0 0))"),
            (1_100, "(ball (pos -14.5 -5 0.042) (vel -2 0 0))"),
        ),
        2_000,
    ),
    Scenario(
        "goal_right",
        "Play on, the ball into the left goal: the right side scores, kicks off after 3 s.",
        _ONE,
        ((10, "(playMode PlayOn)"), (20, "(ball (pos -14 0.5 0.042) (vel -3 0 0))")),
        1_100,
    ),
    Scenario(
        "free_kick",
        "A free kick set by the trainer with the ball in the left penalty area: spot moved to the "
        "area's corner, then a drop ball.",
        _ONE,
        ((10, "(playMode PlayOn)"), (20, "(ball (pos -14 1 0.042) (vel 0 0 0))"), (40, "(playMode free_kick_right)")),
        900,
    ),
    Scenario(
        "beams",
        "Beams in each play mode, and the referee's kick-off clearing of the centre circle.",
        (Player("Ref", 1, (-1.0, 0.0, 0.0)),),
        ((40, "(kickOff Right)"), (80, "(playMode PlayOn)"), (120, "(playMode Goal_Left)"), (300, "(playMode PlayOn)")),
        360,
        acts=(
            (60, 0, "(beam -6 1 0)"),
            (100, 0, "(beam -6 2 0)"),
            (140, 0, "(beam -1 3 0)"),
            (320, 0, "(beam -6 4 0)"),
        ),
    ),
    Scenario(
        "incapable",
        "Three robots fall before kick-off: two bend their knees and lie flat, one bends its hips "
        "and lies with its hips up (torso centre between 0.15 and 0.25 m). From play on the "
        "referee counts: the flat field player is lifted after 15 s on the ground, the flat "
        "goalie after 30 s, the other after 30 s not standing; each is put outside the field "
        "0.5 s later, on the side away from the ball.",
        (
            Player("Ref", 3, (-3.0, 2.0, 0.0)),
            Player("Ref", 1, (-8.0, -2.0, 0.0), joins=4),
            Player("Opp", 2, (-3.0, 2.0, 0.0), joins=8),
        ),
        ((200, "(playMode PlayOn)(ball (pos 0 3 0.042) (vel 0 0 0))"),),
        1_850,
        acts=((20, 0, "(lle4 -6)(rle4 -6)"), (24, 1, "(lle4 -6)(rle4 -6)"), (28, 2, "(lle3 6)(rle3 6)")),
    ),
    Scenario(
        "say",
        "Say and hear: two left robots and a right one joining one by one, standing still; "
        "messages at once and in turn, every cycle, too long, then from over 50 m and under.",
        (
            Player("Ref", 1, (-3.0, 0.0, 0.0)),
            Player("Ref", 2, (-5.0, 3.0, 90.0), joins=4),
            Player("Opp", 1, (-4.0, -2.0, 0.0), joins=14),
        ),
        (
            (30, "(playMode PlayOn)"),
            (60, "(agent (unum 1) (team Right) (pos 22 22 0.4))"),
            (62, "(agent (unum 2) (team Left) (pos -22 -22 0.4))"),  # 62.2 m from the right robot
            (70, "(agent (unum 2) (team Left) (pos -19 -10 0.4))"),  # 52.0 m
            (76, "(agent (unum 2) (team Left) (pos -17 -7 0.4))"),  # 48.6 m
        ),
        84,
        acts=(
            (32, 0, "(say hello)"),
            (34, 1, "(say two)"),
            (34, 2, "(say three)"),
            (35, 0, "(say again)"),
            (36, 0, "(say onemore)"),
            (40, 0, "(say exactly_twenty_chars)"),
            (42, 0, "(say twenty_one_characters)"),
            (50, 0, "(say m50)"),
            (51, 0, "(say m51)"),
            (51, 2, "(say o51)"),
            (52, 0, "(say m52)"),
            (53, 0, "(say m53)"),
            (56, 1, "(say a-b+c*d/e<f>g!?)"),
            (66, 1, "(say far1)"),
            (68, 2, "(say far2)"),
            (74, 1, "(say out52)"),
            (80, 1, "(say in49)"),
        ),
    ),
)


class _Connection:
    """One length-prefixed TCP stream."""

    def __init__(self, address: tuple[str, int]) -> None:
        self.sock = socket.create_connection(address, timeout=30.0)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._decoder = FrameDecoder()
        self._frames: list[bytes] = []

    def send(self, text: str) -> None:
        self.sock.sendall(encode_frame(text.encode()))

    def ready(self, wait: float) -> bool:
        """Whether a message is there, or comes within ``wait`` s."""
        return bool(self._frames) or bool(select.select([self.sock], [], [], wait)[0])

    def receive(self) -> bytes:
        while not self._frames:
            data = self.sock.recv(1 << 16)
            if not data:
                raise ConnectionError("the server closed the connection")
            self._frames.extend(self._decoder.feed(data))
        return self._frames.pop(0)

    def close(self) -> None:
        self.sock.close()


_FOUL = re.compile(rb"\(foul (\d+) (\d+) (\d+) (\d+)\)")
_MONITOR_TIME = re.compile(rb"\(time ([0-9.]+)\)")


def _drain(monitor: _Connection, fouls: list[tuple[float, int, int, int]]) -> None:
    """Read the monitor stream (a monitor that does not read stalls the server), keeping each foul
    it reports: (game time of its message, foul type, team index, number)."""
    try:
        while True:
            frame = monitor.receive()
            if b"(foul " not in frame:
                continue
            now = _MONITOR_TIME.search(frame)
            t = float(now.group(1)) if now else float("nan")
            fouls.extend((t, int(m[2]), int(m[3]), int(m[4])) for m in _FOUL.finditer(frame))
    except (OSError, ConnectionError, struct.error):
        return


def foul_runs(fouls: list[tuple[float, int, int, int]]) -> list[list]:
    """The fouls as runs of one player's one type (the real server records a foul again every
    cycle it holds the player; a run ends after 0.5 s without one): [type, team, unum, first t,
    last t, count]. ``t`` is the game time of the monitor message that reported the foul, which
    comes every second cycle."""
    runs: list[list] = []
    for t, kind, team, unum in fouls:
        same = [r for r in runs if r[:3] == [kind, team, unum] and t - r[4] <= 0.5]
        if same:
            same[-1][4] = t
            same[-1][5] += 1
        else:
            runs.append([kind, team, unum, t, t, 1])
    return runs


#: A robot whose head (``mypos``) is this high has been lifted by the referee.
_LIFTED = 0.6


@dataclass
class _Log:
    segments: list[dict] = field(default_factory=list)
    hear: list[list[dict]] = field(default_factory=list)
    #: per robot: the game times of its first and last vision messages of each run with its head
    #: over ``_LIFTED``, and where its head was at its last vision message
    lifted: list[list[list[float]]] = field(default_factory=list)
    end: list[list[float] | None] = field(default_factory=list)
    _last_ball: list[float] | None = None
    _began = 0

    def read(self, cycle: int, index: int, perception: Perception) -> None:
        if index == 0:
            self._game(cycle, perception)
        vision = perception.vision
        if vision is not None and vision.mypos is not None:
            self._track(index, perception.game.time, vision.mypos)
        for heard in perception.hear:
            self.hear[index].append(
                {"cycle": cycle, "team": heard.team, "t": heard.time, "from": heard.direction, "said": heard.message}
            )

    def _track(self, index: int, t: float, head: tuple[float, float, float]) -> None:
        was_high = self.end[index] is not None and self.end[index][2] > _LIFTED
        if head[2] > _LIFTED:
            if was_high:
                self.lifted[index][-1][1] = t
            else:
                self.lifted[index].append([t, t])
        self.end[index] = [round(v, 2) for v in head]

    def _game(self, cycle: int, perception: Perception) -> None:
        gs = perception.game
        score = [gs.score_left, gs.score_right]
        if not self.segments or self.segments[-1]["mode"] != gs.play_mode or self.segments[-1]["score"] != score:
            self._began = cycle
            self.segments.append(
                {"t": gs.time, "mode": gs.play_mode, "score": score, "ball_in": None, "ball": None, "me": None}
            )
        vision = perception.vision
        if vision is not None and vision.ballpos is not None:
            segment = self.segments[-1]
            ball = [round(v, 2) for v in vision.ballpos]
            if segment["ball_in"] is None and cycle - self._began >= _PLACED_SHOWS:
                segment["ball_in"] = ball
            segment["still"] = ball == self._last_ball
            segment["ball"], self._last_ball = ball, ball
            segment["me"] = None if vision.mypos is None else [round(v, 2) for v in vision.mypos]


def run(scenario: Scenario, address: ServerAddress, lead: int) -> dict:
    """Play ``scenario`` on the server at ``address`` (sync mode, ``mypos`` and ``ballpos`` on),
    sending trainer commands ``lead`` cycles ahead (``TRAINER_LEAD``)."""
    monitor = _Connection((address.host, address.monitor_port))
    fouls: list[tuple[float, int, int, int]] = []
    drain = threading.Thread(target=_drain, args=(monitor, fouls), daemon=True)
    drain.start()
    agents: list[_Connection | None] = [None] * len(scenario.players)
    #: the cycle of each robot's first perception: robots there from the start have theirs at 1
    first: list[int | None] = [None if player.joins else 1 for player in scenario.players]
    robots = len(scenario.players)
    log = _Log(hear=[[] for _ in range(robots)], lifted=[[] for _ in range(robots)], end=[None] * robots)
    trainer = dict(scenario.trainer)

    def join(index: int) -> None:
        agents[index] = _Connection((address.host, address.agent_port))
        agents[index].send("(scene rsg/agent/nao/nao.rsg)")

    try:
        for index, player in enumerate(scenario.players):
            if not player.joins:
                join(index)
        for cycle in range(1, scenario.cycles + 1):
            for index, agent in enumerate(agents):
                if agent is not None and first[index] is None and agent.ready(_JOIN_WAIT):
                    first[index] = cycle
                if agent is not None and first[index] is not None:
                    log.read(cycle, index, parse_perception(agent.receive()))
            if cycle + lead in trainer:
                time.sleep(_SETTLE)
                monitor.send(trainer[cycle + lead])
            for index, (agent, player) in enumerate(zip(agents, scenario.players)):
                if agent is None:
                    continue
                own = None if first[index] is None else cycle - first[index] + 1
                reply = ""
                if own == 1:
                    reply = f"(init (unum {player.unum})(teamname {player.team}))"
                elif own == BEAM_CYCLE:
                    reply = "(beam {:g} {:g} {:g})".format(*player.beam)
                reply += "".join(text for at, who, text in scenario.acts if at == cycle and who == index)
                agent.send(reply + "(syn)")
            for index, player in enumerate(scenario.players):
                if player.joins == cycle:
                    join(index)
    finally:
        for agent in agents:
            if agent is not None:
                agent.close()
        monitor.close()
        drain.join(timeout=5.0)
    return {
        "scenario": scenario.name,
        "about": scenario.about,
        "segments": log.segments,
        "hear": log.hear,
        "lifted": log.lifted,
        "end": log.end,
        "fouls": foul_runs(fouls),
    }


@contextmanager
def stand_in() -> Iterator[ServerAddress]:
    """A stand-in as the real server's sync profile runs: sync, no real time, no beam noise,
    ``mypos`` and ``ballpos`` in vision; on free ports, stopped on exit."""
    process = subprocess.Popen(
        [sys.executable, "-m", "server_stub", "--sync", "--no-realtime", "--no-beam-noise", "--sense-mypos"]
        + ["--agent-port", "0", "--monitor-port", "0", "--exit-with-parent"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        ports = re.search(r"agent port (\d+), monitor port (\d+)", process.stdout.readline())
        if ports is None:
            raise RuntimeError("the stand-in did not start")
        yield ServerAddress("127.0.0.1", int(ports.group(1)), int(ports.group(2)))
    finally:
        process.kill()
        process.wait()
        if process.stdout is not None:
            process.stdout.close()


def record(scenario: Scenario, command: str) -> dict:
    """``scenario`` on a fresh real server (the optimizer's sync profile: no beam noise)."""
    server = RealServerProcess(command)
    try:
        return run(scenario, server.ensure_running(), TRAINER_LEAD["real"])
    finally:
        server.stop()


def table(recording: dict) -> str:
    lines = [f"{recording['scenario']}: {recording['about']}"]
    for s in recording["segments"]:
        ball = "" if s["ball"] is None else "ball {} {} {}".format(*s["ball"]) + ("" if s.get("still") else " (moving)")
        if s["ball_in"] is not None and s["ball_in"] != s["ball"]:
            ball = "ball in {} {} {}, ".format(*s["ball_in"]) + ball
        me = "" if s["me"] is None else "  me {} {}".format(*s["me"][:2])
        lines.append(f"  {s['t']:8.2f}  {s['mode']:<18} {s['score'][0]}:{s['score'][1]}  {ball}{me}")
    for index, (lifted, end) in enumerate(zip(recording["lifted"], recording["end"])):
        if lifted:
            runs = ", ".join(f"{a:.2f}-{b:.2f}" for a, b in lifted)
            lines.append(f"  robot {index}: lifted {runs}; ends at {end}")
    for kind, team, unum, t0, t1, count in recording["fouls"]:
        lines.append(f"  foul type {kind} team {team} unum {unum}: {count} records, {t0:.2f}-{t1:.2f}")
    for index, heard in enumerate(recording["hear"]):
        for h in heard:
            lines.append(f"  robot {index} cycle {h['cycle']}: hear {h['team']} {h['t']:.2f} {h['from']} {h['said']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.record_referee", description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", help="comma-separated scenario names")
    parser.add_argument("--stub", action="store_true", help="run on the stand-in and print, beside the recordings")
    args = parser.parse_args(argv)
    chosen = [s for s in SCENARIOS if not args.only or s.name in args.only.split(",")]
    if args.stub:
        for scenario in chosen:
            with stand_in() as address:
                print(table(run(scenario, address, TRAINER_LEAD["stand-in"])))
            stored = DATA / f"{scenario.name}.json"
            if stored.is_file():
                print("recorded:\n" + table(json.loads(stored.read_text())))
        return 0
    command = find_rcssserver3d()
    DATA.mkdir(parents=True, exist_ok=True)
    for scenario in chosen:
        recording = record(scenario, command)
        (DATA / f"{scenario.name}.json").write_text(json.dumps(recording, indent=1) + "\n")
        print(table(recording))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
