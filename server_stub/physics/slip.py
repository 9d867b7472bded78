"""Force-dependent slip of the contacts (docs/robot_and_server.md sections 4), solved outside Bullet.

ODE, the real server's engine, gives each contact two friction rows with CFM = slip (0.005 m/s
per N) and no Coulomb limit: a contact point slides at slip x its tangential force, and the
solver finds those forces together with everything else. Bullet has no such row, and pybullet
offers only one global CFM, which would soften every motor and contact as well (tried: the robot
sagged and fell). So the stub applies the slip force as an external force at each contact point,
from the linearly implicit damper over one step of length h::

    v + h A F = -slip F        (tangential components of every point at once)

where v holds the points' tangential velocities at the start of the step and A their mobility
(velocity per unit force) if the whole robot were one rigid body, its joints held by their
motors. Solving for all points together is what keeps this stable at one step per cycle, however
many points share a foot; a damper per point with a guessed mass (what this replaced) needed
three sub-steps per cycle and still depended on how many points a foot had.

The rigid-body damper holds only while the motors hold. A point behind a motor at its torque
limit (a flailing or fallen robot's limb) has far less mass behind it; treating it as rigid made
such robots explode, so those points get a damper sized by their own link's mass instead.

This runs for every robot every cycle, on a handful of points, where numpy's per-call cost
dominated (about 40 calls, 0.2 ms a cycle); the kernels are compiled with numba (cached on disk
after the first run) and written as plain loops.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from server_stub.physics.rotations import rotation_matrix


@njit(cache=True)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True)
def _mm(a, b):
    """a b for 3x3 matrices (numba's @ needs SciPy's BLAS)."""
    out = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                out[i, j] += a[i, k] * b[k, j]
    return out


@njit(cache=True)
def _mv(a, v):
    return np.array(
        [
            a[0, 0] * v[0] + a[0, 1] * v[1] + a[0, 2] * v[2],
            a[1, 0] * v[0] + a[1, 1] * v[1] + a[1, 2] * v[2],
            a[2, 0] * v[0] + a[2, 1] * v[1] + a[2, 2] * v[2],
        ]
    )


@njit(cache=True)
def _solve_symmetric_positive(a, b):
    """x with a x = b for a symmetric positive definite ``a`` (Cholesky; a is overwritten)."""
    n = b.shape[0]
    for j in range(n):
        d = a[j, j]
        for k in range(j):
            d -= a[j, k] * a[j, k]
        d = np.sqrt(d)
        a[j, j] = d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= a[i, k] * a[j, k]
            a[i, j] = s / d
    x = b.copy()
    for i in range(n):
        for k in range(i):
            x[i] -= a[i, k] * x[k]
        x[i] /= a[i, i]
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, n):
            x[i] -= a[k, i] * x[k]
        x[i] /= a[i, i]
    return x


@njit(cache=True)
def composite_body(masses, centres, rotations, principal_moments):
    """(mass, centre of mass, inertia about it) of parts welded together. ``centres`` (n, 3)
    and ``rotations`` (n, 3, 3) give each part's centre and axes in a common frame, in which the
    result is expressed; ``principal_moments`` (n, 3) are the parts' own diagonal inertias."""
    n = masses.shape[0]
    mass = 0.0
    com = np.zeros(3)
    for i in range(n):
        mass += masses[i]
        com += masses[i] * centres[i]
    com /= mass
    inertia = np.zeros((3, 3))
    for i in range(n):
        d = centres[i] - com
        spread = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        for a in range(3):
            for b in range(3):
                own = 0.0
                for k in range(3):
                    own += rotations[i, a, k] * principal_moments[i, k] * rotations[i, b, k]
                inertia[a, b] += own - masses[i] * d[a] * d[b]
            inertia[a, a] += masses[i] * spread
    return mass, com, inertia


