"""Where the referee moves robots in each play mode (rcssserver3d's SoccerRuleAspect: ClearPlayers,
ClearPlayersBeforeKickOff, RepelPlayers): out of the other half before and at a kick-off, away
from the spot of a kick the other side takes, out of the kicker's penalty area at a goal kick.

A moved robot keeps its height and orientation, its velocities zeroed (``Robot.place``), as the
real server translates all of a robot's bodies. A robot's extent is its torso box (``footprint``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

from server_stub import field
from server_stub.agent_state import AgentState
from server_stub.config import RefereeConfig
from server_stub.physics.robot import Robot
from server_stub.referee.areas import HALVES, PENALTY_AREAS, Rect, footprint, other


def _robots(agents: Sequence[AgentState], side: str) -> Iterator[Robot]:
    for state in agents:
        if state.side == side and state.robot is not None:
            yield state.robot


def _move_x(robot: Robot, x: float) -> None:
    _, y, z = robot.torso_position()
    robot.place(x, y, z)


def clear_half(agents: Sequence[AgentState], side: str, config: RefereeConfig) -> None:
    """``side``'s robots reaching into the other half go to ``free_kick_move_dist`` behind the
    centre line (a left robot beamed to (0, 0) stands at x = -2.5)."""
    sign = -1.0 if side == "left" else 1.0
    for robot in _robots(agents, side):
        if footprint(robot).intersects(HALVES[other(side)]):
            _move_x(robot, sign * config.free_kick_move_dist)


def clear_circle(agents: Sequence[AgentState], side: str, spot: tuple[float, float], config: RefereeConfig) -> None:
    """``side``'s robots within ``free_kick_distance`` of ``spot`` are put ``free_kick_move_dist``
    from it towards their own goal (along the goal line if that would leave the field)."""
    sx, sy = spot
    sign = -1.0 if side == "left" else 1.0
    move = config.free_kick_move_dist
    for robot in _robots(agents, side):
        if not footprint(robot).near(sx, sy, config.free_kick_distance):
            continue
        x, y, z = robot.torso_position()
        if abs(sx + sign * move) > field.HALF_LENGTH:  # behind its own goal line
            robot.place(x, sy + move if sy < 0 else sy - move, z)
        else:
            robot.place(sx + sign * move, y, z)


def clear_for_kick_off(agents: Sequence[AgentState], kicker: str, config: RefereeConfig) -> None:
    """At a kick-off (and in the goal pause before it): the other side out of the kicker's half
    and out of the centre circle; the kicker's robots out of the other half unless wholly inside
    the centre circle."""
    defender = other(kicker)
    clear_half(agents, defender, config)
    clear_circle(agents, defender, (0.0, 0.0), config)
    sign = -1.0 if kicker == "left" else 1.0
    for robot in _robots(agents, kicker):
        rect = footprint(robot)
        if rect.intersects(HALVES[defender]) and not rect.within_circle(config.free_kick_distance):
            _move_x(robot, sign * config.free_kick_move_dist)


def clear_penalty_area(agents: Sequence[AgentState], kicker: str, config: RefereeConfig) -> None:
    """At ``kicker``'s goal kick, the other side's robots leave its penalty area, to
    ``free_kick_move_dist`` in front of it (x = +-10.7)."""
    area: Rect = PENALTY_AREAS[kicker]
    for robot in _robots(agents, other(kicker)):
        if footprint(robot).intersects(area):
            if kicker == "left":
                _move_x(robot, area.x_max + config.free_kick_move_dist)
            else:
                _move_x(robot, area.x_min - config.free_kick_move_dist)


def repel_kickers(agents: Sequence[AgentState], kicker: str, spot: tuple[float, float], config: RefereeConfig) -> None:
    """When the ball is first placed for ``kicker``'s kick, its robots closer than
    ``kick_repel_dist`` to the spot are pushed out to that distance, straight away from it. (The
    real server then looks for a free place nearby if that one is taken; the stand-in does not.)"""
    sx, sy = spot
    reach = config.kick_repel_dist
    for robot in _robots(agents, kicker):
        x, y, z = robot.torso_position()
        dx, dy = x - sx, y - sy
        distance = math.hypot(dx, dy)
        if 0.0 < distance < reach:
            robot.place(sx + dx / distance * reach, sy + dy / distance * reach, z)
