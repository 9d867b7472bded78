"""Collision: where contacts are, as the real server's colliders make them.

- The ground: ODE 0.16's plane colliders (``ground_contacts``), only for touching or overlapping
  geometry; a box by ODE's box-plane rule (``box_plane``: the deepest corner, at most two
  neighbours and, SimSpark asking for 4, the face's fourth corner), a sphere at its lowest point,
  a capsule at its two ends. ``tests/test_ode_colliders.py`` checks them against libode itself.
- The field's static boxes (``static_boxes``): the goals' side boxes, back walls and top plates,
  and the four border walls, as goal.rsg and soccer.rsg build them.
- ``far_apart``: whether robots, the ball and the boxes are too far apart to touch, so that
  Bullet's collision pass (robot-robot, robot-ball and robot-box contacts, ``stepper``) can be
  skipped on the usual cycle of a lone walker.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub import field
from server_stub.physics.rotations import rotation_into

BOX = 3


SPHERE = 2


CAPSULE = 7


@njit(cache=True)
def box_plane(c, r, size, max_points):
    """ODE 0.16's box-plane contacts (plane z = 0, normal +z), at most ``max_points`` (<= 4): the
    deepest corner; the corner one side away along the side whose projection on the normal is
    shortest, as deep as the first less that projection; the corner one side away from the first
    along the side with the next shortest projection, as deep as the first less its projection;
    each only while that depth is >= 0. With 4 asked and those 3 made, the face's fourth corner
    (second + third - first), as deep as their depths' sum less the first's, only if that is > 0.
    So a box landing on an edge touches at 3 corners, never at the corner along its longest
    projection, however deep. Equal to libode 0.16.2's dCollide on 160,000 random poses to 1e-12
    (a scratch check; ``tests/test_ode_colliders.py`` keeps checking it). Returns (points, depths)."""
    a = np.empty(3)
    bb = np.empty(3)
    p = c.copy()
    for i in range(3):
        a[i] = size[i] * r[2, i]
        bb[i] = abs(a[i])
        sign = -0.5 if a[i] > 0.0 else 0.5
        for q in range(3):
            p[q] += sign * size[i] * r[q, i]
    depth = 0.5 * (bb[0] + bb[1] + bb[2]) - c[2]
    points = np.empty((4, 3))
    depths = np.empty(4)
    if depth < 0.0:
        return points[:0], depths[:0]
    for q in range(3):  # not ``points[0] = p``: numba would compile broadcasting for it
        points[0, q] = p[q]
    depths[0] = depth
    # the two sides with the shortest projections, ties broken as ODE's comparisons break them
    if bb[0] < bb[1]:
        if bb[2] < bb[0]:
            first, second = 2, 0
        else:
            first, second = 0, (1 if bb[1] < bb[2] else 2)
    else:
        if bb[2] < bb[1]:
            first, second = 2, 1
        else:
            first, second = 1, (0 if bb[0] < bb[2] else 2)
    n = 1
    for side in (first, second):
        if n >= max_points or depth - bb[side] < 0.0:
            break
        sign = 1.0 if a[side] > 0.0 else -1.0
        for q in range(3):
            points[n, q] = p[q] + sign * size[side] * r[q, side]
        depths[n] = depth - bb[side]
        n += 1
    if max_points >= 4 and n == 3:
        d4 = depths[1] + depths[2] - depth
        if d4 > 0.0:
            for q in range(3):
                points[3, q] = points[1, q] + points[2, q] - p[q]
            depths[3] = d4
            n = 4
    return points[:n], depths[:n]


@njit(cache=True)
def ground_contacts(shape_body, shape_kind, shape_size, coms, quats, max_points):
    """Contacts of a robot's shapes with the ground plane z = 0, as ODE's colliders make them:
    only for touching or overlapping geometry (depth >= 0); a box gets ODE's box-plane contacts
    (``box_plane``, at most ``max_points``, as many as SimSpark asks ODE for: 4); a sphere its
    lowest point; a capsule (size: length, radius, along its z) the lowest point of its lower end,
    then of the other (ODE's order). Shapes sit at their body's centre with its axes. Returns
    (body, point (n x 3), depth) per contact; the normal is +z."""
    n = shape_body.shape[0]
    cap = n * max(max_points, 2)
    bodies = np.empty(cap, dtype=np.int64)
    points = np.empty((cap, 3))
    depths = np.empty(cap)
    count = 0
    r = np.empty((3, 3))
    for s in range(n):
        k = shape_body[s]
        rotation_into(quats[k], r)
        c = coms[k]
        kind = shape_kind[s]
        if kind == BOX:
            bp, bd = box_plane(c, r, shape_size[s], max_points)
            for i in range(bd.shape[0]):
                bodies[count] = k
                for d in range(3):  # not points[count] = bp[i]: a row copy compiles numba's shape error, ~4 s
                    points[count, d] = bp[i, d]
                depths[count] = bd[i]
                count += 1
        elif kind == SPHERE:
            rad = shape_size[s, 0]
            if c[2] - rad <= 0.0:
                bodies[count] = k
                points[count, 0] = c[0]
                points[count, 1] = c[1]
                points[count, 2] = c[2] - rad
                depths[count] = rad - c[2]
                count += 1
        elif kind == CAPSULE:
            # ODE's capsule-plane: the lower end's sphere first (none at all if it is clear of
            # the ground), then the other end's if at least 2 are asked for and it touches too
            half = shape_size[s, 0] / 2 * (-1.0 if r[2, 2] > 0.0 else 1.0)
            rad = shape_size[s, 1]
            for end in range(min(max_points, 2)):
                side = half if end == 0 else -half
                e2 = c[2] + r[2, 2] * side
                if e2 - rad > 0.0:
                    break
                bodies[count] = k
                points[count, 0] = c[0] + r[0, 2] * side
                points[count, 1] = c[1] + r[1, 2] * side
                points[count, 2] = e2 - rad
                depths[count] = rad - e2
                count += 1
    return bodies[:count], points[:count], depths[:count]


@njit(cache=True)
def far_apart(pos, owner, count, ball, reach, ball_reach, static_lo, static_hi):
    """Whether no two of ``count`` robots (their bodies' centres ``pos``, body b of robot
    ``owner[b]``, each grown by ``reach``), the ball (grown by ``ball_reach``) and the static boxes
    (``static_lo``/``static_hi`` corners) have overlapping boxes: then nothing can touch."""
    lo = np.full((count + 1, 3), np.inf)
    hi = np.full((count + 1, 3), -np.inf)
    for b in range(pos.shape[0]):
        o = owner[b]
        for d in range(3):
            lo[o, d] = min(lo[o, d], pos[b, d] - reach)
            hi[o, d] = max(hi[o, d], pos[b, d] + reach)
    for d in range(3):
        lo[count, d] = ball[d] - ball_reach
        hi[count, d] = ball[d] + ball_reach
    for i in range(count + 1):
        for j in range(i + 1, count + 1):
            if boxes_overlap(lo[i], hi[i], lo[j], hi[j]):
                return False
        for s in range(static_lo.shape[0]):
            if boxes_overlap(lo[i], hi[i], static_lo[s], static_hi[s]):
                return False
    return True


@njit(cache=True)
def boxes_overlap(lo_a, hi_a, lo_b, hi_b):
    return (
        lo_a[0] <= hi_b[0]
        and lo_b[0] <= hi_a[0]
        and lo_a[1] <= hi_b[1]
        and lo_b[1] <= hi_a[1]
        and lo_a[2] <= hi_b[2]
        and lo_b[2] <= hi_a[2]
    )


#: SimSpark's goal and field geometry (goal.rsg, soccer.rsg, naosoccersim.rb): the goals' bar
#: diameter, the border walls' size and distance.
_BAR = 0.04


_SIDE_EXT = 1.0


_BORDER_LENGTH = field.LENGTH * 0.333


_BORDER_WIDTH = field.WIDTH * 0.75


def static_boxes() -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """(half extents, centre) of the static boxes that make contacts on the real server: per goal
    the two side boxes ("posts", goal depth x bar x goal height), the back wall and the top plate
    (goal.rsg, the goal box centred at the goal line + half its depth), and the four border walls
    (soccer.rsg, 1 m thick, centred on the ground)."""
    depth, width, height = field.GOAL_DEPTH, field.GOAL_WIDTH, field.GOAL_HEIGHT
    boxes = []
    for side in (-1.0, 1.0):
        cx = side * (field.LENGTH / 2 + depth / 2)
        for y in (-1.0, 1.0):
            boxes.append(((depth / 2, _BAR / 2, height / 2), (cx, y * (width / 2 + _BAR / 2), height / 2)))
        boxes.append(((_BAR / 2, width / 2, height / 2), (cx + side * (depth / 2 - _BAR / 2), 0.0, height / 2)))
        boxes.append(((depth / 2, width / 2 + _BAR, _BAR / 2), (cx, 0.0, height + _BAR / 2)))
    side_width = _SIDE_EXT + field.WIDTH + 2 * _BORDER_WIDTH
    side_length = _SIDE_EXT + field.LENGTH + 2 * _BORDER_LENGTH
    for side in (-1.0, 1.0):
        boxes.append(
            ((_SIDE_EXT / 2, side_width / 2, _SIDE_EXT / 2), (side * (field.LENGTH / 2 + _BORDER_LENGTH), 0.0, 0.0))
        )
        boxes.append(
            ((side_length / 2, _SIDE_EXT / 2, _SIDE_EXT / 2), (0.0, side * (field.WIDTH / 2 + _BORDER_WIDTH), 0.0))
        )
    return boxes
