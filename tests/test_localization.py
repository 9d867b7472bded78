"""The localization (agent.localization): poses recovered from synthetic views, from the stand-in's
perceptions (standing, walking, along the course) and from the real server's recorded walks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from agent import field_model
from agent.behaviour import Phase, WalkBehaviour
from agent.config import AgentConfig
from agent.localization import LocalizationConfig, TruePose, VisionPose, neck, torso_rotation
from bench.bench_localization import COURSE, Pose, error, stand_in_course, stand_in_robot, torso_pose, warn
from gait import Command, load_gait
from protocol.perception import GameState, Perception, Polar, Vision, parse_perception
from server_stub import field
from server_stub.sensors.vision import VisionSensor


def _perception(vision: Vision | None, acc=(0.0, 0.0, 9.81), joints=None, team: str | None = None) -> Perception:
    joints = joints or {"hj1": 0.0, "hj2": 0.0}
    return Perception(0.0, GameState(team=team), None, acc, joints, {}, vision, [], [])


def _synthetic_view(
    torso: Pose,
    z: float = 0.37,
    pitch: float = 0.0,
    roll: float = 0.0,
    he1: float = 0.0,
    he2: float = 0.0,
    noise_seed: int | None = None,
) -> tuple[Vision, tuple[float, float, float], dict[str, float]]:
    """What the stand-in's camera reports for a torso pose (deg for angles), noiseless or with a
    camera of its own noise and offset: (vision, the accelerometer's reading, the neck joints)."""
    joints = {"hj1": he1, "hj2": he2}
    rot = torso_rotation(math.radians(torso[2]), math.radians(pitch), math.radians(roll))
    head_rot, camera = neck(joints)
    position = np.array([torso[0], torso[1], z]) + rot @ camera
    sensor = VisionSensor(np.random.default_rng(noise_seed), noise=noise_seed is not None)
    see = sensor.see(tuple(position), rot @ head_rot, "left", (0.0, 0.0, 0.042), ())
    message = f"(time (now 0.00))(ACC (n torso) (a 0 0 9.81))(HJ (n hj1) (ax {he1}))(HJ (n hj2) (ax {he2})){see}"
    vision = parse_perception(message).vision
    assert vision is not None
    return vision, tuple(9.81 * rot[2, :]), joints


def test_the_agents_field_is_the_servers() -> None:
    assert field_model.LANDMARKS == dict(field.LANDMARKS)
    assert np.allclose(field_model.LINES, np.array(field.LINES)[:, :, :2])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    x=st.floats(-13.5, 13.5),
    y=st.floats(-8.5, 8.5),
    heading=st.floats(-180, 180),
    he1=st.floats(-40, 40),
    he2=st.floats(-30, 10),
    pitch=st.floats(-3, 3),
    roll=st.floats(-3, 3),
    z=st.floats(0.33, 0.39),
    off=st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05), st.floats(-6, 6)),
)
def test_a_noiseless_view_gives_the_pose_back(x, y, heading, he1, he2, pitch, roll, z, off) -> None:
    vision, acc, joints = _synthetic_view((x, y, heading), z, pitch, roll, he1, he2)
    assume(sum(name in field_model.LANDMARKS for name in vision.objects) >= 2)
    estimator = VisionPose((x + off[0], y + off[1], heading + off[2]))
    estimator.update(_perception(vision, acc, joints), Command())
    position, angle = error(estimator.pose, (x, y, heading))
    assert position < 0.01 and angle < 0.2, (estimator.pose, estimator.rejected)


@pytest.mark.parametrize(
    "pose", [(-9.0, -2.0, 90.0), (3.0, -9.0, -45.0), (-12.0, 5.0, 120.0), (-5.0, -5.0, -90.0), (-13.0, -4.0, -150.0)]
)
def test_lines_alone_place_a_robot_that_sees_at_most_one_flag(pose: Pose) -> None:
    vision, acc, joints = _synthetic_view(pose)
    assert sum(name in field_model.LANDMARKS for name in vision.objects) <= 1
    estimator = VisionPose((pose[0] + 0.04, pose[1] - 0.04, pose[2] + 5.0))
    estimator.update(_perception(vision, acc, joints), Command())
    position, angle = error(estimator.pose, pose)
    assert position < 0.01 and angle < 0.2


