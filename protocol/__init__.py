"""The wire format of rcssserver3d: framing, S-expressions, perceptions, effector and trainer
commands, the monitor stream. No sockets, no physics; imports nothing from other packages."""

from protocol import commands, trainer
from protocol.errors import FrameTooLarge, ProtocolError
from protocol.framing import MAX_FRAME_SIZE, FrameDecoder, encode_frame
from protocol.monitor import MonitorReader, MonitorState, RobotPose
from protocol.nao import (
    CYCLE,
    JOINT_BY_EFFECTOR,
    JOINT_BY_PERCEPTOR,
    JOINTS,
    NAO_HETERO_RSG,
    NAO_RSG,
    PLAY_MODES,
    SPEED_CAP,
    Joint,
)
from protocol.perception import (
    ForceResistance,
    GameState,
    Hear,
    Perception,
    Polar,
    SeenPlayer,
    Vision,
    parse_perception,
)
from protocol.sexp import parse_sexp

__all__ = [
    "CYCLE",
    "FrameDecoder",
    "FrameTooLarge",
    "ForceResistance",
    "GameState",
    "Hear",
    "JOINT_BY_EFFECTOR",
    "JOINT_BY_PERCEPTOR",
    "JOINTS",
    "Joint",
    "MAX_FRAME_SIZE",
    "MonitorReader",
    "MonitorState",
    "NAO_HETERO_RSG",
    "NAO_RSG",
    "PLAY_MODES",
    "Perception",
    "Polar",
    "ProtocolError",
    "RobotPose",
    "SPEED_CAP",
    "SeenPlayer",
    "Vision",
    "commands",
    "encode_frame",
    "parse_perception",
    "parse_sexp",
    "trainer",
]
