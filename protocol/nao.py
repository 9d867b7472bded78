"""The NAO as the server exposes it on the wire: joint names, limits, speed cap, timing.

These are the facts every package needs to agree on (the agent to command joints, the gait to
clamp targets through the agent, the stub to enforce the same rules), so they live here once.
Source of every number: ``docs/robot_and_server.md`` (rcssserver3d 0.7.3 / SimSpark 0.3.2).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Joint:
    """One hinge joint: the effector name commands it, the perceptor name reports it (degrees)."""

    effector: str
    perceptor: str
    min_deg: float
    max_deg: float


#: All 22 hinge joints of robot type 0, in the order the server sends their ``HJ`` perceptors
#: (docs/robot_and_server.md section 5); limits from section 3's table.
JOINTS: tuple[Joint, ...] = (
    Joint("he1", "hj1", -120.0, 120.0),
    Joint("he2", "hj2", -45.0, 45.0),
    Joint("rae1", "raj1", -120.0, 120.0),
    Joint("rae2", "raj2", -95.0, 1.0),
    Joint("rae3", "raj3", -120.0, 120.0),
    Joint("rae4", "raj4", -1.0, 90.0),
    Joint("lae1", "laj1", -120.0, 120.0),
    Joint("lae2", "laj2", -1.0, 95.0),
    Joint("lae3", "laj3", -120.0, 120.0),
    Joint("lae4", "laj4", -90.0, 1.0),
    Joint("rle1", "rlj1", -90.0, 1.0),
    Joint("rle2", "rlj2", -45.0, 25.0),
    Joint("rle3", "rlj3", -25.0, 100.0),
    Joint("rle4", "rlj4", -130.0, 1.0),
    Joint("rle5", "rlj5", -45.0, 75.0),
    Joint("rle6", "rlj6", -25.0, 45.0),
    Joint("lle1", "llj1", -90.0, 1.0),
    Joint("lle2", "llj2", -25.0, 45.0),
    Joint("lle3", "llj3", -25.0, 100.0),
    Joint("lle4", "llj4", -130.0, 1.0),
    Joint("lle5", "llj5", -45.0, 75.0),
    Joint("lle6", "llj6", -45.0, 25.0),
)

#: The toe joints of robot type 4 (naolegtoe.rsg: rle7 / rlj7 and lle7 / llj7, foot -> toe, both
#: -1 to 70 deg, not mirrored; docs/robot_and_server.md section 3, "Robot type 4"). A robot with
#: toes has them after the 22 joints, so every joint keeps its ``JOINTS`` index on every type.
TOE_JOINTS: tuple[Joint, ...] = (
    Joint("rle7", "rlj7", -1.0, 70.0),
    Joint("lle7", "llj7", -1.0, 70.0),
)
#: Heterogeneous types that have toes (nao_hetero.rsg's UseToe; naorobottypes.rb).
TOE_ROBOT_TYPES: frozenset[int] = frozenset({4})


def joints_of(robot_type: int) -> tuple[Joint, ...]:
    """Every hinge joint of a robot of ``robot_type``, in the index order the server, the agent and
    the physics share: ``JOINTS``, then ``TOE_JOINTS`` for a type with toes."""
    return JOINTS + TOE_JOINTS if robot_type in TOE_ROBOT_TYPES else JOINTS


#: Every joint of any robot type by effector name.
JOINT_BY_EFFECTOR: dict[str, Joint] = {j.effector: j for j in JOINTS + TOE_JOINTS}


def _perceptors(first: str, last: str) -> tuple[str, ...]:
    names = [j.perceptor for j in JOINTS]
    return tuple(names[names.index(first) : names.index(last) + 1])


#: The joint perceptors of one perception message in blocks, in the order the server prints them
#: (docs/robot_and_server.md section 5); between the blocks come, in turn, ``See`` (every third
#: cycle), ``FRP rf`` and ``FRP lf`` (each only while that foot touches something). The parser
#: and the stand-in's printer both read the layout from here.
HJ_BEFORE_SEE: tuple[str, ...] = _perceptors("hj1", "hj2")
HJ_BEFORE_FRP_RF: tuple[str, ...] = _perceptors("raj1", "rlj5")
HJ_BEFORE_FRP_LF: tuple[str, ...] = _perceptors("rlj6", "llj5")
HJ_LAST: tuple[str, ...] = _perceptors("llj6", "llj6")
#: Every joint of any robot type by perceptor name.
JOINT_BY_PERCEPTOR: dict[str, Joint] = {j.perceptor: j for j in JOINTS + TOE_JOINTS}


@dataclass(frozen=True)
class PerceptionLayout:
    """Where a robot type's joint perceptors sit in its perception message: ``blocks`` of ``HJ``
    names in the order the server prints them; between the first two comes ``See`` (every third
    cycle), between each later pair one ``FRP`` of ``feet`` in turn (each only while that part
    touches something). The server walks the robot's body tree (docs/robot_and_server.md section 5)."""

    blocks: tuple[tuple[str, ...], ...]
    feet: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.blocks) != len(self.feet) + 2:
            raise ValueError(f"{len(self.blocks)} blocks need {len(self.blocks) - 2} FRPs between them")