def test_one_line_in_view_places_the_robot_across_it_only() -> None:
    # 2 m from the left touch line, facing it: nothing else in view, so x stays where it was
    pose = (5.0, 8.0, 90.0)
    vision, acc, joints = _synthetic_view(pose)
    assert not vision.objects.keys() & field_model.LANDMARKS.keys() and len(vision.lines) == 1
    estimator = VisionPose((5.04, 7.96, 95.0))
    estimator.update(_perception(vision, acc, joints), Command())
    x, y, heading = estimator.pose
    assert x == pytest.approx(5.04, abs=0.002) and y == pytest.approx(8.0, abs=0.01)
    assert heading == pytest.approx(90.0, abs=0.2)


@pytest.mark.parametrize("pose", COURSE[1:])
def test_noisy_views_stay_within_the_targets(pose: Pose) -> None:
    found = []
    for seed in range(10):  # ten robots, each camera with its own offset and noise
        estimator = VisionPose(pose)
        for _ in range(3):
            vision, acc, joints = _synthetic_view(pose, noise_seed=seed)
            estimator.update(_perception(vision, acc, joints), Command())
        found.append(error(estimator.pose, pose))
    errors = np.array(found)
    assert np.median(errors[:, 0]) < 0.02 and errors[:, 0].max() < 0.05 and errors[:, 1].max() < 1.0


def test_a_cycle_without_vision_moves_by_the_odometry() -> None:
    estimator = VisionPose((-5.0, 1.0, 90.0), LocalizationConfig(use_gyro=False))
    estimator.update(_perception(None), Command(0.1, 0.0, 0.0))
    x, y, heading = estimator.pose
    assert (x, y, heading) == pytest.approx((-5.0, 1.1, 90.0))
    estimator.update(_perception(None), Command(0.0, 0.2, 90.0))
    # turning from 90 to 180 deg, the step to the left is taken at the middle heading, 135 deg
    middle = math.radians(135.0)
    assert estimator.pose == pytest.approx((-5.0 - 0.2 * math.sin(middle), 1.1 + 0.2 * math.cos(middle), -180.0))


def test_no_landmark_and_no_line_keeps_the_odometry_estimate() -> None:
    estimator = VisionPose((-5.0, 1.0, 0.0))
    vision = Vision(objects={"B": Polar(1.0, 0.0, -20.0)})
    estimator.update(_perception(vision), Command(0.05, 0.0, 0.0))
    assert estimator.pose == pytest.approx((-4.95, 1.0, 0.0))
    assert estimator.accepted == 0 and estimator.rejected == 0


def test_an_unreadable_see_counts_as_no_vision() -> None:
    # the real server's own words (a robot beamed to (-10, 2.24, 166.29)): the parser refuses the See
    message = (
        "(time (now 57.66))(GS (sl 0) (sr 0) (t 0.00) (pm BeforeKickOff))(GYR (n torso) (rt 0.00 0.00 0.00))"
        "(ACC (n torso) (a 0.00 0.00 9.81))(HJ (n hj1) (ax -0.00))(HJ (n hj2) (ax -0.00))(See (G1L (pol 5.15 27.10 "
        "2.43)) (G2L (pol 5.99 47.06 2.18)) (F1L (pol 9.25 -43.64 -3.50)) (mypos -10.00 2.24 0.55) (myorien 166.29) "
        "(L (pol 7.26 60.32 -4.41) (pol 9.26 -43.61 -3.44)) (L (pol nan nan nan) (pol 7.25 60.00 -4.37)))"
    )
    for source in (VisionPose((-9.0, -2.0, 90.0), LocalizationConfig(use_gyro=False)), TruePose((-9.0, -2.0, 90.0))):
        source.update(parse_perception(message), Command(0.02, 0.0, 0.0))
        assert source.pose == pytest.approx((-9.0, -1.98, 90.0))


