"""The agent's cycle logic replayed against a real client's recorded walk on a real server.

The calibration walk (tests/data/rcssserver3d/walk_calibration) was driven by a probe client with the
same gait, mapping and controller the agent implements; feeding the agent the perceptions that
probe received must make it send the same commands, cycle by cycle.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agent.behaviour import Phase, WalkBehaviour
from agent.config import AgentConfig
from agent.controller import joint_velocities, velocities_towards
from agent.fall import FallDetector
from gait import load_gait
from protocol.nao import JOINTS, SPEED_CAP
from protocol.perception import parse_perception

_COMMAND = re.compile(r"\((\w+) ([-\d.]+)\)")


def _hinges(line: str) -> dict[str, float]:
    return {name: float(v) for name, v in _COMMAND.findall(line) if name not in ("unum",)}


@pytest.mark.parametrize("run", [1, 2, 3])
def test_replay_of_the_real_calibration_walk_sends_the_recorded_commands(fixtures_dir, run: int) -> None:
    folder = fixtures_dir / "walk_calibration"
    perceptions = (folder / f"run{run}_perceptions.txt").read_text().splitlines()
    sent = (folder / f"run{run}_commands.txt").read_text().splitlines()
    config = AgentConfig(team="Calib", beam=(-10.0, 3.0, 0.0), sync=True, duration=15.0, start_now=True)
    behaviour = WalkBehaviour(config, load_gait().walker())
    replies = []
    for line in perceptions:
        replies.append(behaviour.reply(parse_perception(line)) + "(syn)")
        if behaviour.phase is Phase.DONE:
            break
    assert sent[0] == "(scene rsg/agent/nao/nao.rsg)"
    recorded = sent[1:]
    assert len(replies) == len(recorded) == 777
    assert replies[0] == recorded[0] == "(init (unum 1)(teamname Calib))(syn)"
    assert replies[1] == recorded[1] == "(beam -10 3 0)(syn)"
    worst = 0.0
    for k, (ours, theirs) in enumerate(zip(replies[2:], recorded[2:]), start=3):
        a, b = _hinges(ours), _hinges(theirs)
        assert a.keys() == b.keys(), f"reply to perception {k}"
        worst = max(worst, max(abs(a[n] - b[n]) for n in a))
        assert ("(beam -10 3 0)" in ours) == ("(beam -10 3 0)" in theirs), f"reply to perception {k}"
    # 4-decimal printing on both sides: anything above two units in the last place is a real difference
    assert worst <= 2e-4


def test_controller_caps_velocity_and_holds_missing_joints() -> None:
    targets = {j.effector: 90.0 for j in JOINTS}
    perceived = {j.perceptor: -90.0 for j in JOINTS if j.perceptor != "hj1"}
    v = joint_velocities(targets, perceived, gain=15.0)
    assert v["he1"] == 0.0
    assert all(abs(x) <= SPEED_CAP for x in v.values())
    assert v["lle3"] == SPEED_CAP
    small = joint_velocities({"he2": 1.0}, {"hj2": 0.0}, gain=15.0)
    assert small == {"he2": pytest.approx(15.0 * math.radians(1.0))}


_DEGREES = st.floats(-400.0, 400.0, allow_nan=False)


@given(pairs=st.lists(st.tuples(_DEGREES, _DEGREES), min_size=1, max_size=24), gain=st.floats(0.1, 100.0))
def test_the_array_law_gives_the_scalar_laws_floats_bit_for_bit(pairs: list[tuple[float, float]], gain: float) -> None:
    """``velocities_towards`` on arrays is the controller's scalar law, min(max(g (t - a) deg, -cap),
    cap) per joint, to the last bit (the walks must not change by a bit)."""
    targets, angles = (np.array(column) for column in zip(*pairs))
    scalar = [min(max(gain * (t - a) * (math.pi / 180.0), -SPEED_CAP), SPEED_CAP) for t, a in pairs]
    assert velocities_towards(targets, angles, gain).tolist() == scalar


def test_a_posture_naming_a_joint_the_robot_lacks_is_refused() -> None:
    """Type 0 has no toes: holding one is a mistake said at once, not a command for no joint."""
    with pytest.raises(ValueError, match="rle7"):
        WalkBehaviour(AgentConfig(robot_type=0, posture={"rle7": 10.0}), load_gait().walker())
    WalkBehaviour(AgentConfig(robot_type=4, posture={"rle7": 10.0}), load_gait().walker())  # type 4 has them


def test_fall_detector_ignores_spikes_and_sees_a_torso_tipping_over() -> None:
    fd = FallDetector()
    assert not any(fd.update((0.0, 0.0, 9.81), (0.0, 0.0, 0.0)) for _ in range(20))
    assert not fd.update((0.0, -29.4, 1.0), (0.0, 0.0, 0.0))  # one-cycle spike
    assert fd.up_z > 0.99
    # pitching forward at 200 deg/s while the accelerometer reads the fall's own accelerations
    events = [fd.update((0.0, -20.0, 3.0), (-200.0, 0.0, 0.0)) for _ in range(20)]
    assert events.count(True) == 1 and fd.fallen
    tipped = 200.0 * 0.02 * (events.index(True) + 1)  # degrees turned when it was noticed
    assert math.degrees(math.acos(0.6)) <= tipped <= math.degrees(math.acos(0.6)) + 8.0


def test_fall_detector_sees_a_lying_torso_from_the_accelerometer_alone() -> None:
    """Without any gyro (a robot put down lying), the accelerometer's gravity takes over within
    about a second."""
    fd = FallDetector()
    fd.update((0.0, 0.0, 9.81))
    cycles = next(k for k in range(200) if fd.update((0.0, -9.8, 1.0)))
    assert 10 <= cycles <= 60


_vectors = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: 0.1 < math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
)


@given(st.lists(st.tuples(_vectors, st.floats(0.0, 0.69) | st.floats(1.31, 5.0)), min_size=1, max_size=200))
def test_fall_detector_reads_no_gravity_into_accelerations_far_from_1g(readings) -> None:
    """A torso that does not turn (gyro 0) and whose accelerometer reads far from 1 g (a step's
    impact, a free fall) keeps its estimate: the false alarms of fast gaits came from reading such
    accelerations as gravity."""
    fd = FallDetector()
    fd.update((0.0, 0.0, 9.81), (0.0, 0.0, 0.0))
    for direction, g_units in readings:
        norm = math.sqrt(sum(c * c for c in direction))
        fd.update(tuple(9.81 * g_units * c / norm for c in direction), (0.0, 0.0, 0.0))
    assert fd.up_z == pytest.approx(1.0) and not fd.fallen


@given(st.lists(st.tuples(_vectors, st.floats(0.71, 1.29)), min_size=1, max_size=200))
def test_fall_detector_stays_upright_while_gravity_reads_upright(readings) -> None:
    """Readings near 1 g whose direction is within 37 deg of upright (z >= 0.8 of the unit
    vector) pull the estimate among directions at least that upright: never a fall."""
    fd = FallDetector()
    fd.update((0.0, 0.0, 9.81), (0.0, 0.0, 0.0))
    for direction, g_units in readings:
        norm = math.sqrt(sum(c * c for c in direction))
        unit = [c / norm for c in direction]
        if unit[2] < 0.8:
            continue
        fd.update(tuple(9.81 * g_units * c for c in unit), (0.0, 0.0, 0.0))
        assert fd.up_z >= 0.8 - 1e-9
    assert not fd.fallen


def test_fall_detector_on_the_real_forward_fall(fixtures_dir) -> None:
    """The main capture's robot falls forward about 1.4 s after the beam and then lies."""
    fd = FallDetector()
    fell_at = None
    for k, line in enumerate((fixtures_dir / "agent_perceptions_full_run.txt").read_text().splitlines()):
        perception = parse_perception(line)
        if fd.update(perception.acc, perception.gyro) and fell_at is None:
            fell_at = k
    assert fell_at is not None
    assert 40 <= fell_at <= 200  # after the beam at perception 4, within the first 4 s


