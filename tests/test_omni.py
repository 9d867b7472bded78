"""The omni walk engine: its targets stay inside the joint limits for any genes and commands, its
leg IK reaches what it is asked, it stands at the start and after a stop, it clips commands onto
its top speeds, its odometry is the commanded speed in steady state, ``lag_comp`` leads the planned
targets by their rate, its start gait walks on the stand-in, and its gaits round-trip through gait
files (those of 19 genes, from before ``lag_comp`` and the calibration, load as the walk they
were); a calibrated walker plans its map of the command, and its odometry and top speeds are in
the commanded speeds."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import DEFAULT_FAMILY, FAMILIES, OMNI, Command, Gait, GaitFileError, Steerable, load_gait, save_gait
from gait.leg_ik import LEG_LENGTH, leg_fk, leg_ik, rot_x, rot_y, rot_z
from gait.nao_legs import LIMIT_MARGIN_DEG
from gait.omni import EFFECTORS, RATE_STEP, OmniWalker, feedback_angles, joint_angles, planned_angles, tilt
from gait.omni_steps import OmniParams, advance, clip_command, standing
from optimizer.episode import EpisodeConfig, EpisodeRunner
from protocol.nao import JOINT_BY_EFFECTOR, JOINTS

LIMITS = {j.effector: (j.min_deg, j.max_deg) for j in JOINTS}
START = Path(__file__).resolve().parent.parent / "gait" / "walks" / "omni_start.json"
CYCLE = 0.02


@st.composite
def genes(draw: st.DrawFn) -> tuple[float, ...]:
    low, high = OMNI.bounds[:, 0], OMNI.bounds[:, 1]
    unit = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=len(low), max_size=len(low))))
    return tuple(OMNI.repair(low + unit * (high - low), OMNI.bounds).tolist())


commands = st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-400.0, 400.0)).map(lambda c: Command(*c))
gyros = st.tuples(*(st.floats(-500.0, 500.0),) * 3)


def walk(walker: OmniWalker, command: Command, seconds: float, t0: float = 0.04) -> tuple[float, dict[str, float]]:
    """Walks ``command`` for ``seconds`` as the agent asks (a cycle at a time); the last time and targets."""
    walker.command = command
    t, targets = t0, {}
    for k in range(round(seconds / CYCLE)):
        t = t0 + k * CYCLE
        targets = walker.joint_targets(t, LIMITS)
    return t, targets


@settings(max_examples=40, deadline=None)
@given(g=genes(), steps=st.lists(st.tuples(commands, gyros, gyros, st.integers(1, 40)), min_size=1, max_size=4))
def test_targets_stay_inside_the_limits_for_any_genes_and_commands(g, steps) -> None:
    walker = OMNI.gait(g).walker()
    assert isinstance(walker, OmniWalker)
    t = 0.04
    for command, gyro, acc, cycles in steps:
        walker.command = command
        for _ in range(cycles):
            walker.sense(gyro, acc, {})
            targets = walker.joint_targets(t, LIMITS)
            t += CYCLE
            assert set(targets) == set(EFFECTORS)
            for name, value in targets.items():
                low, high = LIMITS[name]
                assert low + LIMIT_MARGIN_DEG - 1e-9 <= value <= high - LIMIT_MARGIN_DEG + 1e-9, name


@settings(max_examples=200, deadline=None)
@given(
    side=st.sampled_from("lr"),
    sole=st.tuples(st.floats(-0.06, 0.06), st.floats(-0.08, 0.08), st.floats(-0.25, -0.15)),
    tilt=st.tuples(st.floats(-20.0, 20.0), st.floats(-20.0, 20.0)),
    yaw=st.floats(-50.0, 50.0),
)
def test_leg_ik_reaches_the_sole_target_it_was_given(side: str, sole, tilt, yaw: float) -> None:
    foot = rot_x(math.radians(tilt[0])) @ rot_y(math.radians(tilt[1])) @ rot_z(math.radians(yaw))
    target = np.array(sole)
    ankle = target - foot @ np.array([0.0, 0.0, -0.05])
    if np.linalg.norm(ankle) > 0.218:  # beyond the thigh and shank's 0.22 m: out of reach
        return
    angles = leg_ik(side, target, foot)
    reached, turned = leg_fk(side, angles)
    assert np.allclose(reached, target, atol=1e-4)
    assert np.allclose(turned, foot, atol=1e-9)


def test_leg_fk_of_the_zero_pose_is_the_model_s_leg() -> None:
    for side in "lr":
        sole, foot = leg_fk(side, np.zeros(6))
        assert np.allclose(sole, [0.0, 0.005, -LEG_LENGTH]) and np.allclose(foot, np.eye(3))
    assert LEG_LENGTH == pytest.approx(0.385 - 0.115)  # soles 0.385 m below the torso, hips 0.115


def test_it_stands_at_time_0_and_again_after_a_stop() -> None:
    walker = load_gait(START).walker()
    assert isinstance(walker, OmniWalker)
    standing = walker.joint_targets(0.04, LIMITS)
    assert walker.joint_targets(0.04, LIMITS) == standing  # settling: the same time, the same pose
    left = np.radians([standing[f"lle{k}"] for k in range(1, 7)])
    right = np.radians([standing[f"rle{k}"] for k in range(1, 7)])
    (ls, lf), (rs, rf) = leg_fk("l", left), leg_fk("r", right)
    assert np.allclose(ls * [-1, 1, 1], rs, atol=1e-6) and ls[0] < 0  # feet side by side, mirrored
    assert np.allclose(lf[2], rf[2]) and abs(lf[2, 2]) > 0.99  # soles flat alike
    t, moving = walk(walker, Command(0.3, 0.1, 20.0), 3.0)
    assert moving != standing and not walker.standing
    _, stopped = walk(walker, Command(), 3.0, t + CYCLE)
    assert walker.standing
    assert stopped == pytest.approx(standing, abs=1e-9)


def test_the_default_command_is_full_forward_and_the_top_speeds_are_the_genes() -> None:
    gait = load_gait(START)
    walker = gait.walker()
    assert isinstance(walker, Steerable)
    p = gait.params
    assert walker.max_command == Command(p["max_forward"], p["max_left"], p["max_turn"])
    assert walker.max_backward == p["max_backward"]
    assert walker.command == Command(p["max_forward"], 0.0, 0.0)


@settings(max_examples=200, deadline=None)
@given(g=genes(), command=commands)
def test_commands_are_clipped_onto_the_top_speeds_direction_kept(g, command: Command) -> None:
    p = OmniParams(*g)
    clipped = clip_command(np.array([command]), p)[0]
    tops = np.array([p.max_forward if command.forward >= 0 else p.max_backward, p.max_left, p.max_turn])
    inside = float(np.sum((np.array(command) / tops) ** 2))
    assert np.sum((clipped / tops) ** 2) <= 1.0 + 1e-9
    assert np.all(np.abs(clipped) <= tops + 1e-12)
    if inside <= 1.0:
        assert np.array_equal(clipped, np.array(command))
    else:
        assert np.allclose(clipped * math.sqrt(inside), command)


#: A calibration far from none: every gain and the sideways turn at work.
CALIBRATION = {"gain_forward": 1.3, "gain_backward": 0.8, "gain_left": 1.2, "gain_turn": 1.4, "side_turn": -45.0}
#: No calibration: the command planned as it is.
UNCALIBRATED = {"gain_forward": 1.0, "gain_backward": 1.0, "gain_left": 1.0, "gain_turn": 1.0, "side_turn": 0.0}


def calibrated(gait: Gait, calibration: dict[str, float] = CALIBRATION) -> Gait:
    return OMNI.gait([calibration.get(name, value) for name, value in gait.params.items()])


@pytest.mark.parametrize("calibrate", [False, True], ids=["uncalibrated", "calibrated"])
@pytest.mark.parametrize(
    "share", [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0)]
)
def test_odometry_is_the_commanded_speed_in_steady_state(share, calibrate: bool) -> None:
    """The odometry is in the commanded speeds whatever the calibration plans for them (it is
    taken back through the same map)."""
    gait = calibrated(load_gait(START)) if calibrate else load_gait(START)
    walker = gait.walker()
    assert isinstance(walker, OmniWalker)
    p = gait.params
    tops = np.array([walker.max_command.forward if share[0] >= 0 else walker.max_backward, *walker.max_command[1:]])
    command = Command(*(0.5 * tops * share))
    t, _ = walk(walker, command, 3.0)  # past the ramp
    walker.moved()
    stride = 2 * p["period"]
    seconds = 4 * stride  # whole strides: a sideways or turning step is every other one
    total = np.zeros(3)
    for k in range(1, round(seconds / CYCLE) + 1):
        walker.joint_targets(t + k * CYCLE, LIMITS)
        moved = walker.moved()
        total += [moved.forward, moved.left, moved.turn]
    expected = np.array(command) * seconds
    # a turn bends the forward and sideways odometry into the turned frame; straight, it is exact
    assert np.allclose(total, expected, atol=1e-9 + 0.02 * abs(expected).max())
    assert np.allclose(total[np.array(share) == 0], 0.0, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(g=genes(), command=commands, cycles=st.integers(1, 60))
def test_the_calibration_plans_its_map_of_the_command_and_takes_odometry_and_tops_back(
    g, command: Command, cycles: int
) -> None:
    """A calibrated walker walking a command is the uncalibrated walker walking the calibration's
    map of it (forward or backward gain, sideways gain, turn gain plus ``side_turn`` per m/s
    sideways): the same targets to the last digit. Its odometry is the uncalibrated one taken
    back through the map, and its top speeds are the genes' divided by the gains."""
    plain, gains = OMNI.gait(g), CALIBRATION
    own, bare = calibrated(plain).walker(), calibrated(plain, UNCALIBRATED).walker()
    assert isinstance(own, OmniWalker) and isinstance(bare, OmniWalker)
    forward_gain = gains["gain_forward"] if command.forward >= 0 else gains["gain_backward"]
    own.command = command
    bare.command = Command(
        command.forward * forward_gain,
        command.left * gains["gain_left"],
        command.turn * gains["gain_turn"] + gains["side_turn"] * command.left,
    )
    for k in range(cycles):
        assert own.joint_targets(0.04 + k * CYCLE, LIMITS) == bare.joint_targets(0.04 + k * CYCLE, LIMITS)
        moved, planned = own.moved(), bare.moved()  # one cycle's: in the frame it began in
        gain = gains["gain_forward"] if planned.forward >= 0 else gains["gain_backward"]
        assert moved.forward == pytest.approx(planned.forward / gain, rel=1e-12, abs=1e-15)
        assert moved.left == pytest.approx(planned.left / gains["gain_left"], rel=1e-12, abs=1e-15)
        assert moved.turn == pytest.approx(
            (planned.turn - gains["side_turn"] * moved.left) / gains["gain_turn"], rel=1e-9, abs=1e-12
        )
    p = plain.params
    assert own.max_command == pytest.approx(
        (
            p["max_forward"] / gains["gain_forward"],
            p["max_left"] / gains["gain_left"],
            p["max_turn"] / gains["gain_turn"],
        )
    )
    assert own.max_backward == pytest.approx(p["max_backward"] / gains["gain_backward"])


