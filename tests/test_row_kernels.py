"""The per-cycle kernels over robot rows (a row per robot, as lanes will run them) against the
one-robot code they replaced in the agent's cycle, which stays as their reference: the same
floats, row by row, whatever the other rows hold."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from agent.controller import velocities_into, velocities_towards
from gait import GENE_BOUNDS, TFSGait, TFSParams, leg_joint_targets, repair_genes
from gait.nao_legs import LEG_EFFECTORS, leg_limits, leg_targets_into
from gait.tfs import angles_into, gait_rows
from optimizer.episode.rounding import perception_numbers
from protocol.nao import JOINT_BY_EFFECTOR

LIMITS = {name: (j.min_deg, j.max_deg) for name, j in JOINT_BY_EFFECTOR.items()}
#: the first call of a kernel in a process loads it: no deadline
_NO_DEADLINE = settings(deadline=None, max_examples=60)


@st.composite
def tfs_params(draw: st.DrawFn) -> TFSParams:
    genes = [draw(st.floats(lo, hi, allow_nan=False)) for lo, hi in GENE_BOUNDS]
    return TFSParams.from_array(repair_genes(np.array(genes)))


def _bits(a) -> bytes:
    return np.asarray(a, dtype=float).tobytes()


@_NO_DEADLINE
@given(st.lists(st.tuples(tfs_params(), st.floats(-50.0, 50.0, allow_nan=False)), min_size=1, max_size=5))
def test_tfs_rows_give_each_gait_its_own_angles_and_targets(walks) -> None:
    """Several gaits at several times in one call: each row the angles ``TFSGait.angles`` gives
    and the targets ``leg_joint_targets`` gives, to the bit."""
    rows = np.concatenate([gait_rows(p) for p, _ in walks])
    times = np.array([t for _, t in walks])
    angles = np.empty((len(walks), 4))
    angles_into(rows, times, angles)
    low, high = leg_limits(LIMITS)
    targets = np.empty((len(walks), len(LEG_EFFECTORS)))
    leg_targets_into(angles, low, high, targets)
    for (params, t), row, target in zip(walks, angles, targets):
        alone = TFSGait(params).angles(t)
        assert _bits(row) == _bits(list(alone))
        reference = leg_joint_targets(alone, LIMITS)
        assert _bits(target) == _bits([reference[name] for name in LEG_EFFECTORS])


finite = st.floats(-1e4, 1e4, allow_nan=False)


@_NO_DEADLINE
@given(
    st.lists(
        st.tuples(st.lists(st.tuples(finite, finite), min_size=22, max_size=22), st.floats(0.1, 50.0)),
        min_size=1,
        max_size=4,
    )
)
def test_the_velocity_law_over_rows_is_the_array_law_of_each_robot(robots) -> None:
    targets = np.array([[t for t, _ in joints] for joints, _ in robots])
    perceived = np.array([[p for _, p in joints] for joints, _ in robots])
    gains = np.array([gain for _, gain in robots])
    out = np.empty_like(targets)
    velocities_into(targets, perceived, gains, out)
    for r, gain in enumerate(gains):
        assert _bits(out[r]) == _bits(velocities_towards(targets[r], perceived[r], float(gain)))


@_NO_DEADLINE
@given(
    st.lists(st.floats(-1e7, 1e7, allow_nan=False), min_size=8, max_size=8),
    st.lists(st.floats(-7.0, 7.0, allow_nan=False), min_size=22, max_size=22),
)
def test_perception_numbers_are_printed_as_round_to_two_decimals(sensed, radians) -> None:
    """Every number as ``%.2f`` prints it: Python's ``round(v, 2)`` of it, the joints after
    ``np.degrees`` (numbers next to a half included: they take Python's own rounding)."""
    out = perception_numbers(np.array([sensed]), np.array([radians]))
    expected = [round(v, 2) for v in sensed] + [round(float(v), 2) for v in np.degrees(np.array(radians))]
    assert _bits(out[0]) == _bits(expected)


def test_perception_numbers_keep_halves_and_non_finite_numbers_as_printing_does() -> None:
    sensed = np.array([[0.125, 0.135, 2.675, -1.005, np.inf, -np.inf, np.nan, 1e300]])
    out = perception_numbers(sensed, np.zeros((1, 22)))
    expected = [round(float(v), 2) for v in sensed[0]]
    assert np.array_equal(out[0, :8], expected, equal_nan=True)
    assert (out[0, 8:] == 0.0).all()