def test_walking_waits_for_play_on_unless_told() -> None:
    config = AgentConfig(settle_cycles=3, rebeam_cycle=2, duration=0.1)
    behaviour = WalkBehaviour(config, load_gait().walker())
    before = "(time (now 1.00))(GS (sl 0) (sr 0) (t 0.00) (pm BeforeKickOff))(HJ (n hj1) (ax 0.00))"
    playon = "(time (now 1.00))(GS (sl 0) (sr 0) (t 0.02) (pm PlayOn))(HJ (n hj1) (ax 0.00))"
    for _ in range(10):
        behaviour.reply(parse_perception(before))
    assert behaviour.phase is Phase.SETTLING
    behaviour.reply(parse_perception(playon))
    assert behaviour.phase is Phase.WALKING
    for _ in range(10):
        behaviour.reply(parse_perception(playon))
    assert behaviour.phase is Phase.DONE and behaviour.walk_time == pytest.approx(0.1)


def _walking_actions(config: AgentConfig, cycles: int) -> list:
    """The actions of a behaviour taken straight into walking, ``cycles`` walking cycles long."""
    behaviour = WalkBehaviour(config, load_gait().walker())
    playon = parse_perception("(time (now 1.00))(GS (sl 0) (sr 0) (t 0.02) (pm PlayOn))(HJ (n hj1) (ax 0.00))")
    actions = [behaviour.action(playon) for _ in range(config.settle_cycles + 2 + cycles)]
    assert behaviour.phase is Phase.WALKING
    return actions


