"""The maximal step of one robot as one dense LCP: the reference ``tree_step.step_tree`` is checked
against (``tests/test_stub_ode.py``). Same rows, same integration; the whole LCP matrix built and
its unbounded rows eliminated by a dense Cholesky factor, so it is slow and simple."""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.integrate import advance, free_velocities, robot_body_terms
from server_stub.physics.linalg import cho_solve, cholesky, cross, mat_vec, plane_space
from server_stub.physics.rows import contact_c
from server_stub.physics.solver import box_qp


@njit(cache=True)
def dense_step(model, state, forces, ground, motors, params):
    """One dWorldStep of one robot's bodies. Returns (positions, quaternions, velocities, spins,
    contact forces (points x 3: normal, t1, t2), tangents (points x 2 x 3), motor/stop torques,
    solver passes). ``motor_state`` (hinges): the bounded rows' active-set guess, updated. The
    drag acts on ``drag_vel`` / ``drag_spin`` (the velocities SimSpark's DragControllers read: the
    bodies' own, except in the step after a beam)."""
    masses, principal, parents, joint_of, local_axes, anchor_child, anchor_parent = model
    pos, quat, vel, spin = state
    gravity, drag_linear, drag_angular, drag_vel, drag_spin = forces
    contact_body, contact_point, contact_depth = ground
    motor_target, motor_lo, motor_hi, push, motor_state = motors
    h, joint_erp, joint_cfm, motor_cfm, surface_layer, implicit_gyro, contact_erp, contact_cfm, slip = params
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nc = contact_point.shape[0]
    rot, inv_inertia, force, _ = robot_body_terms(
        masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
    )
    # rows: unbounded first (5 per hinge, 2 friction per contact), then bounded (motor per hinge,
    # normal per contact). Each row acts on body1 (Jacobian j1) and body2 (j2; -1 none).
    n_unb = 5 * nj + 2 * nc
    nr = n_unb + nj + nc
    b1 = np.full(nr, -1, dtype=np.int64)
    b2 = np.full(nr, -1, dtype=np.int64)
    j1 = np.zeros((nr, 6))
    j2 = np.zeros((nr, 6))
    c = np.zeros(nr)
    cfm = np.zeros(nr)
    lo = np.full(nr, -np.inf)
    hi = np.full(nr, np.inf)
    k_joint = joint_erp / h
    for k in range(1, nb):
        j = joint_of[k]
        p = parents[k]
        a1 = mat_vec(rot[k], anchor_child[j])
        a2 = mat_vec(rot[p], anchor_parent[j])
        gap = pos[p] + a2 - pos[k] - a1
        base = 5 * j
        for i in range(3):
            r = base + i
            b1[r] = k
            b2[r] = p
            j1[r, i] = 1.0
            j2[r, i] = -1.0
            # angular parts: -[a1]x row i on body 1, [a2]x row i on body 2
            e = np.zeros(3)
            e[i] = 1.0
            x1 = cross(a1, e)  # row i of -[a1]x is (a1 x e_i)
            x2 = cross(a2, e)
            for a in range(3):
                j1[r, 3 + a] = x1[a]
                j2[r, 3 + a] = -x2[a]
            c[r] = k_joint * gap[i]
            cfm[r] = joint_cfm
        ax1 = mat_vec(rot[k], local_axes[j])
        ax2 = mat_vec(rot[p], local_axes[j])
        t1, t2 = plane_space(ax1)
        err = cross(ax1, ax2)
        for i in range(2):
            r = base + 3 + i
            d = t1 if i == 0 else t2
            b1[r] = k
            b2[r] = p
            for a in range(3):
                j1[r, 3 + a] = d[a]
                j2[r, 3 + a] = -d[a]
            c[r] = k_joint * (err[0] * d[0] + err[1] * d[1] + err[2] * d[2])
            cfm[r] = joint_cfm
        r = n_unb + j
        b1[r] = k
        b2[r] = p
        for a in range(3):
            j1[r, 3 + a] = ax1[a]
            j2[r, 3 + a] = -ax1[a]
            force[k, 3 + a] += push[j] * ax1[a]
            force[p, 3 + a] -= push[j] * ax1[a]
        c[r] = motor_target[j]
        cfm[r] = motor_cfm
        lo[r] = motor_lo[j]
        hi[r] = motor_hi[j]
    tangents = np.empty((nc, 2, 3))
    normal = np.array([0.0, 0.0, 1.0])
    for i in range(nc):
        k = contact_body[i]
        t1, t2 = plane_space(normal)
        tangents[i, 0] = t1
        tangents[i, 1] = t2
        arm = contact_point[i] - pos[k]
        rn = n_unb + nj + i
        for r, d in ((rn, normal), (5 * nj + 2 * i, t1), (5 * nj + 2 * i + 1, t2)):
            b1[r] = k
            ang = cross(arm, d)
            for a in range(3):
                j1[r, a] = d[a]
                j1[r, 3 + a] = ang[a]
        c[rn] = contact_c(contact_erp, contact_depth[i], surface_layer, h, 0.0, np.inf, 0.0)
        cfm[rn] = contact_cfm
        lo[rn] = 0.0
        cfm[5 * nj + 2 * i] = slip
        cfm[5 * nj + 2 * i + 1] = slip
    # M^-1 J' per row and body; free velocities v + h M^-1 f
    m1 = np.zeros((nr, 6))
    m2 = np.zeros((nr, 6))
    for r in range(nr):
        k = b1[r]
        inv_m = 1.0 / masses[k]
        for a in range(3):
            m1[r, a] = j1[r, a] * inv_m
        ang = mat_vec(inv_inertia[k], j1[r, 3:6])
        for a in range(3):
            m1[r, 3 + a] = ang[a]
        k = b2[r]
        if k >= 0:
            inv_m = 1.0 / masses[k]
            for a in range(3):
                m2[r, a] = j2[r, a] * inv_m
            ang = mat_vec(inv_inertia[k], j2[r, 3:6])
            for a in range(3):
                m2[r, 3 + a] = ang[a]
    free = free_velocities(vel, spin, force, masses, inv_inertia, h)
    # A = h J M^-1 J' + cfm, b = c - J free
    big_a = np.zeros((nr, nr))
    rhs = c.copy()
    for r in range(nr):
        s1 = 0.0
        k = b1[r]
        for a in range(6):
            s1 += j1[r, a] * free[k, a]
        k = b2[r]
        if k >= 0:
            for a in range(6):
                s1 += j2[r, a] * free[k, a]
        rhs[r] -= s1
        for s in range(r, nr):
            v = 0.0
            for x in range(2):
                kr = b1[r] if x == 0 else b2[r]
                if kr < 0:
                    continue
                jr = j1[r] if x == 0 else j2[r]
                for y in range(2):
                    ks = b1[s] if y == 0 else b2[s]
                    if ks != kr:
                        continue
                    ms = m1[s] if y == 0 else m2[s]
                    for a in range(6):
                        v += jr[a] * ms[a]
            big_a[r, s] = h * v
            big_a[s, r] = h * v
        big_a[r, r] += cfm[r]
    # eliminate the unbounded rows, box-solve the bounded ones on the Schur complement
    nbd = nr - n_unb
    lower, ok = cholesky(big_a[:n_unb, :n_unb].copy())
    y = np.empty((n_unb, nbd))
    for s in range(nbd):
        y[:, s] = cho_solve(lower, big_a[:n_unb, n_unb + s].copy())
    y0 = cho_solve(lower, rhs[:n_unb].copy())
    schur = big_a[n_unb:, n_unb:].copy()
    rhs_b = rhs[n_unb:].copy()
    for r in range(nbd):
        for s in range(nbd):
            v = 0.0
            for t in range(n_unb):
                v += big_a[n_unb + r, t] * y[t, s]
            schur[r, s] -= v
        v = 0.0
        for t in range(n_unb):
            v += big_a[n_unb + r, t] * y0[t]
        rhs_b[r] -= v
    state = np.zeros(nbd, dtype=np.int64)
    for j in range(nj):
        state[j] = motor_state[j]
    lam_b, iterations = box_qp(schur, rhs_b, lo[n_unb:], hi[n_unb:], state)
    for j in range(nj):
        motor_state[j] = state[j]
    lam = np.empty(nr)
    for t in range(n_unb):
        v = y0[t]
        for s in range(nbd):
            v -= y[t, s] * lam_b[s]
        lam[t] = v
    lam[n_unb:] = lam_b
    # velocities, then positions and orientations
    new_vel = free.copy()
    for r in range(nr):
        if lam[r] == 0.0:
            continue
        k = b1[r]
        for a in range(6):
            new_vel[k, a] += h * m1[r, a] * lam[r]
        k = b2[r]
        if k >= 0:
            for a in range(6):
                new_vel[k, a] += h * m2[r, a] * lam[r]
    out_pos, out_quat, out_vel, out_spin = advance(pos, quat, new_vel, h)
    forces = np.empty((nc, 3))
    for i in range(nc):
        forces[i, 0] = lam[n_unb + nj + i]
        forces[i, 1] = lam[5 * nj + 2 * i]
        forces[i, 2] = lam[5 * nj + 2 * i + 1]
    torques = lam[n_unb : n_unb + nj].copy()
    return out_pos, out_quat, out_vel, out_spin, forces, tangents, torques, iterations
