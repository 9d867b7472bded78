"""Contacts Bullet finds on pybullet's links, carried onto the step's own bodies
(``server_stub.physics.stepper``): a pile's hundreds of points in one stacked product must give
the numbers a product per point gives, bit for bit, so that a pile is solved as it was."""

from __future__ import annotations

import numpy as np
import pybullet as pb
from hypothesis import given, settings
from hypothesis import strategies as st

from server_stub.physics.bundles import State
from server_stub.physics.stepper import _Frames

_unit = st.floats(-1.0, 1.0, allow_nan=False)
_quat = st.tuples(_unit, _unit, _unit, _unit).filter(lambda q: sum(x * x for x in q) > 0.1)
_vec = st.tuples(*[st.floats(-5.0, 5.0, allow_nan=False)] * 3)


def _rotation(q) -> np.ndarray:
    return np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)


class _Links:
    """A robot as the carry asks it: each link's (centre, quaternion) in pybullet."""

    def __init__(self, frames: dict[int, tuple]) -> None:
        self.frames = frames

    def link_frame(self, link: int) -> tuple:
        return self.frames[link]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(_vec, _quat, _vec, _quat), min_size=3, max_size=3),
    st.lists(st.tuples(st.integers(-1, 2), _vec), min_size=1, max_size=12),
    st.integers(0, 4),
)
def test_carried_points_and_directions_are_those_of_a_product_per_point(links, points, offset) -> None:
    """An island of a three-body robot from body ``offset`` and the ball after it (link 2 here).
    Each point on the robot: its body's centre + its body's rotation x (its link's rotation^T x
    (point - link centre)); each direction: the two rotations alone; equal to the last bit. The
    ball's are its own."""
    frames = {k - 1: (centre, quat) for k, (centre, quat, _, _) in enumerate(links)}
    n = offset + 4
    pos = np.zeros((n, 3))
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    for k, (_, _, body_pos, body_quat) in enumerate(links):
        pos[offset + k] = body_pos
        quats[offset + k] = np.array(body_quat) / np.linalg.norm(body_quat)
    state = State(pos, quats, np.zeros((n, 3)), np.zeros((n, 3)))
    carrier = _Frames(state, [(_Links(frames), offset, 3), (None, offset + 3, 1)])
    bodies = np.array([offset + link + 1 for link, _ in points], dtype=np.int64)
    vectors = np.array([v for _, v in points], dtype=float)
    carried = carrier.carry(bodies, vectors, points=True)
    turned = carrier.carry(bodies, vectors, points=False)
    for row, (link, v) in enumerate(points):
        if link == 2:  # the ball
            assert np.array_equal(carried[row], v) and np.array_equal(turned[row], v)
            continue
        centre, quat = frames[link]
        to_link, to_body = _rotation(quat).T, _rotation(quats[offset + link + 1])
        expected = pos[offset + link + 1] + to_body @ (to_link @ (np.asarray(v) - np.asarray(centre, dtype=float)))
        assert np.array_equal(carried[row], expected)
        assert np.array_equal(turned[row], to_body @ (to_link @ np.asarray(v)))
