"""The monitor stream (port 3200): game-state header plus the scene graph, full or as a delta.

Shapes copied from the real server's traffic (docs/robot_and_server.md section 9; ``monitor_messages.txt``)::

    full:  (<header>)(RSG 0 1)(<node>...)
    delta: ((time <t>)<changed header items><fouls>)(RDS 0 1)(<node>...)
    header := (FieldLength 30)...(PassModeDuration 4)(play_modes <name>...)(time <t>)
              [(team_left <name>)][(team_right <name>)](half <n>)(score_left <n>)(score_right <n>)
              (play_mode <index>)<fouls>
    fouls  := (foul <index> <type> <team> <number>)...   (those recorded since the last message)
    node (full)  := (nd TRF (SLT m0 ... m15)<node>...) | (nd StaticMesh <props>) | (nd SMN <props>)
                  | (nd Light <props>)
    node (delta) := (nd[ (SLT m0 ... m15)]<node>...) | (nd StaticMesh) | (nd SMN) | (nd)

A delta lists the same nodes in the same depth-first order, stripped; a transform carries its
``SLT`` only when one of its 16 numbers moved by more than 0.005 since it was last sent. ``SLT``
is column-major, numbers printed with 6 significant digits (``%g``, as the server's float output;
the moving transforms' by the compiled ``server_stub.sensors.number_text``, the same characters).

The static part is a small stand-in for the real one (lights, field, goals, corner flags), the same
shape but fewer meshes. Each robot is one identity transform holding one transform per body part
whose ``SLT`` is that part's world pose; the torso is found as on the real server: the transform
whose grandchild is the mesh ``models/naobody<type>.obj`` (the child holds a fixed display
rotation). A full scene is needed whenever the robot set or a robot's team/number/type changes
(materials change); ``needs_full`` tells, ``delta`` refuses otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from protocol.nao import PLAY_MODES, TOE_ROBOT_TYPES
from server_stub import field as soccer_field
from server_stub.config import RefereeConfig
from server_stub.physics import nao_model
from server_stub.sensors.number_text import g_rows

Vec3 = tuple[float, float, float]


#: The referee's rules, whose values the monitor header also reports.
_RULES = RefereeConfig()


@dataclass(frozen=True)
class MonitorConfig:
    """Fixed header values of the real server's default configuration (naosoccersim.rb), and the
    delta threshold of the scene (docs/robot_and_server.md section 9)."""

    field_length: float = soccer_field.LENGTH
    field_width: float = soccer_field.WIDTH
    field_height: float = soccer_field.HEIGHT
    goal_width: float = soccer_field.GOAL_WIDTH
    goal_depth: float = soccer_field.GOAL_DEPTH
    goal_height: float = soccer_field.GOAL_HEIGHT
    border_size: float = 0
    free_kick_distance: float = _RULES.free_kick_distance
    wait_before_kick_off: float = 30
    agent_radius: float = 0.4
    ball_radius: float = soccer_field.BALL_RADIUS
    ball_mass: float = soccer_field.BALL_MASS
    rule_goal_pause_time: float = _RULES.goal_pause_time
    rule_kick_in_pause_time: float = _RULES.kick_in_pause_time
    rule_half_time: float = _RULES.half_time
    pass_mode_min_opp_ball_dist: float = 1
    pass_mode_duration: float = 4
    slt_threshold: float = 0.005


@dataclass(frozen=True)
class GameHeader:
    """The changing part of the header. ``play_mode`` by name (sent as its ``PLAY_MODES`` index)."""

    time: float
    play_mode: str
    half: int = 1
    score_left: int = 0
    score_right: int = 0
    team_left: str | None = None
    team_right: str | None = None
    #: the referee's fouls recorded since the last message, as ``(foul ...)`` items
    fouls: tuple[str, ...] = ()


@dataclass(frozen=True)
class RobotView:
    """One robot for the monitor. ``team`` is the side ('left'/'right', None before ``init``);
    ``part_names`` as in ``server_stub.physics.nao_model``, torso included; ``poses`` (n x 4 x 4) their
    world poses in that order, columns = the part's right, forward, up axes and centre."""

    team: str | None
    unum: int | None
    robot_type: int
    part_names: Sequence[str]
    poses: np.ndarray


# ---------------------------------------------------------------------------------------------
# Fixed nodes: each rendered once, full and stripped.