def test_the_start_gait_walks_forward_on_the_stand_in_without_falling() -> None:
    gait = load_gait(START)
    assert gait.family is OMNI
    with EpisodeRunner(EpisodeConfig(family="omni", walk_time=4.0)) as runner:
        result = runner.evaluate(gait, trace=True)
    assert result.status == "ok" and not result.fell
    assert result.distance > 0.25 * 4.0 * gait.params["max_forward"]
    assert abs(result.heading_change or 0.0) < 20.0


@settings(max_examples=30, deadline=None)
@given(g=genes())
def test_omni_gaits_round_trip_through_gait_files(g, tmp_path_factory) -> None:
    gait = OMNI.gait(g)
    path = save_gait(gait, tmp_path_factory.mktemp("omni") / "g.json")
    assert load_gait(path) == gait


def test_a_gait_file_of_19_omni_genes_loads_as_the_same_walk(tmp_path: Path) -> None:
    """Files written before ``lag_comp`` (19 genes, their units) load with it 0 and with no
    calibration (gains 1, ``side_turn`` 0), which walks as they walked; so do those of 20 genes."""
    gait = load_gait(START)
    assert gait.params["lag_comp"] == 0.0 and all(gait.params[k] == v for k, v in UNCALIBRATED.items())
    document = json.loads(START.read_text())
    old = tmp_path / "old.json"
    for name in reversed(OMNI.gene_names[19:]):
        for key in ("units", "params"):
            document[key].pop(name, None)
        old.write_text(json.dumps(document))
        assert load_gait(old) == gait
    del document["params"]["tilt_roll"]  # only the gene added since may be missing
    old.write_text(json.dumps(document))
    with pytest.raises(GaitFileError, match="tilt_roll"):
        load_gait(old)


