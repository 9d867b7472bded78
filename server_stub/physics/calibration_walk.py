"""The real-server calibration walk, replayed in-process against a ``World``.

``tests/data/rcssserver3d/walk_calibration/README.md`` describes a slow TFS gait and its controller,
walked three times for 15 s on a real rcssserver3d (2.91-3.14 m forward). Running the very same
gait and controller here, with the agent seeing joint angles as the wire shows them (2 decimals)
and its commands taking effect with the server's latency, is how the stub's physics settings are
judged. Kept apart from ``gait/`` on purpose: this is a fixed measuring stick, not the project's
gait, and ``server_stub`` may not import ``gait``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from protocol.nao import CYCLE, JOINTS, SPEED_CAP
from server_stub.physics.robot import Robot
from server_stub.physics.world import World

# Gait parameters of the README (degrees, seconds; "human" convention: flexion positive).
HIP_OFFSET = 15.0
KNEE_OFFSET = 30.0
HIP_AMPLITUDE_FIRST = 10.0  # A, first half period
HIP_AMPLITUDE_SECOND = 10.0  # B, second half period
KNEE_AMPLITUDE = 20.0  # C
PERIOD = 0.4
KNEE_PHASE = 0.35  # t2
#: Controller gain, 1/s, on (target two cycles ahead - perceived angle).
GAIN = 15.0
#: Targets are kept this far inside each joint's limits, degrees.
LIMIT_MARGIN = 0.5
#: Episode shape of the README: beam, hold the start pose 25 cycles (beam again at 12), walk 750.
BEAM = (-10.0, 3.0, 0.0)
HOLD_CYCLES = 25
REBEAM_CYCLE = 12
WALK_CYCLES = 750
#: Physics steps before the real agent's beam took effect: its first perception came after two
#: steps (head at z 1.64 in it), the beam was its reply to the second perception.
CYCLES_BEFORE_BEAM = 3
#: Torso height below which the referee counts a robot as not standing (docs/robot_and_server.md section 8).
FALLEN_HEIGHT = 0.25


def _leg(t: float) -> tuple[float, float, float]:
    """(hip pitch, knee, ankle pitch) NAO targets in degrees for gait time ``t``."""
    w = 2.0 * math.pi / PERIOD
    amplitude = HIP_AMPLITUDE_FIRST if (t % PERIOD) < PERIOD / 2 else HIP_AMPLITUDE_SECOND
    hip = HIP_OFFSET + amplitude * math.sin(w * t)
    knee = KNEE_OFFSET + KNEE_AMPLITUDE * max(0.0, math.sin(w * (t - KNEE_PHASE)))
    return hip, -knee, -(hip - knee)


def targets(t: float) -> dict[str, float]:
    """Every joint's target in degrees by effector name at gait time ``t``, clipped inside limits."""
    goal = {j.effector: 0.0 for j in JOINTS}
    goal["lae1"] = goal["rae1"] = -90.0
    goal["lle3"], goal["lle4"], goal["lle5"] = _leg(t)
    goal["rle3"], goal["rle4"], goal["rle5"] = _leg(t + PERIOD / 2)
    return {j.effector: min(j.max_deg - LIMIT_MARGIN, max(j.min_deg + LIMIT_MARGIN, goal[j.effector])) for j in JOINTS}


def velocities(t: float, perceived: dict[str, float]) -> dict[str, float]:
    """The README's controller: rad/s per effector from perceived angles (degrees, by perceptor)."""
    goal = targets(t + 2 * CYCLE)
    return {
        j.effector: max(-SPEED_CAP, min(SPEED_CAP, math.radians(GAIN * (goal[j.effector] - perceived[j.perceptor]))))
        for j in JOINTS
    }


def _perceive(robot: Robot) -> dict[str, float]:
    """Joint angles as an agent reads them off the wire (2 decimals)."""
    return {name: round(value, 2) for name, value in robot.joint_angles().items()}


def _act(robot: Robot, t: float) -> None:
    for effector, v in velocities(t, _perceive(robot)).items():
        robot.command(effector, round(v, 4))


@dataclass
class WalkResult:
    """What one calibration episode did: displacement over the walk and per-cycle traces."""

    dx: float
    dy: float
    fell: bool
    torso: list[tuple[float, float, float]] = field(default_factory=list)  # per walk cycle
    feet: list[frozenset[str]] = field(default_factory=list)  # FRP keys present per walk cycle


def run(
    world: World,
    robot_type: int = 0,
    *,
    beam: tuple[float, float, float] = BEAM,
    rebeam_cycle: int | None = REBEAM_CYCLE,
    beam_delay: int = 0,
    cycles_before_beam: int = CYCLES_BEFORE_BEAM,
) -> WalkResult:
    """One episode of the README on ``world``: new robot, beam, hold, 15 s walk.

    The keywords perturb the start the way real runs differ: ``beam`` = (x, y, heading deg);
    ``rebeam_cycle`` = hold cycle whose reply repeats the beam (None: no repeat);
    ``beam_delay`` = extra steps before a beam takes effect (0: at the next step, as in the
    README's timing; 1: one step later, as through the stub server's pipelined cycle);
    ``cycles_before_beam`` = physics steps before the first beam is sent.
    """
    robot = world.add_robot(robot_type)
    due: set[int] = set()
    steps = 0

    def step() -> None:
        nonlocal steps
        if steps in due:
            robot.beam(*beam)
        world.step()
        steps += 1

    for _ in range(cycles_before_beam):
        step()
    due.add(steps + beam_delay)
    step()
    for cycle in range(HOLD_CYCLES):
        _act(robot, 0.0)
        if cycle == rebeam_cycle:
            due.add(steps + beam_delay)
        step()
    start = robot.torso_position()
    result = WalkResult(0.0, 0.0, False)
    for cycle in range(WALK_CYCLES):
        _act(robot, cycle * CYCLE)
        step()
        position = robot.torso_position()
        result.torso.append(position)
        result.feet.append(frozenset(robot.foot_pressure()))
        result.fell |= position[2] < FALLEN_HEIGHT
    result.dx = position[0] - start[0]
    result.dy = position[1] - start[1]
    return result
