"""Contact points: how the physics hands them over, and what the foot sensors make of them.

Where the contact model lives (docs/robot_and_server.md section 4):

- its settings, each with the source of its value: ``server_stub.config.PhysicsConfig`` (the
  "contacts" block);
- how contacts are made and solved: the "ode" backend's ground contacts and LCP
  (``server_stub.physics.ode_kernels``, ``ode_step``, ``ode_maximal``), or, on the "bullet"
  backend, Bullet's own collision pass with force-dependent slip added beside its solver
  (``server_stub.physics.slip``);
- what a robot reports of them: this module.

Both backends leave each robot's contact points of the last step in pybullet's tuple layout
(``pybullet.getContactPoints``; the "ode" backends fill it with their solved forces), so the
sensors read one format. The field positions below name that layout.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

#: Fields of a pybullet contact point tuple.
LINK_A = 3  # link of the robot (-1: the torso)
POSITION_ON_A = 5  # world position of the point on the robot
NORMAL_ON_B = 7  # world unit normal, from the other body towards the robot
DISTANCE = 8  # negative when the shapes overlap
NORMAL_FORCE = 9  # N, >= 0
FRICTION_1 = 10  # N, along FRICTION_DIR_1
FRICTION_DIR_1 = 11
FRICTION_2 = 12  # N, along FRICTION_DIR_2
FRICTION_DIR_2 = 13

Vec3 = tuple[float, float, float]


def loaded(points: Iterable[Sequence]) -> list[Sequence]:
    """The points that carried load in the last step: where ODE would have had a contact joint
    (Bullet also keeps points a little apart, with no force)."""
    return [c for c in points if c[NORMAL_FORCE] > 0.0]


def link_pressure(
    points: Iterable[Sequence], links: Mapping[int, str], extra_force: Mapping[int, Sequence[float]]
) -> dict[int, tuple[Vec3, Vec3]]:
    """Per link of ``links`` that touches: (centre of pressure, total contact force), both in the
    world frame. A link touches when a point carries load or overlaps (ODE makes a contact for
    touching geometry, so a foot resting without load still counts: the real walk shows 7% of
    its FRPs under 1 N). The centre is the points' mean weighted by normal force (the plain mean
    when none carries load); the force is the points' normal and friction forces plus
    ``extra_force`` on the link (the "bullet" backend's slip, applied outside Bullet's solver)."""
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
        ex, ey, ez = extra_force.get(link, (0.0, 0.0, 0.0))
        force = (s[0] + ex, s[1] + ey, s[2] + ez)
        if s[6] > 0.0:
            centre = (s[3] / s[6], s[4] / s[6], s[5] / s[6])
        else:
            centre = (s[7] / s[10], s[8] / s[10], s[9] / s[10])
        result[link] = (centre, force)
    return result