@dataclass(frozen=True)
class _Node:
    full: str
    delta: str


def _slt(values: Sequence[float] | np.ndarray) -> str:
    return _SLT_FMT % tuple(values)


_SLT_FMT = "(SLT " + " ".join(["%g"] * 16) + ")"
_IDENTITY = np.eye(4)
#: Display rotation the real server puts between a torso/head transform and its mesh (observed).
_DISPLAY = "(SLT -1 3.82137e-15 8.74228e-08 -0 8.74228e-08 4.37114e-08 1 0 0 1 -4.37114e-08 0 0 0 0 1)"


def _translation(x: float, y: float, z: float) -> str:
    return _slt((1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, y, z, 1))


def _trf(slt: str, *children: _Node) -> _Node:
    return _Node(f"(nd TRF {slt}{''.join(c.full for c in children)})", f"(nd{''.join(c.delta for c in children)})")


def _mesh(model: str, scale: Vec3 | float, materials: Sequence[str], transparent: bool = False) -> _Node:
    extra = " (setTransparent)" if transparent else ""
    sx, sy, sz = scale if isinstance(scale, tuple) else (scale, scale, scale)
    return _Node(
        f"(nd StaticMesh (setVisible 1){extra} (load {model}) (sSc {sx:g} {sy:g} {sz:g})"
        f"(resetMaterials {' '.join(materials)}))",
        "(nd StaticMesh)",
    )


def _smn(load: str, scale: Vec3, material: str, visible: bool = True, transparent: bool = False) -> _Node:
    extra = " (setTransparent)" if transparent else ""
    sx, sy, sz = scale
    return _Node(
        f"(nd SMN (setVisible {int(visible)}){extra} (load {load}) (sSc {sx:g} {sy:g} {sz:g}) (sMat {material}))",
        "(nd SMN)",
    )


def _light(ambient: float) -> _Node:
    return _Node(
        f"(nd Light (setDiffuse 1 1 1 1) (setAmbient {ambient:g} {ambient:g} {ambient:g} 1)"
        " (setSpecular 0.1 0.1 0.1 1))",
        "(nd)",
    )


def _static_scene() -> _Node:
    """Lights, field, goals and corner flags, the way the real scene opens (shortened)."""
    field_rot = "(SLT -1 -8.74228e-08 -3.82137e-15 0 0 -4.37114e-08 1 0 -8.74228e-08 1 4.37114e-08 -0 0 0 0 1)"
    goal_rot = "(SLT -4.37114e-08 1 4.37114e-08 0 0 -4.37114e-08 1 0 1 4.37114e-08 1.91069e-15 0 0.3 0 -0.4 1)"
    nodes = [
        _trf(_translation(-10, 10, 10), _light(0.8)),
        _trf(_translation(10, -10, 10), _light(0)),
        _trf(field_rot, _mesh("models/naosoccerfield.obj", (2.5, 1, 2.5), ["None_rcs-naofield.png"])),
        _trf(
            _translation(-15.3, 0, 0.4),
            _trf(goal_rot, _mesh("models/leftsoccergoal.obj", (2.18, 0.88, 0.68), ["naogoalnet", "yellow"], True)),
        ),
        _trf(
            _slt((-1, -8.74228e-08, -0.0, -0.0, 8.74228e-08, -1, 0, 0, 0, 0, 1, 0, 15.3, 0, 0.4, 1)),
            _trf(goal_rot, _mesh("models/rightsoccergoal.obj", (2.18, 0.88, 0.68), ["naogoalnet", "sky-blue"], True)),
        ),
    ]
    nodes += [_trf(_translation(x, y, 0)) for x, y in ((-15, 10), (-15, -10), (15, 10), (15, -10))]
    return _Node("".join(n.full for n in nodes), "".join(n.delta for n in nodes))


_STATIC = _static_scene()
_BALL_CHILD = _mesh("models/soccerball.obj", soccer_field.BALL_RADIUS, ["soccerball_rcs-soccerball.png"])


