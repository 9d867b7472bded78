"""The walk to poses (``agent.goto``): commands within the walk's speeds, poses taken in order, a
stand at the end, the pose source chosen by what the server sends; and the agent's behaviour
steering a steerable walker with it."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agent.behaviour import Phase, WalkBehaviour
from agent.config import AgentConfig
from agent.goto import GoTo, GotoConfig, ServerPoseWhereSent, in_torso_frame, wrapped
from gait import Command, Steerable
from protocol.perception import GameState, Perception, Vision

TOP = Command(1.0, 0.7, 90.0)
BACK = 0.8

coordinate = st.floats(-14.0, 14.0)
heading = st.floats(-180.0, 180.0)
pose = st.tuples(coordinate, coordinate, heading)


@given(pose, st.lists(pose, min_size=1, max_size=4))
def test_commands_stay_within_the_walks_top_speeds(here, poses):
    command = GoTo(poses).command(here, TOP, BACK)
    reach_forward = TOP.forward if command.forward >= 0 else BACK
    assert math.hypot(command.forward / reach_forward, command.left / TOP.left) <= 1.0 + 1e-9
    assert abs(command.turn) <= TOP.turn + 1e-9


@given(pose, st.floats(0.2, 10.0), st.floats(-math.pi, math.pi))
def test_the_command_points_at_the_pose(here, distance, bearing):
    goal = (here[0] + distance * math.cos(bearing), here[1] + distance * math.sin(bearing), here[2])
    command = GoTo([goal], GotoConfig(face_beyond=100.0)).command(here, TOP, BACK)
    forward, left = in_torso_frame(goal[0] - here[0], goal[1] - here[1], here[2])
    # the same direction in the torso's frame (a positive dot product, no sideways error of sign)
    assert command.forward * forward + command.left * left > 0


@given(pose, st.floats(-170.0, 170.0))
def test_it_turns_the_short_way_to_the_poses_heading(here, error):
    goal = (here[0], here[1], wrapped(here[2] + error))
    command = GoTo([goal]).command(here, TOP, BACK)
    if abs(error) > GotoConfig().reach[1]:
        assert math.copysign(1.0, command.turn) == math.copysign(1.0, error)


def test_poses_are_taken_in_order_and_the_walk_stands_at_the_last():
    goto = GoTo([(1.0, 0.0, 0.0), (1.0, 1.0, 0.0)])
    assert goto.command((1.0, 1.0, 0.0), TOP, BACK) != Command()  # the second, before the first: not done
    assert goto.index == 0
    goto.command((1.0, 0.05, 2.0), TOP, BACK)
    assert goto.index == 1
    assert goto.command((1.02, 0.98, -3.0), TOP, BACK) == Command()
    assert goto.done


def test_the_approach_slows_to_a_stand_at_the_last_pose_only():
    far, near = (-4.0, 0.0, 0.0), (0.9, 0.0, 0.0)  # 5 m left: beyond where the approach slows
    last = GoTo([(1.0, 0.0, 0.0)])
    assert last.command(far, TOP, BACK).forward == pytest.approx(TOP.forward)
    assert last.command(near, TOP, BACK).forward < 0.2
    passing = GoTo([(1.0, 0.0, 0.0), (5.0, 0.0, 0.0)])
    assert passing.command(near, TOP, BACK).forward >= GotoConfig().pass_speed


def test_a_long_leg_across_is_walked_facing_its_way_when_that_is_faster():
    # 6 m to the left at 0.7 m/s takes 8.6 s; turning 90 deg twice and 6 m ahead at 1 m/s, 8 s
    goto = GoTo([(0.0, 6.0, 0.0)], GotoConfig(face_saving=0.0))
    command = goto.command((0.0, 0.0, 0.0), TOP, BACK)
    assert command.turn > 0  # turning to face +y
    goto = GoTo([(0.0, 6.0, 0.0)], GotoConfig(face_saving=0.5))
    command = goto.command((0.0, 0.0, 0.0), TOP, BACK)
    assert command.left > 0 and abs(command.turn) < 1e-9  # not worth it: sideways


class _Fixed:
    def __init__(self, at: tuple[float, float, float]) -> None:
        self.pose = at
        self.updates = 0

    def update(self, perception: Perception, odometry: Command) -> None:
        self.updates += 1

    def reset(self, start: tuple[float, float, float]) -> None:
        self.pose = start


def _perception(vision: Vision | None = None, play_mode: str = "PlayOn") -> Perception:
    game = GameState(play_mode=play_mode, time=0.0)
    return Perception(0.0, game, (0.0, 0.0, 0.0), (0.0, 0.0, 9.81), {}, {}, vision, [], [])


def test_the_servers_pose_is_used_where_it_sends_one():
    true, own = _Fixed((1.0, 0.0, 0.0)), _Fixed((2.0, 0.0, 0.0))
    chosen = ServerPoseWhereSent(true, own)
    chosen.update(_perception(), Command())
    chosen.update(_perception(Vision(mypos=(1.0, 0.0, 0.5), myorien=0.0)), Command())
    chosen.update(_perception(), Command())
    assert chosen.uses_server_pose and chosen.pose == true.pose and true.updates == 3 and own.updates == 2
    chosen = ServerPoseWhereSent(_Fixed((1.0, 0.0, 0.0)), own := _Fixed((2.0, 0.0, 0.0)))
    chosen.update(_perception(Vision()), Command())
    assert not chosen.uses_server_pose and chosen.pose == own.pose


class _Walker:
    """A steerable walker that records the commands it is given and stands."""

    def __init__(self) -> None:
        self.command = Command(1.0, 0.0, 0.0)
        self.commands: list[Command] = []

    @property
    def max_command(self) -> Command:
        return TOP

    @property
    def max_backward(self) -> float:
        return BACK

    def sense(self, gyro, acc, joints) -> None:
        pass

    def moved(self) -> Command:
        return Command()

    def joint_targets(self, t, limits):
        self.commands.append(self.command)
        return {}


def test_the_behaviour_steers_a_steerable_walker_to_its_goals():
    walker = _Walker()
    assert isinstance(walker, Steerable)
    config = AgentConfig(goals=((3.0, 0.0, 0.0),), settle_cycles=2, start_now=True)
    source = _Fixed((0.0, 0.0, 0.0))
    behaviour = WalkBehaviour(config, walker, pose=source)
    for _ in range(6):
        behaviour.action(_perception())
    assert behaviour.phase is Phase.WALKING
    assert walker.commands[0] == Command()  # standing while settling
    assert walker.commands[-1].forward > 0.5 and source.updates == len(walker.commands)


def test_goals_need_a_steerable_gait():
    class Fixed:
        def joint_targets(self, t, limits):
            return {}

    with pytest.raises(ValueError, match="steerable"):
        WalkBehaviour(AgentConfig(goals=((1.0, 0.0, 0.0),)), Fixed())