@njit(cache=True)
def slip_forces(points, normals, velocities, com, mass, inertia, slip, h):
    """Force (n, 3) at each contact point that solves v + h A F = -slip F in the contact planes.

    ``points``, unit ``normals`` and ``velocities`` (of the robot's material at each point) are
    (n, 3); ``com``, ``mass`` and ``inertia`` (world frame) describe the rigid body the points
    belong to. Forces have no normal component (the constraint solver handles that direction):
    with P the projector onto each contact plane, (slip I + h P A P) F = -P v, where
    A = 1 / mass (for the push) + [r]x I^-1 [r]x^T (for the turn, r from the centre of mass).
    """
    n = points.shape[0]
    inv = _inverse3(inertia)
    plane = np.empty((n, 3, 3))
    lever = np.empty((n, 3, 3))  # P [r]x
    rhs = np.empty(3 * n)
    for i in range(n):
        r = points[i] - com
        rx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        for a in range(3):
            for b in range(3):
                plane[i, a, b] = (1.0 if a == b else 0.0) - normals[i, a] * normals[i, b]
        lever[i] = _mm(plane[i], rx)
        pv = _mv(plane[i], velocities[i])
        for a in range(3):
            rhs[3 * i + a] = -pv[a]
    system = np.empty((3 * n, 3 * n))
    for i in range(n):
        li = _mm(lever[i], inv)
        for j in range(n):
            block = (h / mass) * _mm(plane[i], plane[j].T) + h * _mm(li, lever[j].T)
            for a in range(3):
                for b in range(3):
                    system[3 * i + a, 3 * j + b] = block[a, b]
    for k in range(3 * n):
        system[k, k] += slip
    return _solve_symmetric_positive(system, rhs).reshape(n, 3)


@njit(cache=True)
def _inverse3(m):
    c0 = _cross(m[1], m[2])
    c1 = _cross(m[2], m[0])
    c2 = _cross(m[0], m[1])
    det = m[0, 0] * c0[0] + m[0, 1] * c0[1] + m[0, 2] * c0[2]
    out = np.empty((3, 3))
    for a in range(3):
        out[a, 0] = c0[a] / det
        out[a, 1] = c1[a] / det
        out[a, 2] = c2[a] / det
    return out


@njit(cache=True)
def _tangential(v, normal):
    return v - (v[0] * normal[0] + v[1] * normal[1] + v[2] * normal[2]) * normal


@njit(cache=True)
def loose_slip_forces(normals, velocities, masses, slip, h):
    """The same damper for points that each move on their own with ``masses`` (n,) behind them:
    F = -P v / (slip + h / m), what an implicit damper leaves after a step of h."""
    out = np.empty_like(velocities)
    for i in range(velocities.shape[0]):
        out[i] = -_tangential(velocities[i], normals[i]) / (slip + h / masses[i])
    return out


@njit(cache=True)
def at_most_stopping(forces, normals, velocities, slip):
    """``forces`` scaled down, point by point, to at most |v| / slip: the force the damper puts
    on a point stopped dead. The rigid-body solve can ask more of a point whose neighbours move
    differently (limbs driven apart by their motors), which the articulated robot cannot take."""
    out = forces.copy()
    for i in range(forces.shape[0]):
        limit = np.sqrt(np.sum(_tangential(velocities[i], normals[i]) ** 2)) / slip
        size = np.sqrt(np.sum(forces[i] ** 2))
        if size > limit:
            out[i] *= limit / size
    return out


@njit(cache=True)
def hinge_torques(points, forces, chains, anchors, axes):
    """Torque about every hinge (world ``anchors``, unit ``axes``) of the forces at ``points``,
    each counted on the hinges its row of ``chains`` (points x hinges) marks:
    axis . ((p - anchor) x F)."""
    torque = np.zeros(anchors.shape[0])
    for k in range(points.shape[0]):
        for j in range(anchors.shape[0]):
            if chains[k, j]:
                torque[j] += np.sum(axes[j] * _cross(points[k] - anchors[j], forces[k]))
    return torque


@dataclass(frozen=True)
class Skeleton:
    """What does not change about a robot: parts (torso first) and hinges (joint order)."""

    masses: np.ndarray  # (parts,)
    principal_moments: np.ndarray  # (parts, 3), in each part's own axes
    local_axes: np.ndarray  # (hinges, 3) each hinge's axis in its child part's axes
    #: (parts, hinges): True where the hinge lies between that part and the torso
    chains: np.ndarray
    torque_limit: float


@dataclass(frozen=True)
class Pose:
    """A robot at the start of a step, every vector in the world frame."""

    centres: np.ndarray  # (parts, 3) centres of mass
    orientations: np.ndarray  # (parts, 4) unit quaternions (x, y, z, w)
    velocities: np.ndarray  # (parts, 3) of the centres
    spins: np.ndarray  # (parts, 3) angular velocities
    anchors: np.ndarray  # (hinges, 3)


