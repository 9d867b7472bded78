"""What the stand-in knows about one agent: its robot, team and number, and the state of its
connection's cycle (kept here so that the socket-free core, ``server_stub.simulation``, and the
socket shell, ``server_stub.net.server``, share one record)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # types only: the network side does not need the physics to load
    from server_stub.physics.robot import Robot
    from server_stub.sensors.vision import VisionSensor


@dataclass
class AgentState:
    """What the server knows about one agent connection's robot."""

    robot: Robot | None = None
    robot_type: int = 0
    side: str | None = None
    team: str | None = None
    unum: int | None = None
    #: the first GS after init carries unum and team (docs/robot_and_server.md section 5)
    announce_identity: bool = False
    #: a perception was sent and no ``(syn)`` has come back since
    awaiting_syn: bool = False
    sent_at: float = 0.0
    #: perception computed after the last step, sent at the next cycle boundary
    next_perception: str | None = None
    #: frames received since the last step, applied after the next perception goes out, and their bytes
    inbox: list[bytes] = field(default_factory=list)
    inbox_bytes: int = 0
    vision: VisionSensor | None = None
