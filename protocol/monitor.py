"""Reader of the monitor stream (server -> monitor, port 3200): game state and robot torso poses.

Grammar read (docs/robot_and_server.md section 9)::

    message := '(' header* ')' [ '(RSG 0 1)' scene | '(RDS 0 1)' delta ]
    header  := '(' <name> <value>* ')'     full: FieldLength ... play_modes time [team_left]
                                            [team_right] half score_left score_right play_mode;
                                            delta: time and only what changed
    scene   := '(' node* ')'
    node    := '(nd' [<kind>] ('(SLT' m0 ... m15 ')' | '(' <name> <value>* ')' | node)* ')'
    delta   := the same nodes in the same depth-first order as bare '(nd' ... ')', a transform
               carrying '(SLT ...)' only if it moved

A full scene is read token by token once (it comes on connect and when robots appear or leave).
A delta is not parsed into a tree: the reader steps over ``(nd`` openings with ``str.find`` to
the torsos' nodes and decodes only their ``SLT``s.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from protocol.errors import ProtocolError
from protocol.nao import PLAY_MODES
from protocol.sexp import decode_ascii

Vec3 = tuple[float, float, float]


@dataclass(slots=True)
class RobotPose:
    """One robot's torso. ``team`` is ``'left'``/``'right'`` and ``unum`` the shirt number, both
    None until ``init`` set them; ``up``/``forward`` are the torso's axes in world coordinates."""

    team: str | None
    unum: int | None
    robot_type: int | None
    position: Vec3
    up: Vec3
    forward: Vec3


@dataclass(slots=True)
class MonitorState:
    """Game state after a message; ``robots`` in scene order."""

    game_time: float
    play_mode: str
    half: int
    score_left: int
    score_right: int
    team_left: str | None
    team_right: str | None
    robots: list[RobotPose]


_SCENE_MARK = re.compile(r"\((RSG|RDS) \d+ \d+\)")
_HEADER = re.compile(r"\((?:\(\w+(?: [^\s()]+)*\))*\)")
_PREDICATE = re.compile(r"\((\w+)((?: [^\s()]+)*)\)")
_SCENE_TOKEN = re.compile(r"\((nd|SLT|load|resetMaterials)?([^()]*)|\)")
_BODY_MESH = re.compile(r"models/naobody(\d+)\.obj")
_MATERIAL_NUMBER = re.compile(r"matNum(\d*)")
_MATERIAL_SIDE = {"matLeft": "left", "matRight": "right"}


class _Robot:
    """What the reader keeps per robot between messages."""

    __slots__ = ("torso", "team", "unum", "robot_type", "pose")

    def __init__(self, torso: int, team: str | None, unum: int | None, robot_type: int) -> None:
        self.torso = torso
        self.team = team
        self.unum = unum
        self.robot_type = robot_type
        self.pose: tuple[Vec3, Vec3, Vec3] = ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0))


def _pose(slt: str, position: int) -> tuple[Vec3, Vec3, Vec3]:
    """Translation (m12, m13, m14), up (m8, m9, m10) and forward (m4, m5, m6) axes of a
    column-major 4x4 ``SLT``; the robot parts' parents are the identity, so this is the world pose."""
    m = slt.split()
    if len(m) != 16:
        raise ProtocolError(position, "16 numbers in (SLT ...)", f"{len(m)} values")
    try:
        return (
            (float(m[12]), float(m[13]), float(m[14])),
            (float(m[8]), float(m[9]), float(m[10])),
            (float(m[4]), float(m[5]), float(m[6])),
        )
    except ValueError:
        raise ProtocolError(position, "numbers in (SLT ...)", slt) from None


