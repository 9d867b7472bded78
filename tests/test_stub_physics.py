"""The stub's physics core against the real server's numbers (docs/robot_and_server.md)."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocol.nao import JOINTS, SPEED_CAP
from server_stub.config import PhysicsConfig
from server_stub.field import BALL_RADIUS
from server_stub.physics import contact, nao_model
from server_stub.physics.world import World

DEG_PER_CYCLE_AT_CAP = math.degrees(SPEED_CAP * 0.02)  # 7.035


def settle(world: World, seconds: float) -> None:
    for _ in range(round(seconds / world.config.cycle)):
        world.step()


@pytest.fixture(scope="module")
def standing():
    """One NAO beamed at (-3, 2) facing +x and left to rest for 3 s (shared, read-only tests)."""
    world = World()
    robot = world.add_robot()
    robot.beam(-3.0, 2.0, 0.0)
    settle(world, 3.0)
    yield world, robot
    world.close()


@pytest.fixture
def world():
    w = World()
    yield w
    w.close()


# ----- the model -----
def test_model_mass_and_sole_match_the_facts_sheet():
    assert nao_model.total_mass() == pytest.approx(4.6071, abs=1e-9)
    parts = {p.name: p for p in nao_model.body_parts()}
    sole = parts["rfoot"].centre[2] - parts["rfoot"].size[2] / 2
    assert sole == pytest.approx(-0.385)
    assert parts["lthigh"].centre == (-0.055, 0.0, -0.155)


def test_hinges_follow_protocol_order_and_mirror_left():
    hinges = nao_model.hinges()
    assert [h.effector for h in hinges] == [j.effector for j in JOINTS]
    by = {h.effector: h for h in hinges}
    assert by["lle1"].axis == (-0.7071, 0.0, -0.7071)
    assert by["lle4"].anchor == (-0.055, -0.005, -0.235)
    assert by["lae3"].parent == "lupperarm"


def test_hetero_types_move_the_chain_below_the_changed_offset():
    t0 = {p.name: p.centre for p in nao_model.body_parts(0)}
    t1 = {p.name: p.centre for p in nao_model.body_parts(1)}
    drop = (0.05832 - 0.04) + (0.07332 - 0.055)
    assert t1["rfoot"][2] == pytest.approx(t0["rfoot"][2] - drop)
    assert t1["rthigh"][2] == pytest.approx(t0["rthigh"][2] - (0.05832 - 0.04))
    assert t1["rhip2"] == t0["rhip2"]
    assert nao_model.speed_caps(2)[[j.effector for j in JOINTS].index("lle6")] == 3.47234
    with pytest.raises(ValueError):
        nao_model.body_parts(5)


def test_only_colliding_parts_have_collision_shapes(world):
    robot = world.add_robot()
    body = robot.body_id
    shapes = {
        pb.getJointInfo(body, i, physicsClientId=world._client)[12].decode(): len(
            pb.getCollisionShapeData(body, i, physicsClientId=world._client)
        )
        for i in range(len(JOINTS))
    }
    parts = {p.name: p for p in nao_model.body_parts()}
    for name, count in shapes.items():
        assert (count > 0) == parts[name].collides, name


# ----- resting, FRP, ACC, GYR -----
def test_beamed_robot_rests_at_the_real_height(standing):
    _, robot = standing
    assert robot.torso_position()[2] == pytest.approx(0.383, abs=0.01)
    assert robot.torso_position()[:2] == pytest.approx((-3.0, 2.0), abs=0.02)


def test_standing_feet_carry_the_weight(standing):
    _, robot = standing
    frp = robot.foot_pressure()
    assert set(frp) == {"lf", "rf"}
    total = sum(force[2] for _, force in frp.values())
    assert total == pytest.approx(45.2, rel=0.05)
    for centre, force in frp.values():
        assert force[2] == pytest.approx(22.6, rel=0.15)
        assert centre[2] == pytest.approx(-0.01, abs=0.002)  # on the sole, in the foot frame
        assert abs(centre[0]) <= 0.04 + 1e-6 and abs(centre[1]) <= 0.08 + 1e-6


def test_a_flat_foot_touches_at_its_four_sole_corners_and_holds_still(world):
    """As ODE's box-plane collider gives them, all at once (Bullet's plane collider added one
    corner per step, and a robot stepped once per cycle rocked on two of them for ever)."""
    robot = world.add_robot()
    robot.beam(5.0, -2.0, 30.0)
    settle(world, 1.0)
    for _ in range(25):
        world.step()
        assert len([c for c in robot.contact_points() if c[contact.NORMAL_FORCE] > 0.0]) == 8
        assert max(abs(g) for g in robot.gyro()) < 0.1


def test_frp_absent_without_contact(world):
    robot = world.add_robot()  # appears in the air
    world.step()
    assert robot.foot_pressure() == {}


def test_accelerometer_reads_gravity_at_rest_and_zero_in_free_fall(standing, world):
    _, resting = standing
    assert resting.accelerometer() == pytest.approx((0.0, 0.0, 9.81), abs=0.15)
    assert resting.gyro() == pytest.approx((0.0, 0.0, 0.0), abs=0.5)
    falling = world.add_robot()
    world.step()
    world.step()
    assert falling.accelerometer() == pytest.approx((0.0, 0.0, 0.0), abs=0.01)


def test_accelerometer_reads_before_the_step_and_sees_an_init_but_not_a_beam(world):
    """The real capture's ACC z around the start (agent_perceptions_first20.txt, lines 3-5): 29.42
    after the ``init`` move stopped the robot's fall, 0.00 after the beam (the accelerometer read
    before it, in free fall), 9.81 after that (the fall restarted from rest, as before). The real
    robot had fallen 3 steps when its ``init`` came."""
    robot = world.add_robot()
    for _ in range(3):
        world.step()
    robot.place(-14.2, 9.2, 0.4, yaw_deg=0.0)  # what an init does (Simulation._init)
    world.step()
    readings = [robot.accelerometer()[2]]
    robot.beam(-1.0, 0.0, 0.0)
    for _ in range(2):
        world.step()
        readings.append(robot.accelerometer()[2])
    assert readings == pytest.approx([29.42, 0.0, 9.81], abs=0.01)


def test_gyro_is_in_the_torso_frame_in_degrees(world):
    robot = world.add_robot()
    robot.place(0.0, 0.0, 3.0, yaw_deg=0.0)  # facing world +x, in the air
    pb.resetBaseVelocity(robot.body_id, (0, 0, 0), (1.0, 0.0, 0.5), physicsClientId=world._client)
    gx, gy, gz = robot.gyro()
    # world +x is the robot's forward (torso y); world z is torso z
    assert (gx, gy, gz) == pytest.approx((0.0, math.degrees(1.0), math.degrees(0.5)), abs=1e-6)


# ----- frames and joint signs -----
@pytest.mark.parametrize("heading, forward", [(0.0, (1, 0, 0)), (90.0, (0, 1, 0)), (180.0, (-1, 0, 0))])
def test_beam_heading_sets_the_torso_forward_axis(world, heading, forward):
    robot = world.add_robot()
    robot.beam(1.0, -2.0, heading)
    rotation = robot.torso_rotation()
    assert rotation[:, 1] == pytest.approx(forward, abs=1e-9)
    assert rotation[:, 2] == pytest.approx((0, 0, 1), abs=1e-9)
    assert robot.torso_position() == pytest.approx((1.0, -2.0, 0.4))
    assert robot.head_pose()[0] == pytest.approx((1.0, -2.0, 0.555), abs=1e-6)


def test_new_robot_appears_in_the_air_facing_plus_y(world):
    robot = world.add_robot()
    assert robot.torso_position() == pytest.approx((0.0, -1.0, 1.5))
    assert robot.torso_rotation()[:, 1] == pytest.approx((0, 1, 0))


def _torso_frame(robot, world_point):
    position = np.array(robot.torso_position())
    return robot.torso_rotation().T @ (np.array(world_point) - position)


def _part(robot, name):
    return dict(zip(robot.part_names, robot.part_poses()))[name]


def _drive(world, robot, effector, velocity, cycles):
    robot.command(effector, velocity)
    for _ in range(cycles):
        world.step()
    robot.command(effector, 0.0)
    world.step()
    world.step()


def test_joint_signs_match_the_facts_sheet(world):
    robot = world.add_robot()
    robot.place(0.0, 0.0, 3.0)
    pb.createConstraint(
        robot.body_id, -1, -1, -1, pb.JOINT_FIXED, (0, 0, 0), (0, 0, 0), (0.0, 0.0, 3.0), physicsClientId=world._client
    )
    foot0 = _torso_frame(robot, _part(robot, "lfoot")[:3, 3])
    _drive(world, robot, "lle3", 2.0, 10)  # thigh forward
    foot1 = _torso_frame(robot, _part(robot, "lfoot")[:3, 3])
    assert robot.joint_angles()["llj3"] > 10 and foot1[1] > foot0[1] + 0.05
    _drive(world, robot, "lle5", 2.0, 10)  # toes up
    toes = robot.torso_rotation().T @ _part(robot, "lfoot")[:3, 1]
    assert robot.joint_angles()["llj5"] > 10 and toes[2] > 0.2
    _drive(world, robot, "lae1", -6.0, 14)  # arm down from forward
    hand = _torso_frame(robot, _part(robot, "llowerarm")[:3, 3])
    assert robot.joint_angles()["laj1"] < -80 and hand[2] < -0.05 and abs(hand[1]) < 0.05


# ----- motors -----
def test_full_speed_command_moves_a_joint_7_03_degrees_per_cycle(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 0.0)
    settle(world, 0.5)
    robot.command("he1", 100.0)
    world.step()
    world.step()  # latency: the command starts acting in this step
    angles = []
    for _ in range(5):
        angles.append(robot.joint_angles()["hj1"])
        world.step()
    assert np.diff(angles) == pytest.approx([DEG_PER_CYCLE_AT_CAP] * 4, abs=0.1)


def test_a_command_shows_first_two_observations_later(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 0.0)
    settle(world, 0.5)
    before = robot.joint_angles()["hj1"]
    robot.command("he1", 1.0)  # given after observation k
    world.step()  # observation k+1
    assert robot.joint_angles()["hj1"] == pytest.approx(before, abs=1e-6)
    world.step()  # observation k+2
    moved = robot.joint_angles()["hj1"] - before
    assert moved == pytest.approx(math.degrees(0.02), abs=0.01)  # 1.15 deg, as observed


def test_commands_are_sticky(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 0.0)
    robot.command("he1", 1.0)
    for _ in range(2):
        world.step()
    angles = []
    for _ in range(20):
        world.step()
        angles.append(robot.joint_angles()["hj1"])
    assert np.diff(angles) == pytest.approx([math.degrees(0.02)] * 19, abs=0.01)


def test_a_joint_driven_into_its_stop_overshoots_one_step_and_bounces(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 0.0)
    robot.command("he1", 100.0)
    angles = []
    for _ in range(30):
        world.step()
        angles.append(robot.joint_angles()["hj1"])
    tail = angles[-6:]
    highs, lows = tail[0::2], tail[1::2]
    if highs[0] < lows[0]:
        highs, lows = lows, highs
    assert all(h > 120 for h in highs) and all(lo < 120 for lo in lows)
    assert max(highs) - min(lows) == pytest.approx(DEG_PER_CYCLE_AT_CAP, abs=0.2)  # 119.5 / 126.5


def test_a_command_is_dropped_while_the_joint_is_outside_its_range(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 0.0)
    robot.command("he1", 100.0)
    for _ in range(30):
        world.step()
    # The command given now is applied in two steps, from the angle seen after the next step.
    if robot.joint_angles()["hj1"] > 120:
        world.step()  # now inside; the next observation is outside
    robot.command("he1", -1.0)
    world.step()
    outside = robot.joint_angles()["hj1"]
    world.step()
    world.step()
    assert outside > 120
    assert robot.joint_angles()["hj1"] > 120  # dropped: still bouncing at full speed
    robot.command("he1", -1.0)  # given while inside the next time round: applied
    for _ in range(6):
        world.step()
    a = robot.joint_angles()["hj1"]
    world.step()
    assert robot.joint_angles()["hj1"] - a == pytest.approx(-math.degrees(0.02), abs=0.05)


@settings(max_examples=40, deadline=None)
@given(
    st.sampled_from([j.effector for j in JOINTS]),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
)
def test_command_accepts_any_finite_velocity_and_clips_it(effector, velocity):
    robot = _shared_robot()
    robot.command(effector, velocity)
    index = [j.effector for j in JOINTS].index(effector)
    assert abs(robot._requested[index]) <= SPEED_CAP + 1e-12
    assert robot._requested[index] == pytest.approx(max(-SPEED_CAP, min(SPEED_CAP, velocity)))


_WORLD_FOR_PROPERTIES: list[World] = []


def _shared_robot():
    if not _WORLD_FOR_PROPERTIES:
        _WORLD_FOR_PROPERTIES.append(World())
        _WORLD_FOR_PROPERTIES[0].add_robot()
    return _WORLD_FOR_PROPERTIES[0].robots[0]


def test_command_rejects_unknown_effectors_and_non_finite_values(world):
    robot = world.add_robot()
    with pytest.raises(KeyError):
        robot.command("xe9", 1.0)
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError):
            robot.command("he1", bad)


# ----- falling, placing, ball, many robots, determinism -----
def test_a_robot_that_falls_drops_below_the_referee_height(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 0.0)
    for effector in ("lle3", "rle3"):
        robot.command(effector, 6.0)  # both thighs up fast: the robot sits and tips over
    settle(world, 3.0)
    assert robot.torso_position()[2] < 0.25


def test_place_keeps_orientation_and_joints_and_zeroes_velocity(world):
    robot = world.add_robot()
    robot.beam(0.0, 0.0, 30.0)
    robot.command("he1", 2.0)
    settle(world, 0.5)
    angles = robot.joint_angles()
    rotation = robot.torso_rotation()
    robot.place(2.0, 1.0, 0.6)
    assert robot.torso_position() == pytest.approx((2.0, 1.0, 0.6))
    assert robot.torso_rotation() == pytest.approx(rotation, abs=1e-9)
    assert robot.joint_angles() == pytest.approx(angles, abs=1e-9)
    assert pb.getBaseVelocity(robot.body_id, physicsClientId=world._client)[0] == (0.0, 0.0, 0.0)
    robot.place(2.0, 1.0, 0.6, yaw_deg=-90.0)
    assert robot.torso_rotation()[:, 1] == pytest.approx((0, -1, 0), abs=1e-9)


def test_ball_rests_on_the_ground_and_can_be_set(world):
    settle(world, 0.5)
    x, y, z = world.ball_position()
    assert (x, y) == pytest.approx((0.0, 0.0), abs=1e-6)
    # radius 0.042, sunk into the ground by ODE's contact surface layer (docs/robot_and_server.md
    # section 4) and by the ball's soft contact (ball.rsg: CFM 0.05, ERP
    # 0.35 with the ground: 0.73 mm more under its weight)
    assert BALL_RADIUS - PhysicsConfig().contact_slop - 1e-3 <= z <= BALL_RADIUS + 1e-4
    world.set_ball((1.0, 2.0, 0.042), (1.0, 0.0, 0.0))
    world.step()
    x, y, _ = world.ball_position()
    # it rolls at once at 5/7 of its speed (ODE's friction, no Coulomb limit; Bullet's ball slid
    # at 1 m/s), as the real server's ball does (tests/test_stub_ode.py, the recorded roll)
    assert 1.013 <= x <= 1.022 and y == pytest.approx(2.0, abs=1e-6)


def test_ball_position_is_what_pybullet_holds_and_reading_it_does_not_hide_a_placement(world):
    """The world answers ``ball_position`` from what its step last wrote (the referee asks several
    times a cycle); a placement read before the next step must still wake a resting ball."""
    settle(world, 0.5)  # long enough for ODE's auto-disable to put the ball to sleep
    world.set_ball((1.0, 2.0, 0.5))
    assert world.ball_position() == (1.0, 2.0, 0.5)  # the referee looks before the step
    for _ in range(5):
        world.step()
        held = pb.getBasePositionAndOrientation(world._ball, physicsClientId=world._client)[0]
        assert world.ball_position() == tuple(held)
    assert world.ball_position()[2] < 0.5 - 0.01  # stepped: it falls


def test_part_poses_cover_every_part(standing):
    _, robot = standing
    fresh = robot.part_positions(["head", "rfoot", "llowerarm"])  # before part_poses is cached
    poses = dict(zip(robot.part_names, robot.part_poses()))
    for name, position in fresh.items():
        assert position == pytest.approx(poses[name][:3, 3], abs=1e-12)
        assert robot.part_positions([name])[name] == pytest.approx(position, abs=1e-12)
    assert set(poses) == {p.name for p in nao_model.body_parts()}
    assert poses["torso"][:3, 3] == pytest.approx(robot.torso_position())
    assert poses["head"][:3, 3] == pytest.approx(robot.head_pose()[0])
    assert poses["head"][:3, :3] == pytest.approx(robot.head_pose()[1], abs=1e-12)
    assert poses["torso"][:3, :3] == pytest.approx(robot.torso_rotation(), abs=1e-12)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(lambda q: sum(c * c for c in q) > 0.01))
def test_part_rotations_match_pybullet_for_any_orientation(q):
    from server_stub.physics.rotations import body_poses

    q = np.array(q) / np.linalg.norm(q)
    base = np.reshape(pb.getMatrixFromQuaternion([0.1, 0.2, 0.3, 0.927]), (3, 3))
    ours = body_poses(np.array([1.0, 2.0, 3.0]), base, np.array([[4.0, 5.0, 6.0, *q]]))
    assert ours[1, :3, :3] == pytest.approx(np.reshape(pb.getMatrixFromQuaternion(q.tolist()), (3, 3)), abs=1e-12)
    assert ours[1, :3, 3].tolist() == [4.0, 5.0, 6.0] and ours[0, :3, 3].tolist() == [1.0, 2.0, 3.0]
    assert (ours[0, :3, :3] == base).all() and ours[:, 3].tolist() == [[0.0, 0.0, 0.0, 1.0]] * 2


def test_robots_can_be_added_and_removed(world):
    first = world.add_robot()
    second = world.add_robot(1)
    first.beam(-2.0, 0.0, 0.0)
    second.beam(-2.0, 2.0, 0.0)
    world.remove_robot(first)
    settle(world, 1.0)
    assert world.robots == (second,)
    assert second.torso_position()[2] > 0.3


def test_same_seed_same_commands_same_motion():
    def run():
        with World(seed=7) as world:
            robot = world.add_robot()
            robot.beam(0.0, 0.0, 10.0)
            for i in range(100):
                robot.command("lle3", math.sin(i / 10.0))
                robot.command("rle2", 0.3 * math.cos(i / 7.0))
                world.step()
            return robot.torso_position(), robot.joint_angles()

    assert run() == run()
