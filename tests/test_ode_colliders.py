"""The stand-in's ground contacts against libode's own plane colliders: libode 0.16.2 is what the
real rcssserver3d links, and a contact point more or less changes a landing foot's step (a foot
landing on an edge gets 3 points from ODE; 4 kept a gait walking that falls on the real server).

Two checks: the stored libode answers (``tests/data/libode``, made by ``tests/libode_colliders.py``)
always; fresh random poses against the library itself where it is installed (the real server's
build installs it; CI sets ``GALA_REQUIRE_REAL_SERVER=1`` and so must have it)."""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from server_stub.config import PhysicsConfig
from server_stub.physics import collision
from server_stub.physics.rotations import rotation_into
from tests.conftest import missing_real_server_part
from tests.libode_colliders import BOX, CAPSULE, FIXTURE, SPHERE, LibOde, random_pose

_KINDS = {BOX: collision.BOX, SPHERE: collision.SPHERE, CAPSULE: collision.CAPSULE}


def _ours(case: dict) -> list[tuple[np.ndarray, float]]:
    if case["kind"] == BOX:  # on libode's own rotation matrix, so near-ties break the same way
        points, depths = collision.box_plane(
            np.array(case["centre"]), np.array(case["rotation"]), np.array(case["size"]), case["max_points"]
        )
    else:
        _, points, depths = collision.ground_contacts(
            np.array([0], dtype=np.int64),
            np.array([_KINDS[case["kind"]]], dtype=np.int64),
            np.array([case["size"]], dtype=float),
            np.array([case["centre"]], dtype=float),
            np.array([case["quat"]], dtype=float),
            case["max_points"],
        )
    return list(zip(points, depths))


def _assert_same(case: dict, reference: list) -> None:
    ours = _ours(case)
    assert len(ours) == len(reference), (case, ours, reference)
    # in ODE's order: a box's deepest corner, its neighbours, the fourth; a capsule's lower end first
    for (point, depth), (ref_point, ref_depth) in zip(ours, reference):
        assert np.allclose(point, ref_point, rtol=0, atol=1e-9), (case, ours, reference)
        assert depth == pytest.approx(ref_depth, abs=1e-9), (case, ours, reference)


def test_ground_contacts_equal_stored_libode_answers():
    cases = json.loads(FIXTURE.read_text())["cases"]
    assert len(cases) >= 1000
    for case in cases:
        _assert_same(case, case["contacts"])
    # the stored set has what matters: boxes with 3 and with 4 points, and boxes ODE leaves at 3
    boxes = [c for c in cases if c["kind"] == BOX and c["max_points"] == 4]
    counts = {n: sum(len(c["contacts"]) == n for c in boxes) for n in range(5)}
    assert counts[3] > 10 and counts[4] > 50


def test_a_foot_landing_on_its_edge_gets_three_points_not_the_far_corner():
    """The 6-Hz shuffle gait's right foot at its second landing (the stand-in's state, rounded):
    25.7 mm deep at its outer heel corner. Four of its corners are below the ground, the fourth
    0.15 mm deep at the toe; ODE gives 3 points (the face's fourth corner is above the ground).
    With 3 the stand-in's next perception equals the real server's to 0.01 deg; with 4 the right
    knee and hip differ by 13 and 7.5 deg and the gait walks where the real server falls."""
    centre = np.array([-4.95067, -0.05272, 0.002466])
    quat = np.array([0.10657, -0.01095, -0.73022, 0.67477])
    size = np.array([0.08, 0.16, 0.02])
    _, points, depths = collision.ground_contacts(
        np.array([0], dtype=np.int64),
        np.array([collision.BOX], dtype=np.int64),
        size[None],
        centre[None],
        quat[None] / np.linalg.norm(quat),
        4,
    )
    rotation = np.empty((3, 3))
    rotation_into(quat / np.linalg.norm(quat), rotation)
    corners = [centre + rotation @ ((2 * np.array(signs) - 1) * size / 2) for signs in np.ndindex(2, 2, 2)]
    below = sorted(-c[2] for c in corners if c[2] < 0.0)
    assert len(below) == 4 and below[0] < 0.0002
    assert np.allclose(depths, [0.025724, 0.014455, 0.006183], atol=1e-6)
    assert depths[1] + depths[2] - depths[0] <= 0.0  # the face's fourth corner, above the ground


@pytest.mark.parametrize("points", [0, 5])
def test_more_box_points_than_ode_makes_are_refused(points: int) -> None:
    with pytest.raises(ValueError, match="ode_box_points"):
        PhysicsConfig(ode_box_points=points)


@functools.cache
def _libode() -> LibOde:
    try:
        return LibOde()
    except OSError as exc:
        missing_real_server_part(f"libode, which the real server's build installs (libode8): {exc}")


@pytest.mark.real_server
@settings(max_examples=400, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from([BOX, BOX, SPHERE, CAPSULE]), max_points=st.integers(1, 4))
def test_ground_contacts_equal_libode_on_random_poses(seed, kind, max_points):
    ode = _libode()
    pose = random_pose(np.random.default_rng(seed), kind)
    rotation, found = ode.contacts(pose["kind"], pose["size"], pose["centre"], pose["quat"], max_points)
    _assert_same({**pose, "max_points": max_points, "rotation": rotation.tolist()}, found)
