"""Contact points: how the physics hands them over, and what the foot sensors make of them.

Where the contact model lives (docs/robot_and_server.md section 4):

- its settings, each with the source of its value: ``server_stub.config.PhysicsConfig`` (the
  "contacts" block);
- how contacts are made and solved: the ground's colliders (``server_stub.physics.collision``),
  Bullet's collision pass for everything else (``stepper``), their rows (``rows``) and the step's
  LCP (``solver``);
- what a robot reports of them: this module.

The step leaves each robot's contact points in pybullet's tuple layout
(``pybullet.getContactPoints``), filled with the forces it solved, so the sensors read one format.
The field positions below name that layout.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

#: Fields of a pybullet contact point tuple.
BODY_A = 1  # the robot's body
BODY_B = 2  # the other body
LINK_A = 3  # link of the robot (-1: the torso)
LINK_B = 4  # link of the other body
POSITION_ON_A = 5  # world position of the point on the robot
POSITION_ON_B = 6  # world position of the point on the other body
NORMAL_ON_B = 7  # world unit normal, from the other body towards the robot
DISTANCE = 8  # negative when the shapes overlap
NORMAL_FORCE = 9  # N, >= 0
FRICTION_1 = 10  # N, along FRICTION_DIR_1
FRICTION_DIR_1 = 11
FRICTION_2 = 12  # N, along FRICTION_DIR_2
FRICTION_DIR_2 = 13

Vec3 = tuple[float, float, float]


def point(body_a, body_b, link_a, link_b, on_a, on_b, normal_on_b, distance, force, tangents, sign=1.0) -> tuple:
    """One solved contact point in pybullet's layout: ``force`` the solved (normal, first friction,
    second friction) forces along the normal and ``tangents``; ``sign`` -1 for the second body of
    a two-body contact, whose friction is the first body's turned round."""
    normal, first, second = float(force[0]), force[1], force[2]
    if sign < 0.0:
        first, second = -first, -second
    return (0, body_a, body_b, link_a, link_b, on_a, on_b, normal_on_b, distance, normal) + (
        float(first),
        tuple(tangents[0]),
        float(second),
        tuple(tangents[1]),
    )


def link_pressure(points: Iterable[Sequence], links: Mapping[int, str]) -> dict[int, tuple[Vec3, Vec3]]:
    """Per link of ``links`` that touches: (centre of pressure, total contact force), both in the
    world frame. A link touches when a point carries load or overlaps (ODE makes a contact for
    touching geometry, so a foot resting without load still counts: the real walk shows 7% of
    its FRPs under 1 N). The centre is the points' mean weighted by normal force (the plain mean
    when none carries load); the force is the points' normal and friction forces."""
    sums: dict[int, list[float]] = {}
    for c in points:
        normal = c[NORMAL_FORCE]
        link = c[LINK_A]
        if not (normal > 0.0 or c[DISTANCE] <= 0.0) or link not in links:
            continue
        s = sums.setdefault(link, [0.0] * 11)
        (nx, ny, nz), (ax, ay, az), (bx, by, bz) = c[NORMAL_ON_B], c[FRICTION_DIR_1], c[FRICTION_DIR_2]
        f1, f2 = c[FRICTION_1], c[FRICTION_2]
        s[0] += normal * nx + f1 * ax + f2 * bx
        s[1] += normal * ny + f1 * ay + f2 * by
        s[2] += normal * nz + f1 * az + f2 * bz
        px, py, pz = c[POSITION_ON_A]
        weight = max(normal, 0.0)
        s[3] += weight * px
        s[4] += weight * py
        s[5] += weight * pz
        s[6] += weight
        s[7] += px
        s[8] += py
        s[9] += pz
        s[10] += 1.0
    result: dict[int, tuple[Vec3, Vec3]] = {}
    for link in sorted(sums):
        s = sums[link]
        force = (s[0], s[1], s[2])
        if s[6] > 0.0:
            centre = (s[3] / s[6], s[4] / s[6], s[5] / s[6])
        else:
            centre = (s[7] / s[10], s[8] / s[10], s[9] / s[10])
        result[link] = (centre, force)
    return result