def _part_children(part: str, team: str | None, unum: int | None, robot_type: int) -> _Node:
    """The mesh under one body part's transform, materials as the real server sets them."""
    mat_team = {"left": "matLeft", "right": "matRight"}.get(team or "", "matTeam")
    mat_num = "matNum" if unum is None else f"matNum{unum}"
    mat_type = f"matType{robot_type}"
    side, kind = part[0], part[1:]
    if part == "torso":
        body = _mesh(f"models/naobody{robot_type}.obj", 0.1, [mat_num, mat_team, mat_type, "naowhite"])
        select = _smn("StdUnitCylinder 1 1", (0.2, 0.2, 0.02), "matSelect", visible=False, transparent=True)
        nodes = [_trf(_DISPLAY, body), _trf(_slt(_IDENTITY.T.ravel()), select)]
    elif part == "neck":
        nodes = [_smn("StdCapsule 0.015 0.08", (1, 1, 1), "matDarkGrey")]
    elif part == "head":
        nodes = [_trf(_DISPLAY, _mesh("models/naohead.obj", 0.1, [mat_team, "naoblack", "naogrey", "naowhite"]))]
    elif side in "rl" and kind in ("shoulder", "elbow", "hip1", "hip2", "ankle"):
        nodes = [_smn("StdUnitSphere", (0.01, 0.01, 0.01), "matRed" if kind == "ankle" else "matYellow")]
    elif side in "rl" and kind in ("upperarm", "shank"):
        scale = 0.07 if kind == "upperarm" else 0.08
        nodes = [_mesh(f"models/{part}{robot_type}.obj", scale, [mat_team, mat_type, "naowhite"])]
    elif side in "rl" and kind in ("foot", "toe") and robot_type in TOE_ROBOT_TYPES:
        nodes = [_mesh(f"models/{side}foot.obj", _toe_type_scale(kind, robot_type), [mat_team, "naowhite"])]
    elif side in "rl" and kind in ("lowerarm", "thigh", "foot"):
        scale = {"lowerarm": 0.05, "thigh": 0.07, "foot": 0.08}[kind]
        numbered = [mat_num] if part == "rthigh" else []
        nodes = [_mesh(f"models/{part}.obj", scale, numbered + [mat_team, "naowhite"])]
    else:
        raise ValueError(f"unknown NAO body part {part!r} for the monitor scene")
    return _Node("".join(n.full for n in nodes), "".join(n.delta for n in nodes))


def _toe_type_scale(kind: str, robot_type: int) -> Vec3:
    """The foot mesh's scale on a foot or toe of a type with toes (naolegtoe.rsg; measured on the
    real server: foot 0.08 0.062241 0.08, toe 0.08 0.0228259 0.04): the foot's by its length of
    the full 0.16 m, the toe's by its length of the foot's and its thickness of the foot's."""
    parts = {p.name: p for p in nao_model.body_parts(robot_type)}
    width, foot_length, foot_height = parts["rfoot"].size
    if kind == "foot":
        return (width, width * foot_length / _FULL_FOOT_LENGTH, width)
    _, toe_length, toe_height = parts["rtoe"].size
    return (width, width * toe_length / foot_length, width * toe_height / foot_height)


#: The type-0 foot's length (docs/robot_and_server.md section 2), to which the foot mesh is made.
_FULL_FOOT_LENGTH = 0.16


# ---------------------------------------------------------------------------------------------
# Moving transforms: a group of TRFs whose SLT is resent only when it moved.


@dataclass
class _Movers:
    """Transforms with fixed children; remembers what each last sent (column-major rows)."""

    children: list[_Node]
    threshold: float
    sent: np.ndarray = field(default_factory=lambda: np.empty((0, 16)))

    def full(self, poses: np.ndarray) -> str:
        self.sent = poses.copy()
        return "".join(f"(nd TRF (SLT {numbers}){c.full})" for numbers, c in zip(g_rows(poses), self.children))

    def __post_init__(self) -> None:
        self._still = "".join(f"(nd{c.delta})" for c in self.children)

    def delta(self, poses: np.ndarray) -> str:
        moved = np.abs(poses - self.sent).max(axis=1) > self.threshold
        if not moved.any():
            return self._still
        self.sent[moved] = poses[moved]
        numbers = iter(g_rows(poses[moved]))
        return "".join(
            f"(nd (SLT {next(numbers)}){c.delta})" if m else f"(nd{c.delta})"
            for m, c in zip(moved.tolist(), self.children)
        )


def _column_major(poses: np.ndarray) -> np.ndarray:
    return poses.transpose(0, 2, 1).reshape(-1, 16)