def contact_forces(
    skeleton: Skeleton,
    pose: Pose,
    parts: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    motor_load: np.ndarray,
    yielding: np.ndarray,
    last_torque: np.ndarray,
    slip: float,
    h: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Slip force at each contact point (on part ``parts[k]``), and the torque these put on every
    hinge (pass it back as ``last_torque`` next step).

    ``motor_load``: the torque each motor applied in the last step (0 for stops); ``yielding``:
    the motors at their limit then. A held point is one whose hinges all hold; the rigid-body
    damper is solved for the held points, and those whose forces would push a motor past its
    limit (a motor balances the change of external torque with its own) are let go and the rest
    solved again once.
    """
    c = np.ascontiguousarray  # one memory layout, so numba compiles (and caches) one version
    return _contact_forces(
        c(skeleton.masses, float),
        c(skeleton.principal_moments, float),
        c(skeleton.local_axes, float),
        c(skeleton.chains, bool),
        float(skeleton.torque_limit),
        c(pose.centres, float),
        c(pose.orientations, float),
        c(pose.velocities, float),
        c(pose.spins, float),
        c(pose.anchors, float),
        c(parts, np.int64),
        c(points, float),
        c(normals, float),
        c(motor_load, float),
        c(yielding, bool),
        c(last_torque, float),
        float(slip),
        float(h),
    )


@njit(cache=True)
def _contact_forces(
    masses,
    principal_moments,
    local_axes,
    all_chains,
    torque_limit,
    centres,
    orientations,
    part_velocities,
    spins,
    anchors,
    parts,
    points,
    normals,
    motor_load,
    yielding,
    last_torque,
    slip,
    h,
):
    n = points.shape[0]
    rotations = np.empty((centres.shape[0], 3, 3))
    for i in range(centres.shape[0]):
        rotations[i] = rotation_matrix(orientations[i])
    axes = np.empty_like(local_axes)
    for j in range(local_axes.shape[0]):
        axes[j] = _mv(rotations[j + 1], local_axes[j])
    velocities = np.empty((n, 3))
    for k in range(n):
        p = parts[k]
        velocities[k] = part_velocities[p] + _cross(spins[p], points[k] - centres[p])
    mass, com, inertia = composite_body(masses, centres, rotations, principal_moments)
    chains = all_chains[parts]
    held = np.ones(n, dtype=np.bool_)
    for k in range(n):
        if np.any(chains[k] & yielding):
            held[k] = False
    forces = np.zeros((n, 3))
    for _ in range(2):
        which = np.nonzero(held)[0]
        if which.size == 0:
            break
        solved = slip_forces(points[which], normals[which], velocities[which], com, mass, inertia, slip, h)
        for i in range(which.size):
            forces[which[i]] = solved[i]
        torque = hinge_torques(points[which], solved, chains[which], anchors, axes)
        over = np.abs(motor_load - (torque - last_torque)) > torque_limit
        overloaded = False
        for k in which:
            if np.any(chains[k] & over):
                held[k] = False
                overloaded = True
        if not overloaded:
            break
    for k in range(n):
        if not held[k]:
            count = 0
            for i in range(n):
                if not held[i] and parts[i] == parts[k]:
                    count += 1
            share = np.array([masses[parts[k]] / count])
            forces[k] = loose_slip_forces(normals[k : k + 1], velocities[k : k + 1], share, slip, h)[0]
    capped = at_most_stopping(forces, normals, velocities, slip)
    return capped, hinge_torques(points, capped, chains, anchors, axes)


def warm_up() -> None:
    """Compile (or load from numba's disk cache) every kernel now, on a one-point problem, so the
    first physics step of a process does not pay for it (a cold compile takes ~13 s, a cached
    load ~0.3 s). Cheap after the first call."""
    skeleton = Skeleton(
        np.ones(2), np.full((2, 3), 0.01), np.array([[1.0, 0.0, 0.0]]), np.array([[False], [True]]), 10.0
    )
    pose = Pose(
        np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.05]]),
        np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)),
        np.zeros((2, 3)),
        np.zeros((2, 3)),
        np.array([[0.0, 0.0, 0.1]]),
    )
    contact_forces(
        skeleton,
        pose,
        np.array([1]),
        np.zeros((1, 3)),
        np.array([[0.0, 0.0, 1.0]]),
        np.zeros(1),
        np.zeros(1, dtype=bool),
        np.zeros(1),
        0.005,
        0.02,
    )