def test_the_family_is_registered_after_the_default_and_its_box_holds_the_robot() -> None:
    assert FAMILIES["omni"] is OMNI and DEFAULT_FAMILY == "tfs" and list(FAMILIES)[-1] == "omni"
    box = dict(zip(OMNI.gene_names, OMNI.bounds))
    assert box["hip_height"][1] < LEG_LENGTH  # the knee can always bend further
    assert box["period"][0] >= 4 * CYCLE  # a step gives each joint several commands
    with pytest.raises(ValueError, match="hip_height"):
        OMNI.gait([*load_gait(START).genes[:1], 0.3, *load_gait(START).genes[2:]])
    repaired = OMNI.repair(np.full(len(OMNI.gene_names), 1e6), OMNI.bounds)
    OMNI.gait(repaired)
    assert JOINT_BY_EFFECTOR["lle1"].max_deg == 1.0  # le1 turns a foot outwards only: the leading foot turns


def test_many_robots_step_at_once_as_each_alone() -> None:
    """The per-cycle math takes a robot axis: three robots with their own genes, commands and
    gyros, stepped together, get the targets and odometry each gets alone."""
    rng = np.random.default_rng(5)
    low, high = OMNI.bounds[:, 0], OMNI.bounds[:, 1]
    genes = low + rng.random((3, len(low))) * (high - low)
    commands = np.array([[0.3, 0.1, 20.0], [-0.2, -0.1, -30.0], [0.0, 0.2, 0.0]])
    gyros = rng.normal(0.0, 30.0, (3, 3))
    tilts = rng.normal(0.0, 10.0, (3, 2))
    together = standing(3)
    params = OmniParams(*genes.T)
    alone = [standing(1) for _ in range(3)]
    for _ in range(60):
        together, odometry = advance(together, CYCLE, clip_command(commands, params), params)
        angles = joint_angles(together, clip_command(commands, params), params, gyros, tilts)
        for k in range(3):
            p = OmniParams(*genes[k])
            alone[k], own = advance(alone[k], CYCLE, clip_command(commands[k : k + 1], p), p)
            assert np.allclose(own[0], odometry[k]) and np.allclose(
                joint_angles(alone[k], clip_command(commands[k : k + 1], p), p, gyros[k : k + 1], tilts[k : k + 1])[0],
                angles[k],
            )