def _ball_pose(ball: Vec3) -> np.ndarray:
    x, y, z = ball
    return np.array([[1.0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, y, z, 1]])


class MonitorScene:
    """The monitor stream of one server. Call ``full`` on a monitor's connect and whenever
    ``needs_full`` says the robot set changed, ``delta`` otherwise (every 0.04 s)."""

    def __init__(self, config: MonitorConfig = MonitorConfig()) -> None:
        self._cfg = config
        c = config
        fixed = (
            ("FieldLength", c.field_length),
            ("FieldWidth", c.field_width),
            ("FieldHeight", c.field_height),
            ("GoalWidth", c.goal_width),
            ("GoalDepth", c.goal_depth),
            ("GoalHeight", c.goal_height),
            ("BorderSize", c.border_size),
            ("FreeKickDistance", c.free_kick_distance),
            ("WaitBeforeKickOff", c.wait_before_kick_off),
            ("AgentRadius", c.agent_radius),
            ("BallRadius", c.ball_radius),
            ("BallMass", c.ball_mass),
            ("RuleGoalPauseTime", c.rule_goal_pause_time),
            ("RuleKickInPauseTime", c.rule_kick_in_pause_time),
            ("RuleHalfTime", c.rule_half_time),
            ("PassModeMinOppBallDist", c.pass_mode_min_opp_ball_dist),
            ("PassModeDuration", c.pass_mode_duration),
        )
        self._fixed_header = "".join(f"({k} {v:g})" for k, v in fixed) + f"(play_modes {' '.join(PLAY_MODES)})"
        self._sent_header: dict[str, object] = {}
        self._ball = _Movers([_BALL_CHILD], c.slt_threshold)
        self._robots: list[_Movers] = []
        self._keys: list[tuple] = []

    @staticmethod
    def _key(robot: RobotView) -> tuple:
        return (robot.team, robot.unum, robot.robot_type, tuple(robot.part_names))

    def needs_full(self, robots: Sequence[RobotView]) -> bool:
        """True when the robots (or their team, number, type, parts) differ from the last full."""
        return [self._key(r) for r in robots] != self._keys

    def _header_values(self, header: GameHeader) -> dict[str, object]:
        return {
            "team_left": header.team_left,
            "team_right": header.team_right,
            "half": header.half,
            "score_left": header.score_left,
            "score_right": header.score_right,
            "play_mode": PLAY_MODES.index(header.play_mode),
        }

    def full(self, header: GameHeader, robots: Sequence[RobotView], ball: Vec3) -> str:
        """Full header, ``(RSG 0 1)``, the whole scene; resets what deltas compare against."""
        values = self._header_values(header)
        self._sent_header = values
        items = "".join(f"({k} {v})" for k, v in values.items() if v is not None)
        self._robots = [
            _Movers(
                [_part_children(name, r.team, r.unum, r.robot_type) for name in r.part_names], self._cfg.slt_threshold
            )
            for r in robots
        ]
        self._keys = [self._key(r) for r in robots]
        scene = [_STATIC.full, self._ball.full(_ball_pose(ball))]
        for movers, robot in zip(self._robots, robots):
            scene.append(f"(nd TRF {_slt(_IDENTITY.T.ravel())}{movers.full(_column_major(robot.poses))})")
        fouls = "".join(header.fouls)
        return f"({self._fixed_header}(time {header.time:g}){items}{fouls})(RSG 0 1)({''.join(scene)})"

    def delta(self, header: GameHeader, robots: Sequence[RobotView], ball: Vec3) -> str:
        """``(time)`` plus changed header items, ``(RDS 0 1)``, the stripped scene.
        Raises ``ValueError`` if the robot set changed since the last ``full``."""
        if self.needs_full(robots):
            raise ValueError("the robots changed since the last full scene; send MonitorScene.full")
        values = self._header_values(header)
        changed = "".join(f"({k} {v})" for k, v in values.items() if v is not None and v != self._sent_header.get(k))
        self._sent_header = values
        scene = [_STATIC.delta, self._ball.delta(_ball_pose(ball))]
        for movers, robot in zip(self._robots, robots):
            scene.append(f"(nd{movers.delta(_column_major(robot.poses))})")
        return f"((time {header.time:g}){changed}{''.join(header.fouls)})(RDS 0 1)({''.join(scene)})"
