"""The referee's rules one at a time, without sockets: the float32 clock, the goal and field
tests, drop-ball spots, timeouts (the whole games are replayed against the real server in
``test_referee_scenarios.py``)."""

from __future__ import annotations

import pytest

from server_stub.game import Game
from server_stub.referee.areas import ball_on_field, goal_entered
from server_stub.simulation import Simulation


@pytest.fixture
def sim():
    simulation = Simulation()
    yield simulation
    simulation.close()


def test_the_referee_s_clock_adds_float32_cycles_as_the_real_server_s_does() -> None:
    game = Game(play_mode="PlayOn")
    for _ in range(15_000):
        game.advance()
    assert game.time == pytest.approx(300.0) and f"{game.clock32:.2f}" == "299.99" and game.clock32 < 300.0
    game.advance()
    assert f"{game.clock32:.2f}" == "300.01"


def test_a_mode_keeps_its_start_when_the_trainer_sets_the_clock() -> None:
    game = Game()
    game.kick_off("left")
    game.set_time(20.0)
    assert game.play_mode == "KickOff_Left" and game.last_mode_change == 0.0 and game.mode_time == 20.0
    assert game.time == game.clock32 == 20.0
    game.set_play_mode("KickOff_Left")  # the same mode again: no new start
    assert game.last_mode_change == 0.0


@pytest.mark.parametrize(
    ("ball", "goal"),
    [
        ((15.001, 0.0, 0.042), "right"),  # centre just over the goal line: touching the sensor box
        ((14.99, 0.0, 0.042), None),
        ((-15.3, 1.04, 0.5), "left"),
        ((15.3, 1.06, 0.1), None),  # outside the posts
        ((15.3, 0.0, 0.85), None),  # over the bar
    ],
)
def test_a_goal_is_the_ball_reaching_the_box_inside_a_goal(ball, goal) -> None:
    assert goal_entered(ball) == goal


def test_the_ball_leaves_the_field_once_past_a_line_by_its_radius_and_a_millimetre() -> None:
    assert ball_on_field((15.042, 0.0, 0.042)) and not ball_on_field((15.044, 0.0, 0.042))
    assert ball_on_field((0.0, -10.042, 0.042)) and not ball_on_field((0.0, -10.044, 0.042))


@pytest.mark.parametrize(
    ("ball", "dropped"),
    [
        ((14.0, 0.0, 0.042), (13.2, 3.0)),  # in a penalty area: its front corner on the ball's side
        ((-14.5, -1.0, 0.042), (-13.2, -3.0)),
        ((5.0, 10.5, 0.042), (5.0, 9.958)),  # off the field: in from the side line
        ((5.0, 4.0, 0.042), (5.0, 4.0)),
    ],
)
def test_the_trainer_s_drop_ball_moves_the_ball_where_the_real_referee_does(sim, ball, dropped) -> None:
    sim.set_ball(ball, (0.0, 0.0, 0.0))
    sim.drop_ball()
    x, y, z = sim.world.ball_position()
    assert sim.game.play_mode == "PlayOn"
    assert (x, y) == pytest.approx(dropped) and z == pytest.approx(ball[2])


def test_a_kick_off_nobody_takes_ends_after_15_s_in_a_drop_ball(sim) -> None:
    sim.set_play_mode("KickOff_Right")
    sim.set_play_mode("PlayOn")
    sim.set_play_mode("KickOff_Right")
    steps = 0
    while sim.game.play_mode == "KickOff_Right":
        sim.step()
        steps += 1
    assert sim.game.play_mode == "PlayOn" and steps == 750 and f"{sim.game.time:.2f}" == "15.00"


def test_a_goal_scores_pauses_3_s_then_the_other_side_kicks_off_from_the_centre(sim) -> None:
    sim.set_play_mode("PlayOn")
    sim.set_ball((14.9, 0.3, 0.042), (1.0, 0.0, 0.0))
    while sim.game.play_mode == "PlayOn":
        sim.step()
    assert (sim.game.play_mode, sim.game.score_left, sim.game.score_right) == ("Goal_Left", 1, 0)
    scored = sim.game.time
    while sim.game.play_mode == "Goal_Left":
        sim.step()
    assert sim.game.play_mode == "KickOff_Right" and sim.game.time - scored == pytest.approx(3.02, abs=0.021)
    assert sim.world.ball_position() == pytest.approx((0.0, 0.0, 0.042))


def test_a_ball_nobody_touched_may_leave_the_field_and_play_goes_on(sim) -> None:
    sim.set_play_mode("PlayOn")
    sim.set_ball((3.0, 9.9, 0.042), (0.0, 3.0, 0.0))
    for _ in range(50):
        sim.step()
    assert sim.world.ball_position()[1] > 10.1 and sim.game.play_mode == "PlayOn"