def test_lag_comp_leads_the_planned_targets_by_their_rate() -> None:
    """Three robots walking mixed commands: with ``lag_comp`` 0 the targets are the planned ones
    plus the feedback; with it > 0 they lead the planned ones by ``lag_comp`` times their change
    over the next cycle under the same command, per second (a finite difference of two
    ``planned_angles``)."""
    rng = np.random.default_rng(7)
    low, high = OMNI.bounds[:, 0], OMNI.bounds[:, 1]
    genes = low + rng.random((3, len(low))) * (high - low)
    lag_comp = np.array([0.0, 0.067, 0.1])
    genes[:, OMNI.gene_names.index("lag_comp")] = lag_comp
    p = OmniParams(*genes.T)
    command = clip_command(np.array([[0.3, 0.1, 20.0], [-0.2, -0.1, -30.0], [0.0, 0.2, 0.0]]), p)
    gyros, tilts = rng.normal(0.0, 30.0, (3, 3)), rng.normal(0.0, 10.0, (3, 2))
    state, led = standing(3), 0.0
    for _ in range(40):
        state, _ = advance(state, CYCLE, command, p)
        planned = planned_angles(state, p)
        rate = (planned_angles(advance(state, RATE_STEP, command, p)[0], p) - planned) / RATE_STEP
        angles, feedback = joint_angles(state, command, p, gyros, tilts), feedback_angles(p, gyros, tilts)
        assert np.allclose(angles[0], planned[0] + feedback[0], rtol=0.0, atol=1e-12)
        assert np.allclose(angles, planned + lag_comp[:, None] * rate + feedback, rtol=0.0, atol=1e-9)
        led = max(led, float(np.abs(lag_comp[1:, None] * rate[1:]).max()))
    assert led > 1.0  # the lead moved the targets by degrees


def test_the_tilt_is_read_from_gravity_in_the_accelerometer() -> None:
    upright, face_down, on_right_side = tilt(np.array([[0.0, 0.0, 9.81], [0.0, -9.8, 1.0], [-9.81, 0.0, 0.0]]))
    assert np.allclose(upright, 0.0) and face_down[0] > 80.0 and on_right_side[1] == pytest.approx(90.0)