#: Types 0-3: See, FRP rf, FRP lf between the blocks.
LAYOUT = PerceptionLayout((HJ_BEFORE_SEE, HJ_BEFORE_FRP_RF, HJ_BEFORE_FRP_LF, HJ_LAST), ("rf", "lf"))
#: A robot with toes: each toe's body follows its foot's in the tree (naolegtoe.rsg), so its
#: ``FRP`` (rf1, lf1) and its joint (rlj7, llj7) follow the ankle roll: ... FRP rf, rlj6, FRP rf1,
#: rlj7, llj1 ... llj5, FRP lf, llj6, FRP lf1, llj7.
TOE_LAYOUT = PerceptionLayout(
    (HJ_BEFORE_SEE, HJ_BEFORE_FRP_RF, ("rlj6",), ("rlj7", *HJ_BEFORE_FRP_LF[1:]), HJ_LAST, ("llj7",)),
    ("rf", "rf1", "lf", "lf1"),
)


def perception_layout(robot_type: int) -> PerceptionLayout:
    """The perception layout of a robot of ``robot_type``."""
    return TOE_LAYOUT if robot_type in TOE_ROBOT_TYPES else LAYOUT


#: Hinge motor speed cap in rad/s (section 3; observed 7.03 deg per 0.02 s cycle).
SPEED_CAP: float = 6.1395
#: Motor torque limit of every hinge, N m (section 3).
TORQUE_LIMIT: float = 10.0
#: One agent cycle = one perception = one physics step, seconds (section 4).
CYCLE: float = 0.02
#: Cycles between a reply and the first perception that shows its effect (section 4, observed).
ACTION_LATENCY_CYCLES: int = 2

NAO_RSG: str = "rsg/agent/nao/nao.rsg"
NAO_HETERO_RSG: str = "rsg/agent/nao/nao_hetero.rsg"
#: Heterogeneous robot types the server offers (section 3); type 0 is nao.rsg.
ROBOT_TYPES: tuple[int, ...] = (0, 1, 2, 3, 4)

#: Play-mode names in the monitor's index order (section 9).
PLAY_MODES: tuple[str, ...] = (
    "BeforeKickOff",
    "KickOff_Left",
    "KickOff_Right",
    "PlayOn",
    "KickIn_Left",
    "KickIn_Right",
    "corner_kick_left",
    "corner_kick_right",
    "goal_kick_left",
    "goal_kick_right",
    "offside_left",
    "offside_right",
    "GameOver",
    "Goal_Left",
    "Goal_Right",
    "free_kick_left",
    "free_kick_right",
    "direct_free_kick_left",
    "direct_free_kick_right",
    "pass_left",
    "pass_right",
)
#: Play modes in which ``beam`` is honoured (section 6).
BEAM_PLAY_MODES: frozenset[str] = frozenset({"BeforeKickOff", "Goal_Left", "Goal_Right"})