@given(noise=st.floats(1e-4, 0.5), seed=st.integers(0, 2**31))
@settings(max_examples=25, deadline=None)
def test_the_command_dither_stays_within_its_bound_and_only_while_walking(noise: float, seed: int) -> None:
    plain = _walking_actions(AgentConfig(start_now=True), 20)
    dithered = _walking_actions(AgentConfig(start_now=True, command_noise=noise, noise_seed=seed), 20)
    walking_from = AgentConfig.settle_cycles + 2
    assert dithered[:walking_from] == plain[:walking_from]  # handshake, beam and settling untouched
    moved = []
    for a, b in zip(plain[walking_from:], dithered[walking_from:]):
        assert a.velocities.keys() == b.velocities.keys()
        moved += [b.velocities[k] - a.velocities[k] for k in a.velocities]
    assert max(abs(m) for m in moved) <= noise * (1 + 1e-12)
    assert any(m != 0 for m in moved)


def test_the_command_dither_is_fixed_by_its_seed() -> None:
    def velocities(seed: int) -> list[dict[str, float]]:
        config = AgentConfig(start_now=True, command_noise=0.001, noise_seed=seed)
        return [a.velocities for a in _walking_actions(config, 10)]

    assert velocities(3) == velocities(3)
    assert velocities(3) != velocities(4)
    with pytest.raises(ValueError, match="command_noise"):
        AgentConfig(command_noise=-0.1)


@given(noise=st.floats(1e-4, 0.5), seed=st.integers(0, 2**31))
@settings(max_examples=10, deadline=None)
def test_the_dither_drawn_in_blocks_is_one_draw_a_cycle_bit_for_bit(noise: float, seed: int) -> None:
    """The behaviour draws its dither a block of cycles at a time; each cycle's velocities are the
    plain ones plus the numbers a draw of 22 a cycle from the same seed gives, to the last bit,
    across block boundaries (150 cycles)."""
    cycles = 150
    plain = _walking_actions(AgentConfig(start_now=True), cycles)
    dithered = _walking_actions(AgentConfig(start_now=True, command_noise=noise, noise_seed=seed), cycles)
    draws = np.random.default_rng(seed)
    walking_from = AgentConfig.settle_cycles + 2
    for a, b in zip(plain[walking_from:], dithered[walking_from:], strict=True):
        expected = a.speeds + draws.uniform(-noise, noise, len(a.speeds))
        assert b.speeds.tobytes() == expected.tobytes()


def test_a_joint_missing_from_the_perception_is_held_and_the_others_move_as_usual() -> None:
    """A joint the perception does not name gets 0 ("hold"); every other joint gets what it gets
    when all are named."""
    angles = " ".join(f"(HJ (n {j.perceptor}) (ax 0.00))" for j in JOINTS if j.perceptor != "hj1")
    head = "(time (now 1.00))(GS (sl 0) (sr 0) (t 0.02) (pm BeforeKickOff))"
    without = parse_perception(head + angles)
    with_it = parse_perception(head + "(HJ (n hj1) (ax 0.00))" + angles)

    def settling(perception) -> np.ndarray:
        behaviour = WalkBehaviour(AgentConfig(posture={"he1": 30.0}), load_gait().walker())
        behaviour.action(perception), behaviour.action(perception)  # init, beam
        return behaviour.action(perception).speeds

    full, held = settling(with_it), settling(without)
    he1 = [j.effector for j in JOINTS].index("he1")
    assert full[he1] != 0.0 and held[he1] == 0.0
    assert np.delete(held, he1).tobytes() == np.delete(full, he1).tobytes()
