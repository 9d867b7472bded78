"""Forces before the LCP and the integration after it, as ODE 0.16's dWorldStep does them: gravity,
SimSpark's drag and ODE's implicit gyroscopic torque (``body_terms``, ``gyroscopic_torque``), the
velocities without constraints (``free_velocities``), then x += h v and ODE's infinitesimal
rotation q += h/2 (0, w) q, normalised (``advance``; SimSpark does not turn on finite rotation)."""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.linalg import cross3, fused_multiply_add, mv3, qmul4
from server_stub.physics.rotations import rotation_into


@njit(cache=True)
def gyroscopic_torque(inertia, w, h, implicit):
    """ODE 0.16's gyroscopic torque of one body: implicit (its default), (I I~^-1 - 1) L / h with
    L = I w and I~ = I - h [L]x; explicit, -w x I w. A tuple."""
    big_l = mv3(inertia, w)
    if not implicit:
        x, y, z = cross3(w, big_l)
        return (-x, -y, -z)
    # I~ = I - h [L]x (its entries as scalars: this runs for every body every step, and a 3 x 3
    # array made here cost more than the arithmetic), its inverse as ``linalg.invert3`` computes
    # it, I I~^-1 as ``linalg.mat_mul3`` (fused multiply-adds in k order), all to the bit
    m00 = inertia[0, 0]
    m01 = inertia[0, 1] + h * big_l[2]
    m02 = inertia[0, 2] - h * big_l[1]
    m10 = inertia[1, 0] - h * big_l[2]
    m11 = inertia[1, 1]
    m12 = inertia[1, 2] + h * big_l[0]
    m20 = inertia[2, 0] + h * big_l[1]
    m21 = inertia[2, 1] - h * big_l[0]
    m22 = inertia[2, 2]
    c00 = m11 * m22 - m12 * m21
    c01 = m12 * m20 - m10 * m22
    c02 = m10 * m21 - m11 * m20
    det = m00 * c00 + m01 * c01 + m02 * c02
    if det == 0.0:
        return (0.0, 0.0, 0.0)
    inv = 1.0 / det
    b00 = c00 * inv
    b10 = c01 * inv
    b20 = c02 * inv
    b01 = (m02 * m21 - m01 * m22) * inv
    b11 = (m00 * m22 - m02 * m20) * inv
    b21 = (m01 * m20 - m00 * m21) * inv
    b02 = (m01 * m12 - m02 * m11) * inv
    b12 = (m02 * m10 - m00 * m12) * inv
    b22 = (m00 * m11 - m01 * m10) * inv
    v0, v1, v2 = big_l[0] / h, big_l[1] / h, big_l[2] / h
    return (
        _gyro_row(inertia, 0, b00, b01, b02, b10, b11, b12, b20, b21, b22, v0, v1, v2),
        _gyro_row(inertia, 1, b00, b01, b02, b10, b11, b12, b20, b21, b22, v0, v1, v2),
        _gyro_row(inertia, 2, b00, b01, b02, b10, b11, b12, b20, b21, b22, v0, v1, v2),
    )


@njit(cache=True)
def _gyro_row(inertia, a, b00, b01, b02, b10, b11, b12, b20, b21, b22, v0, v1, v2):
    """Row a of (I I~^-1 - 1) v, I~^-1 = b: ``linalg.mat_mul3``'s entries, then ``mv3``'s sum."""
    i0, i1, i2 = inertia[a, 0], inertia[a, 1], inertia[a, 2]
    p0 = fused_multiply_add(i2, b20, fused_multiply_add(i1, b10, i0 * b00))
    p1 = fused_multiply_add(i2, b21, fused_multiply_add(i1, b11, i0 * b01))
    p2 = fused_multiply_add(i2, b22, fused_multiply_add(i1, b12, i0 * b02))
    if a == 0:
        p0 -= 1.0
    elif a == 1:
        p1 -= 1.0
    else:
        p2 -= 1.0
    return p0 * v0 + p1 * v1 + p2 * v2


@njit(cache=True)
def body_terms(
    masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
):
    """Each body's rotation, world inverse inertia, forces before the step (gravity, drag with
    per-body coefficients ``drag_linear`` / ``drag_angular``, gyroscopic torque) and diagonal
    block of H (M/h, the tree solve's)."""
    nb = masses.shape[0]
    rot = np.empty((nb, 3, 3))
    inv_inertia = np.empty((nb, 3, 3))
    force = np.empty((nb, 6))
    dbody = np.zeros((nb, 6, 6))
    inertia = np.empty((3, 3))
    for k in range(nb):
        r = rot[k]
        rotation_into(quat[k], r)
        for a in range(3):
            for b in range(3):
                s = 0.0
                t = 0.0
                for cc in range(3):
                    s += r[a, cc] * principal[k, cc] * r[b, cc]
                    t += r[a, cc] / principal[k, cc] * r[b, cc]
                inertia[a, b] = s
                inv_inertia[k, a, b] = t
                dbody[k, 3 + a, 3 + b] = s / h
            dbody[k, a, a] = masses[k] / h
        for a in range(3):
            force[k, a] = masses[k] * gravity[a] - drag_linear[k] * drag_vel[k, a]
        tq = gyroscopic_torque(inertia, spin[k], h, implicit_gyro)
        for a in range(3):
            force[k, 3 + a] = tq[a] - drag_angular[k] * drag_spin[k, a]
    return rot, inv_inertia, force, dbody


@njit(cache=True)
def robot_body_terms(
    masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
):
    """``body_terms`` with one drag coefficient for all bodies (one robot's)."""
    nb = masses.shape[0]
    dl = np.full(nb, drag_linear)
    da = np.full(nb, drag_angular)
    return body_terms(masses, principal, quat, spin, gravity, dl, da, drag_vel, drag_spin, h, implicit_gyro)


@njit(cache=True)
def free_velocities(vel, spin, force, masses, inv_inertia, h):
    """Each body's velocity and spin without the constraints: v + h M^-1 f."""
    nb = masses.shape[0]
    free = np.empty((nb, 6))
    for k in range(nb):
        for a in range(3):
            free[k, a] = vel[k, a] + h * force[k, a] / masses[k]
        ang = mv3(inv_inertia[k], (force[k, 3], force[k, 4], force[k, 5]))  # a tuple: no array per body
        for a in range(3):
            free[k, 3 + a] = spin[k, a] + h * ang[a]
    return free


@njit(cache=True)
def advance(pos, quat, new_vel, h):
    """The bodies' new velocities and spins (``new_vel``, nb x 6), then x += h v and ODE's
    infinitesimal rotation q += h/2 (0, w) q, normalised. Returns (positions, quaternions,
    velocities, spins)."""
    nb = pos.shape[0]
    out_pos = pos.copy()
    out_quat = quat.copy()
    out_vel = np.empty((nb, 3))
    out_spin = np.empty((nb, 3))
    half_h = 0.5 * h
    qn = np.empty(4)
    for k in range(nb):
        for a in range(3):
            out_vel[k, a] = new_vel[k, a]
            out_spin[k, a] = new_vel[k, 3 + a]
            out_pos[k, a] = pos[k, a] + h * new_vel[k, a]
        dq = qmul4((out_spin[k, 0], out_spin[k, 1], out_spin[k, 2], 0.0), quat[k])
        for a in range(4):
            qn[a] = quat[k, a] + half_h * dq[a]
        norm = np.sqrt(qn[0] ** 2 + qn[1] ** 2 + qn[2] ** 2 + qn[3] ** 2)
        for a in range(4):
            out_quat[k, a] = qn[a] / norm
    return out_pos, out_quat, out_vel, out_spin
