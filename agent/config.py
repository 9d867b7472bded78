"""Everything an agent run can be told, in one place (the CLI and the optimizer fill it)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from agent.goto import GotoConfig
from agent.localization import Pose


@dataclass(frozen=True)
class AgentConfig:
    host: str = "127.0.0.1"
    port: int = 3100
    team: str = "GALA"
    unum: int = 1
    #: Gait file (``gait.gait_file`` format); None = the shipped default gait.
    gait: Path | None = None
    #: Beam pose (x, y, heading deg; heading 0 faces the opponent goal, +x for the left team).
    beam: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: Sync mode: end every reply with ``(syn)`` (the server waits for it before stepping).
    sync: bool = False
    #: Seconds of walking after the gait starts; None = walk until the server closes.
    duration: float | None = None
    #: Heterogeneous robot type 0-4 (0 = nao.rsg).
    robot_type: int = 0
    #: Start walking at once after settling instead of waiting for PlayOn.
    start_now: bool = False
    #: Cycles spent holding the gait's first pose after the beam before walking may start; 25 as in
    #: the real-server calibration walk, enough for the joints to reach the pose (<= 7 deg/cycle).
    settle_cycles: int = 25
    #: Settle cycle (counted from 0) at which the beam is repeated: moving into the gait pose
    #: shifts the robot, and beam only works before kick-off, so it is done again once the pose
    #: is nearly reached (cycle 12, as in the calibration walk). None: no repeated beam. Earlier or
    #: never, the shipped gait falls on the real server (docs/fidelity.md, "3. ODE's maximal coordinates").
    rebeam_cycle: int | None = 12
    #: Proportional gain of the joint controller, 1/s (calibration walk: 15/s).
    gain: float = 15.0
    #: Targets are taken this many cycles ahead to cover the server's two-cycle action latency.
    lookahead_cycles: int = 2
    #: Fixed targets (deg) of every joint the gait does not drive: arms down, everything else 0.
    posture: dict[str, float] = field(default_factory=lambda: {"lae1": -90.0, "rae1": -90.0})
    #: Seconds to wait for the TCP connection and for each server message.
    timeout: float = 10.0
    #: Sync mode: send a bare ``(syn)`` this often until the first perception arrives (the real
    #: server otherwise answers a silent new agent only after about 2 s). None: never, for a server
    #: known to answer at once (the stub), where a nudge arriving late could make it step early.
    syn_nudge_interval: float | None = 0.01
    #: Dither (rad/s) on every joint velocity command while walking: each command gets its own
    #: uniform draw in +-``command_noise``, from a generator seeded with ``noise_seed``. 0: the gait
    #: exactly. A 15-s walk is a chaotic process; a dither far below anything physical (0.001 rad/s
    #: moves a joint 2e-5 rad a cycle) moves where a walk ends and how far it turns as much as the
    #: real server's own run-to-run spread does. So the same dither and seeds on two servers draw
    #: from each one's spread alike, which is how the fidelity benchmark compares them
    #: (``bench.fidelity``).
    command_noise: float = 0.0
    noise_seed: int = 0
    #: Poses to walk to in order (x, y m, heading deg; field frame), with a steerable gait
    #: (``gait.Steerable``); none: the gait walks its own way (a steerable one straight ahead).
    goals: tuple[Pose, ...] = ()
    #: One command a steerable gait walks from the walk's start on (forward m/s, left m/s, turn
    #: deg/s), for measuring what it does; None: its own (full ahead), or the walk to ``goals``.
    walk_command: tuple[float, float, float] | None = None
    goto: GotoConfig = GotoConfig()
    #: Steer by the server's ``mypos``/``myorien`` where it sends them; False: always by the
    #: agent's own estimate from vision and odometry.
    true_pose: bool = True

    def __post_init__(self) -> None:
        if not self.command_noise >= 0.0:
            raise ValueError(f"command_noise must be >= 0 rad/s, got {self.command_noise}")
        if self.goals and self.walk_command is not None:
            raise ValueError("a walk to poses makes its own commands: give goals or walk_command, not both")