class MonitorReader:
    """Follows the monitor stream: full scenes (RSG) and the deltas (RDS) that refer to them.

    Feed every message in order; each call returns the state after it.
    """

    def __init__(self) -> None:
        self._play_modes: list[str] = list(PLAY_MODES)
        self._game_time = 0.0
        self._play_mode = 0
        self._half = 1
        self._score_left = 0
        self._score_right = 0
        self._team_left: str | None = None
        self._team_right: str | None = None
        self._node_count: int | None = None
        self._robots: list[_Robot] = []
        self._torsos: list[tuple[int, _Robot]] = []  # by node index, the order deltas list them

    def feed(self, msg: str | bytes) -> MonitorState:
        """Read one monitor message (grammar in the module docstring)."""
        text = decode_ascii(msg)
        mark = _SCENE_MARK.search(text)
        header_end = len(text) if mark is None else mark.start()
        if _HEADER.fullmatch(text, 0, header_end) is None:
            raise ProtocolError(0, "a header '((<name> <value>...)...)' before (RSG/RDS ...)", text[:40])
        for name, values in _PREDICATE.findall(text, 1, header_end):
            self._header_predicate(name, values.split(), text)
        if mark is not None:
            if mark.group(1) == "RSG":
                self._read_full_scene(text, mark.end())
            else:
                self._apply_delta(text, mark.end())
        return self.state

    @property
    def state(self) -> MonitorState:
        """The current state (a fresh object; feeding later messages does not change it)."""
        play_mode = self._play_modes[self._play_mode]
        robots = [RobotPose(r.team, r.unum, r.robot_type, *r.pose) for r in self._robots]
        return MonitorState(
            self._game_time,
            play_mode,
            self._half,
            self._score_left,
            self._score_right,
            self._team_left,
            self._team_right,
            robots,
        )

    def _header_predicate(self, name: str, values: list[str], text: str) -> None:
        """``(<name> <value>...)``; field sizes and rule constants are not kept."""
        try:
            if name == "time":
                self._game_time = float(values[0])
            elif name == "play_mode":
                index = int(values[0])
                if not 0 <= index < len(self._play_modes):
                    raise ValueError(index)
                self._play_mode = index
            elif name == "play_modes":
                self._play_modes = values
            elif name == "half":
                self._half = int(values[0])
            elif name == "score_left":
                self._score_left = int(values[0])
            elif name == "score_right":
                self._score_right = int(values[0])
            elif name == "team_left":
                self._team_left = values[0]
            elif name == "team_right":
                self._team_right = values[0]
        except (ValueError, IndexError):
            at = text.find(f"({name}")
            raise ProtocolError(at, f"a valid value for header {name}", " ".join(values)) from None

    def _read_full_scene(self, text: str, start: int) -> None:
        """Walk every token of a full scene once: node parents, transforms, meshes, materials."""
        parents: list[int] = []
        slts: dict[int, tuple[str, int]] = {}
        meshes: list[tuple[int, int, list[str]]] = []  # (node, robot type, materials)
        open_kinds: list[int] = []  # per open '(': its node index, or -1 if not a node
        nodes: list[int] = [-1]  # innermost open node
        for token in _SCENE_TOKEN.finditer(text, start):
            if token.group() == ")":
                if not open_kinds:
                    raise ProtocolError(token.start(), "'(' before this ')' (unbalanced scene)", ")")
                if open_kinds.pop() >= 0:
                    nodes.pop()
                continue
            keyword = token.group(1)
            if keyword == "nd":
                index = len(parents)
                parents.append(nodes[-1])
                open_kinds.append(index)
                nodes.append(index)
                continue
            open_kinds.append(-1)
            if keyword == "SLT":
                slts[nodes[-1]] = (token.group(2), token.start())
            elif keyword == "load":
                body = _BODY_MESH.search(token.group(2))
                if body is not None:
                    meshes.append((nodes[-1], int(body.group(1)), []))
            elif keyword == "resetMaterials" and meshes and meshes[-1][0] == nodes[-1]:
                meshes[-1][2].extend(token.group(2).split())
        if open_kinds:
            raise ProtocolError(len(text), "')' (the full scene ends inside a node)", "end of message")
        self._node_count = len(parents)
        self._robots = [
            self._robot(node, robot_type, materials, parents, slts) for node, robot_type, materials in meshes
        ]
        self._torsos = sorted(((robot.torso, robot) for robot in self._robots), key=lambda item: item[0])

    @staticmethod
    def _robot(
        mesh: int, robot_type: int, materials: list[str], parents: list[int], slts: dict[int, tuple[str, int]]
    ) -> _Robot:
        """The torso is the mesh's grandparent transform (the parent holds a display rotation)."""
        torso = parents[parents[mesh]] if parents[mesh] >= 0 else -1
        if torso < 0 or torso not in slts:
            raise ProtocolError(None, f"a transform two levels above the naobody{robot_type} mesh node")
        team = next((_MATERIAL_SIDE[m] for m in materials if m in _MATERIAL_SIDE), None)
        unum = None
        for material in materials:
            number = _MATERIAL_NUMBER.fullmatch(material)
            if number is not None and number.group(1):
                unum = int(number.group(1))
        robot = _Robot(torso, team, unum, robot_type)
        robot.pose = _pose(*slts[torso])
        return robot

    def _apply_delta(self, text: str, start: int) -> None:
        """Give each torso the ``(SLT ...)`` that follows its node's opening, if any.

        Nodes are found by counting ``(nd`` openings with ``str.find`` up to the last torso, and
        a transform's ``SLT`` is the first one before the next opening; nothing else of the delta
        is read. The node count is not required to match the last full scene: a monitor that
        missed messages (``monitor_full_run.txt`` has a cut after line 1) sees a delta for a scene
        that lost a trailing node, and index order still holds for the nodes before the change.
        Only balance is checked, which catches truncation.
        """
        if self._node_count is None:
            raise ProtocolError(start, "a full scene (RSG) before the first delta (RDS)")
        opened = text.count("(", start)
        closed = text.count(")", start)
        if opened != closed:
            raise ProtocolError(len(text), f"{opened - closed} more ')' to balance the delta", "end of message")
        node, at = -1, start - 3
        for torso, robot in self._torsos:
            while node < torso:
                at = text.find("(nd", at + 3)
                if at < 0:
                    return
                node += 1
            following = text.find("(nd", at + 3)
            slt = text.find("(SLT ", at + 3, len(text) if following < 0 else following)
            if slt >= 0:
                robot.pose = _pose(text[slt + 5 : text.find(")", slt)], slt)