def test_a_view_far_from_the_prediction_is_rejected() -> None:
    pose = (-9.0, -2.0, 90.0)
    estimator = VisionPose(pose)
    for _ in range(5):
        vision, acc, joints = _synthetic_view(pose)
        estimator.update(_perception(vision, acc, joints), Command())
    # a view from 3 m away, 40 deg turned: not where the robot can be
    vision, acc, joints = _synthetic_view((-6.0, 0.0, 130.0))
    before = estimator.pose
    estimator.update(_perception(vision, acc, joints), Command(0.02, 0.0, 0.0))
    assert estimator.rejected == 1
    heading = math.radians(before[2])
    moved = (before[0] + 0.02 * math.cos(heading), before[1] + 0.02 * math.sin(heading), before[2])
    assert estimator.pose == pytest.approx(moved, abs=1e-9)


def test_the_right_team_sees_the_field_turned_half_round() -> None:
    # the right team's robot at its (-9, -2, 90) stands at (9, 2) facing -y in the left team's frame
    vision, acc, joints = _synthetic_view((9.0, 2.0, -90.0))
    estimator = VisionPose((-8.96, -2.04, 93.0))
    estimator.update(_perception(vision, acc, joints, team="right"), Command())
    assert estimator.side == "right"
    position, angle = error(estimator.pose, (-9.0, -2.0, 90.0))
    assert position < 0.01 and angle < 0.2


@given(
    x=st.floats(-14, 14),
    y=st.floats(-9, 9),
    heading=st.floats(-179, 179),
    he1=st.floats(-90, 90),
    he2=st.floats(-40, 30),
    pitch=st.floats(-15, 15),
    roll=st.floats(-10, 10),
)
@settings(max_examples=40, deadline=None)
def test_true_pose_is_mypos_moved_from_the_head_to_the_torso(x, y, heading, he1, he2, pitch, roll) -> None:
    joints = {"hj1": he1, "hj2": he2}
    rot = torso_rotation(math.radians(heading), math.radians(pitch), math.radians(roll))
    head_rot, camera = neck(joints)
    head = np.array([x, y, 0.37]) + rot @ camera
    forward = (rot @ head_rot)[:, 1]
    vision = Vision(mypos=tuple(head), myorien=math.degrees(math.atan2(forward[1], forward[0])))
    estimator = TruePose((0.0, 0.0, 0.0))
    acc = tuple(9.81 * rot[2, :])
    for _ in range(600):  # the tilt filter settles on the accelerometer's reading
        estimator.update(_perception(None, acc, joints), Command())
    estimator.update(_perception(vision, acc, joints), Command())
    position, angle = error(estimator.pose, (x, y, heading))
    assert position < 1e-4 and angle < 1e-3


# ---------------------------------------------------------------------------------------------
# The stand-in: the server's own perception text, the true torso from its physics.


@pytest.mark.parametrize("pose", COURSE + [(-3.0, 5.0, 45.0), (-14.0, -8.0, -90.0)])
def test_standing_on_the_stand_in(pose: Pose) -> None:
    sim, state = stand_in_robot(seed=11)
    try:
        sim.apply_frame(state, f"(beam {pose[0]} {pose[1]} {pose[2]})".encode(), warn)
        vision_pose, true_pose = VisionPose(pose), TruePose(pose)
        errors = []
        for _ in range(30):
            sim.step()
            perception = parse_perception(sim.perception(state, sim.vision_due))
            vision_pose.update(perception, Command())
            true_pose.update(perception, Command())
            if perception.vision is not None:
                truth = torso_pose(state)
                errors.append(error(vision_pose.pose, truth))
                assert error(true_pose.pose, truth)[0] < 0.01
        e = np.array(errors)
        assert np.median(e[:, 0]) < 0.02 and e[:, 0].max() < 0.05 and e[:, 1].max() < 1.0, e
    finally:
        sim.close()


