"""The TFS gait: eq. 3-5 as docs/gait_families.md reads them, the NAO mapping and the gait files."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gait import (
    DEFAULT_GAIT_PATH,
    GENE_BOUNDS,
    GENE_NAMES,
    TFS,
    GaitFileError,
    LegAngles,
    TFSGait,
    TFSParams,
    leg_joint_targets,
    load_gait,
    repair_genes,
    save_gait,
)
from gait.nao_legs import LIMIT_MARGIN_DEG, clamped
from protocol.nao import JOINT_BY_EFFECTOR

LIMITS = {name: (j.min_deg, j.max_deg) for name, j in JOINT_BY_EFFECTOR.items()}


@st.composite
def tfs_params(draw: st.DrawFn) -> TFSParams:
    genes = [draw(st.floats(lo, hi, allow_nan=False)) for lo, hi in GENE_BOUNDS]
    return TFSParams.from_array(repair_genes(np.array(genes)))


times = st.floats(-50.0, 50.0, allow_nan=False)


@given(tfs_params(), times)
def test_signal_is_periodic_with_period_2pi_over_w(p: TFSParams, t: float) -> None:
    gait = TFSGait(p)
    a, b = gait.angles(t), gait.angles(t + p.period)
    assert np.allclose(a, b, atol=1e-7)


@given(tfs_params(), times)
def test_right_leg_is_left_leg_half_a_period_later(p: TFSParams, t: float) -> None:
    gait = TFSGait(p)
    now, later = gait.angles(t), gait.angles(t + p.period / 2)
    assert math.isclose(now.right_hip, later.left_hip, abs_tol=1e-7)
    assert math.isclose(now.right_knee, later.left_knee, abs_tol=1e-7)


@given(tfs_params(), st.integers(-20, 20))
def test_continuous_at_every_portion_boundary(p: TFSParams, k: int) -> None:
    gait = TFSGait(p)
    eps = 1e-7
    boundaries = [k * p.period, k * p.period + p.period / 2, k * p.period + p.t2, k * p.period + p.t2 + p.period / 2]
    for t in boundaries:
        # the slope is bounded by w * max amplitude, so eps * slope bounds an honest jump-free step
        slope = p.w * max(p.A, p.B, p.C) + 1
        assert abs(gait.hip(t - eps) - gait.hip(t + eps)) <= 2 * eps * slope + 1e-9
        assert abs(gait.knee(t - eps) - gait.knee(t + eps)) <= 2 * eps * slope + 1e-9


@given(tfs_params(), times)
def test_knee_never_below_its_lock_and_bump_bounded(p: TFSParams, t: float) -> None:
    knee = TFSGait(p).knee(t)
    assert p.c_k - 1e-9 <= knee <= p.c_k + p.C + 1e-9


def test_portions_use_their_own_amplitude() -> None:
    p = TFSParams(c_h=5, c_k=10, A=20, B=8, C=30, t2=0.1, w=2 * math.pi)
    gait = TFSGait(p)
    assert gait.hip(0.25) == pytest.approx(5 + 20)  # peak of the upper portion
    assert gait.hip(0.75) == pytest.approx(5 - 8)  # trough of the lower portion
    assert gait.knee(0.1 + 0.25) == pytest.approx(40)  # middle of the bump, T/4 after t2
    assert gait.knee(0.1 + 0.6) == pytest.approx(10)  # locked outside the bump


@given(tfs_params(), times)
def test_nao_targets_respect_limits_and_keep_foot_flat(p: TFSParams, t: float) -> None:
    angles = TFSGait(p).angles(t)
    targets = leg_joint_targets(angles, LIMITS)
    for name, value in targets.items():
        low, high = LIMITS[name]
        assert low + LIMIT_MARGIN_DEG - 1e-9 <= value <= high - LIMIT_MARGIN_DEG + 1e-9
    for side in "lr":
        hip, knee, ankle = (targets[f"{side}le{i}"] for i in (3, 4, 5))
        raw_ankle = -(hip + knee)
        if LIMITS[f"{side}le5"][0] + LIMIT_MARGIN_DEG < raw_ankle < LIMITS[f"{side}le5"][1] - LIMIT_MARGIN_DEG:
            assert ankle == pytest.approx(raw_ankle)


def test_mapping_signs_follow_the_facts_sheet() -> None:
    targets = leg_joint_targets(LegAngles(20.0, 40.0, -10.0, 0.0), LIMITS)
    assert targets["lle3"] == 20.0 and targets["lle4"] == -40.0 and targets["lle5"] == 20.0
    assert targets["rle3"] == -10.0 and targets["rle4"] == pytest.approx(0.0)
    assert targets["rle5"] == pytest.approx(10.0)


@pytest.mark.parametrize(
    "field, value, words",
    [("t2", 0.0, "t2"), ("t2", 0.5, "t2"), ("c_k", -1.0, "c_k"), ("w", 0.0, "w"), ("A", float("nan"), "A")],
)
def test_eq5_violations_name_the_parameter(field: str, value: float, words: str) -> None:
    base = dict(c_h=15.0, c_k=30.0, A=10.0, B=10.0, C=20.0, t2=0.35, w=2 * math.pi / 0.4)
    base[field] = value
    with pytest.raises(ValueError, match=rf"\b{words}\b"):
        TFSParams(**base)


@given(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=7, max_size=7))
def test_repair_always_gives_a_valid_gait_inside_bounds(values: list[float]) -> None:
    genes = repair_genes(np.array(values))
    assert np.all(genes >= GENE_BOUNDS[:, 0]) and np.all(genes <= GENE_BOUNDS[:, 1])
    TFSParams.from_array(genes)  # raises if eq. 5 is violated


def test_default_gait_is_the_real_server_calibration_walk() -> None:
    gait = load_gait()
    assert gait.family is TFS
    p = TFSParams.from_array(gait.genes)
    assert (p.c_h, p.c_k, p.A, p.B, p.C, p.t2) == (15, 30, 10, 10, 20, 0.35)
    assert p.period == pytest.approx(0.4)


def test_gait_file_round_trip(tmp_path) -> None:
    gait = TFS.gait([12.5, 3.0, 7.0, 9.0, 33.0, 0.2, 12.0])
    path = save_gait(gait, tmp_path / "g.json", notes="test")
    assert load_gait(path) == gait
    document = json.loads(path.read_text())
    assert document["units"]["w"] == "rad/s" and document["family"] == "tfs" and document["format"] == "gait/2"
    # the first format (no family) still loads, as the paper's TFS
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"format": "tfs-gait/1", "units": document["units"], "params": document["params"]}))
    assert load_gait(old) == gait


@pytest.mark.parametrize(
    "content, words",
    [
        ("not json", "not valid JSON"),
        ('{"format": "other"}', "format"),
        ('{"format": "tfs-gait/1", "params": {"c_h": 1}}', "missing parameters"),
        (
            '{"format": "tfs-gait/1", "units": {"t2": "ms"}, '
            '"params": {"c_h": 15, "c_k": 30, "A": 10, "B": 10, "C": 20, "t2": 0.35, "w": 15.7}}',
            "units",
        ),
        (
            '{"format": "tfs-gait/1", '
            '"params": {"c_h": 15, "c_k": -3, "A": 10, "B": 10, "C": 20, "t2": 0.35, "w": 15.7}}',
            "c_k",
        ),
        ('{"format": "gait/2", "family": "hexapod", "params": {}}', "unknown gait family 'hexapod'; known: tfs"),
        ('{"format": "gait/2", "family": "tfs", "params": {"c_h": "15"}}', "missing parameters"),
        (
            '{"format": "gait/2", "family": "tfs", '
            '"params": {"c_h": "a", "c_k": 30, "A": 10, "B": 10, "C": 20, "t2": 0.35, "w": 15.7}}',
            "c_h must be a finite number",
        ),
    ],
)
def test_bad_gait_files_are_refused_with_the_reason(tmp_path, content: str, words: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(GaitFileError, match=words):
        load_gait(path)


def test_missing_gait_file_names_the_path(tmp_path) -> None:
    with pytest.raises(GaitFileError, match="nope.json"):
        load_gait(tmp_path / "nope.json")


def test_gene_names_match_the_dataclass() -> None:
    assert GENE_NAMES == tuple(TFSParams.__dataclass_fields__)
    assert DEFAULT_GAIT_PATH.is_file()


def test_the_gene_box_comes_from_the_robot() -> None:
    """Offsets span the joints' ranges, amplitudes what the joints can follow at the slowest
    stride, strides 8 control cycles up to the one where the widest swing meets the speed cap;
    the facts are the ones the wire package holds (``gait`` does not import it)."""
    from protocol import nao

    hip = nao.JOINT_BY_EFFECTOR["lle3"]
    knee = nao.JOINT_BY_EFFECTOR["lle4"]
    c_h, c_k, a, b, c, t2, w = GENE_BOUNDS
    assert tuple(c_h) == (hip.min_deg, hip.max_deg)
    assert tuple(c_k) == (0.0, -knee.min_deg) and tuple(c) == (0.0, -knee.min_deg)
    assert a[1] == b[1] == (hip.max_deg - hip.min_deg) / 2
    assert w[1] == pytest.approx(2 * math.pi / (8 * nao.CYCLE))
    assert math.radians(a[1]) * w[0] == pytest.approx(nao.SPEED_CAP)  # the widest swing at the slowest stride
    assert t2[1] == pytest.approx(2 * math.pi / w[0])


@pytest.mark.parametrize(
    "genes",
    [
        (14.95, 16.83, 37.56, 24.10, 89.0, 0.2346, 22.44),  # the fastest TFS walk known on the real server
        (15.0, 30.0, 10.0, 10.0, 20.0, 0.35, 15.708),  # the shipped calibration walk
    ],
)
def test_known_real_walks_lie_inside_the_box(genes) -> None:
    assert np.all(np.array(genes) >= GENE_BOUNDS[:, 0]) and np.all(np.array(genes) <= GENE_BOUNDS[:, 1])
    assert list(repair_genes(np.array(genes))) == pytest.approx(list(genes))


_ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True)


@given(value=_ANY_FLOAT, low=_ANY_FLOAT, high=_ANY_FLOAT)
def test_clamped_gives_min_of_max_to_the_bit(value: float, low: float, high: float) -> None:
    """Every joint target goes through ``clamped``; it must be ``min(max(v, lo), hi)`` for any
    floats, NaN, infinities, signed zeros and ties included, or the walks would change."""
    expected, got = min(max(value, low), high), clamped(value, low, high)
    assert repr(got) == repr(expected) and math.copysign(1.0, got) == math.copysign(1.0, expected)