def test_walking_the_fastest_gait_on_the_stand_in() -> None:
    """A straight walk (about 1 m/s) from (-9, -2, 90) with the beam's noise: the start is up to
    0.05 m and 10 deg off; the odometry a rough forward speed."""
    sim, state = stand_in_robot(seed=5, beam_noise=True)
    try:
        pose = (-9.0, -2.0, 90.0)
        behaviour = WalkBehaviour(
            AgentConfig(beam=pose, sync=True, start_now=True), load_gait("gait/walks/fastest.json").walker()
        )
        behaviour.phase = Phase.BEAMING
        estimator = None
        reply = b""
        errors = []
        for _ in range(240):
            if reply:
                sim.apply_frame(state, reply, warn)
            sim.step()
            perception = parse_perception(sim.perception(state, sim.vision_due))
            reply = behaviour.reply(perception).encode()
            if estimator is None:
                if behaviour.phase is Phase.SETTLING and behaviour.settle_cycle > 13:  # after the second beam
                    estimator = VisionPose(pose)
                    sim.set_play_mode("PlayOn")
                continue
            walking = behaviour.phase is Phase.WALKING
            estimator.update(perception, Command(0.02 if walking else 0.0, 0.0, 0.0))
            if perception.vision is not None:
                errors.append(error(estimator.pose, torso_pose(state)))
        e = np.array(errors[2:])
        assert torso_pose(state)[1] > 0.0  # it walked
        assert np.median(e[:, 0]) < 0.03 and e[:, 0].max() < 0.06 and e[:, 1].max() < 1.0, e
    finally:
        sim.close()


def test_the_course_on_thestand_in_robot() -> None:
    """The bench's course scene (``bench.bench_localization.stand_in_course``): every vision
    cycle's error within the targets, no view rejected."""
    errors, estimator = stand_in_course(3)
    e = np.array(errors)
    assert estimator.rejected == 0
    assert np.median(e[:, 0]) < 0.02 and e[:, 0].max() < 0.05
    assert np.median(e[:, 1]) < 0.5 and e[:, 1].max() < 2.0


# ---------------------------------------------------------------------------------------------
# The real server's recorded walks (tests/data/rcssserver3d/walk_calibration: mypos on).


@pytest.mark.parametrize("run", [1, 2, 3])
def test_the_real_servers_walks(fixtures_dir, run: int) -> None:
    """Vision against the server's own ground truth, and that ground truth moved to the torso
    against the monitor's torso track (sampled every other cycle)."""
    folder = fixtures_dir / "walk_calibration"
    track = np.loadtxt(folder / f"run{run}_torso_track.tsv", skiprows=1)
    monitor = {}
    for t, x, y, *_ in track:
        monitor.setdefault(round(t, 2), (x, y))
    start = (-10.0, 3.0, 0.0)
    vision_pose, true_pose = VisionPose(start), TruePose(start)
    errors, offsets = [], []
    for k, line in enumerate((folder / f"run{run}_perceptions.txt").read_text().splitlines()[2:]):
        perception = parse_perception(line)
        vision_pose.update(perception, Command())
        true_pose.update(perception, Command())
        if perception.vision is not None and k > 30:
            errors.append(error(vision_pose.pose, true_pose.pose))
            seen_at = round(perception.game.time, 2)
            if seen_at in monitor and seen_at > 0.6:
                offsets.append(math.dist(true_pose.pose[:2], monitor[seen_at]))
    e = np.array(errors)
    assert np.median(e[:, 0]) < 0.015 and e[:, 0].max() < 0.05 and e[:, 1].max() < 0.5
    assert len(offsets) > 100 and np.median(offsets) < 0.01 and max(offsets) < 0.02
