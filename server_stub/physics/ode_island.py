"""One ODE island of the maximal step (``PhysicsConfig.ode_maximal``, ``ode_contacts``): several
robots and the ball that touch each other, solved together in one LCP, as ODE's dWorldStep solves
every island of bodies connected by joints or contacts.

The kernel is ``ode_maximal.step_tree`` generalised (same facts, same Baraff 1996 tree solve):

- the bodies form a forest (one tree per robot, torso at its root; the ball a tree of one body);
  ``parents`` is -1 at a root, and every parent's index is below its children's;
- contacts with one body (the ground, a goal or a border wall) are as ``step_tree``'s ground
  contacts, but each with its own normal and surface (soft ERP, soft CFM, slip, bounce, minimum
  bounce velocity): their two friction rows are unbounded nodes of the tree, their normal row
  bounded;
- contacts between two bodies (robot-robot, robot-ball) close loops across the trees, so all their
  three rows (normal >= 0, two unbounded friction rows with CFM = slip, as SimSpark's infinite mu
  makes them) go with the bounded rows into the Schur complement, each row's forward pass running
  along the union of its two bodies' paths to their roots;
- ODE's contact row (contact.cpp, ODE 0.16): c = ERP / h * max(depth - surface layer, 0); with
  bounce, the outgoing normal velocity u = J v at the step's start and, when -u > the minimum
  bounce velocity, c = max(c, -bounce * u).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.ode_kernels import _cross, _plane_space, box_qp
from server_stub.physics.ode_maximal import (
    _inverse_definite,
    _mat_vec,
    _mdmt,
    _mtdm_sub,
    _mtv_sub,
    _mv,
    _mv_sub,
    _qmul,
    gyroscopic_torque,
)
from server_stub.physics.rotations import rotation_matrix

#: columns of a surface row: soft ERP, soft CFM, slip, bounce, minimum bounce velocity (inf: none)
ERP, CFM, SLIP, BOUNCE, BOUNCE_VEL = range(5)


@njit(cache=True)
def _contact_c(erp, depth, surface_layer, h, bounce, bounce_vel, outgoing):
    """ODE 0.16's right-hand side of a contact's normal row."""
    d = depth - surface_layer
    c = erp * d / h if d > 0.0 else 0.0
    if bounce_vel >= 0.0 and -outgoing > bounce_vel:
        newc = -bounce * outgoing
        if newc > c:
            c = newc
    return c


#: Islands with more bounded rows than this are solved by block principal pivoting first
#: (``_block_pivot``), the active-set ``box_qp`` only finishing; smaller ones by ``box_qp`` alone.
BLOCK_PIVOT_ROWS = 100
#: Most block-pivoting passes before ``box_qp`` takes over from the last guess.
BLOCK_PIVOT_PASSES = 40


@njit(cache=True)
def _block_pivot(a, b, lo, hi, state):
    """The boxed LCP of ``box_qp`` (A symmetric positive definite) by block principal pivoting
    (Judice and Pires): solve the free rows with the others at their bounds, then move every row
    that breaks its bound or its sign condition at once; a few passes of LAPACK solves where the
    active-set method changes one row per pass (hundreds in a pile of robots); when the count of
    wrong rows stops falling, one row a pass (Murty's rule). ``state`` (in/out)
    as ``box_qp``'s. Returns (x, converged, passes); not converged: ``state`` is the last guess."""
    n = b.shape[0]
    x = np.zeros(n)
    passes = 0
    best = n + 1
    stalled = 0
    for passes in range(1, BLOCK_PIVOT_PASSES + 1):
        for i in range(n):
            if state[i] < 0 and np.isfinite(lo[i]):
                x[i] = lo[i]
            elif state[i] > 0 and np.isfinite(hi[i]):
                x[i] = hi[i]
            else:
                state[i] = 0
        free = np.nonzero(state == 0)[0]
        bound = np.nonzero(state != 0)[0]
        nf = free.size
        if nf > 0:
            sub = np.empty((nf, nf))
            rhs = np.empty(nf)
            for ii in range(nf):
                i = free[ii]
                t = b[i]
                for k in bound:
                    t -= a[i, k] * x[k]
                rhs[ii] = t
                for jj in range(nf):
                    sub[ii, jj] = a[i, free[jj]]
            sol = np.linalg.solve(sub, rhs)
            for ii in range(nf):
                x[free[ii]] = sol[ii]
        w = a @ x - b
        wrong = np.zeros(n, dtype=np.bool_)
        for i in range(n):
            if state[i] == 0:
                wrong[i] = x[i] < lo[i] or x[i] > hi[i]
            elif state[i] < 0:
                wrong[i] = w[i] < 0.0
            else:
                wrong[i] = w[i] > 0.0
        count = int(np.sum(wrong))
        if count == 0:
            return x, True, passes
        if count < best:
            best = count
            stalled = 0
        else:
            stalled += 1
        last = n - 1
        while not wrong[last]:
            last -= 1
        for i in range(n):
            # all at once; after 3 passes without fewer wrong rows, only the last wrong one
            # (Murty's rule, finite for positive definite A)
            if not wrong[i] or (stalled >= 3 and i != last):
                continue
            if state[i] == 0:
                state[i] = -1 if x[i] < lo[i] else 1
            else:
                state[i] = 0
    return x, False, passes


@njit(cache=True)
def _forest_solve(
    nb, parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact, rb, rj, rf
):
    """``ode_maximal._tree_solve`` on a forest (roots have parent -1)."""
    t6 = np.empty(6)
    t5 = np.empty(5)
    t2 = np.empty(2)
    for k in range(nb - 1, -1, -1):
        c = contact_first[k]
        while c >= 0:
            _mv(dinv_contact[c], rf[c], t2)
            _mtv_sub(jf[c], t2, rb[k])
            c = contact_next[c]
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        _mv(dinv_body[k], rb[k], t6)
        _mv_sub(jc[j], t6, rj[j])
        _mv(dinv_joint[j], rj[j], t5)
        _mtv_sub(jp[j], t5, rb[p])
    for k in range(nb):
        p = parents[k]
        if p >= 0:
            j = joint_of[k]
            _mv_sub(jp[j], rb[p], rj[j])
            _mv(dinv_joint[j], rj[j], t5)
            rj[j, :] = t5
            _mtv_sub(jc[j], rj[j], rb[k])
        _mv(dinv_body[k], rb[k], t6)
        rb[k, :] = t6
        c = contact_first[k]
        while c >= 0:
            _mv_sub(jf[c], rb[k], rf[c])
            _mv(dinv_contact[c], rf[c], t2)
            rf[c, :] = t2
            c = contact_next[c]


@njit(cache=True)
def step_island(
    masses,
    principal,
    parents,
    joint_of,
    local_axes,
    anchor_child,
    anchor_parent,
    pos,
    quat,
    vel,
    spin,
    gravity,
    drag_linear,
    drag_angular,
    drag_vel,
    drag_spin,
    implicit_gyro,
    motor_target,
    motor_lo,
    motor_hi,
    push,
    motor_state,
    c_body,
    c_point,
    c_normal,
    c_depth,
    c_surface,
    p_body1,
    p_body2,
    p_point,
    p_normal,
    p_depth,
    p_surface,
    h,
    joint_erp,
    joint_cfm,
    motor_cfm,
    surface_layer,
):
    """One dWorldStep of an island. Bodies: ``masses`` ... ``spin`` as ``step_tree``'s, with
    ``parents`` -1 at each root and ``joint_of`` the hinge of each non-root; ``drag_linear`` /
    ``drag_angular`` per body. Contacts with one body: ``c_*`` (the normal points away from the
    static object, into the body); between two: ``p_*`` (the normal points from body 2 into body
    1); surfaces as rows of (ERP, CFM, slip, bounce, minimum bounce velocity). Returns (positions,
    quaternions, velocities, spins, one-body contact forces (normal, t1, t2) and tangents, two-body
    contact forces (on body 1) and tangents, motor/stop torques, solver passes)."""
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nc = c_point.shape[0]
    npc = p_point.shape[0]
    rot = np.empty((nb, 3, 3))
    inv_inertia = np.empty((nb, 3, 3))
    force = np.empty((nb, 6))
    dbody = np.zeros((nb, 6, 6))
    child_of = np.zeros(nj, dtype=np.int64)
    for k in range(nb):
        r = rotation_matrix(quat[k])
        rot[k] = r
        inertia = np.empty((3, 3))
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
        if parents[k] >= 0:
            child_of[joint_of[k]] = k
    jc = np.zeros((nj, 5, 6))
    jp = np.zeros((nj, 5, 6))
    cj = np.zeros((nj, 5))
    motor_dir = np.zeros((nj, 3))
    k_joint = joint_erp / h
    for k in range(nb):
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        a1 = _mat_vec(rot[k], anchor_child[j])
        a2 = _mat_vec(rot[p], anchor_parent[j])
        for i in range(3):
            jc[j, i, i] = 1.0
            jp[j, i, i] = -1.0
            cj[j, i] = k_joint * (pos[p, i] + a2[i] - pos[k, i] - a1[i])
        jc[j, 0, 4] = a1[2]
        jc[j, 0, 5] = -a1[1]
        jc[j, 1, 3] = -a1[2]
        jc[j, 1, 5] = a1[0]
        jc[j, 2, 3] = a1[1]
        jc[j, 2, 4] = -a1[0]
        jp[j, 0, 4] = -a2[2]
        jp[j, 0, 5] = a2[1]
        jp[j, 1, 3] = a2[2]
        jp[j, 1, 5] = -a2[0]
        jp[j, 2, 3] = -a2[1]
        jp[j, 2, 4] = a2[0]
        ax1 = _mat_vec(rot[k], local_axes[j])
        ax2 = _mat_vec(rot[p], local_axes[j])
        t1, t2 = _plane_space(ax1)
        err = _cross(ax1, ax2)
        for i in range(2):
            d = t1 if i == 0 else t2
            for a in range(3):
                jc[j, 3 + i, 3 + a] = d[a]
                jp[j, 3 + i, 3 + a] = -d[a]
            cj[j, 3 + i] = k_joint * (err[0] * d[0] + err[1] * d[1] + err[2] * d[2])
        motor_dir[j] = ax1
        for a in range(3):
            force[k, 3 + a] += push[j] * ax1[a]
            force[p, 3 + a] -= push[j] * ax1[a]
    # one-body contacts: friction nodes of the tree, normal rows bounded
    jf = np.zeros((nc, 2, 6))
    jn = np.zeros((nc, 6))
    cn = np.zeros(nc)
    tangents = np.empty((nc, 2, 3))
    contact_first = np.full(nb, -1, dtype=np.int64)
    contact_next = np.full(nc, -1, dtype=np.int64)
    for i in range(nc - 1, -1, -1):
        k = c_body[i]
        contact_next[i] = contact_first[k]
        contact_first[k] = i
        normal = c_normal[i].copy()
        t1, t2 = _plane_space(normal)
        tangents[i, 0] = t1
        tangents[i, 1] = t2
        arm = c_point[i] - pos[k]
        an = _cross(arm, normal)
        a1 = _cross(arm, t1)
        a2 = _cross(arm, t2)
        outgoing = 0.0
        for a in range(3):
            jn[i, a] = normal[a]
            jn[i, 3 + a] = an[a]
            jf[i, 0, a] = t1[a]
            jf[i, 0, 3 + a] = a1[a]
            jf[i, 1, a] = t2[a]
            jf[i, 1, 3 + a] = a2[a]
            outgoing += normal[a] * vel[k, a] + an[a] * spin[k, a]
        sf = c_surface[i]
        cn[i] = _contact_c(sf[ERP], c_depth[i], surface_layer, h, sf[BOUNCE], sf[BOUNCE_VEL], outgoing)
    # bounded rows: motors, one-body normals, then 3 rows per two-body contact; each acts on up
    # to two bodies (gb: body, -1 none; gj: its 6 Jacobian entries)
    nbd = nj + nc + 3 * npc
    gb = np.full((nbd, 2), -1, dtype=np.int64)
    gj = np.zeros((nbd, 2, 6))
    bb = np.empty(nbd)
    lo = np.empty(nbd)
    hi = np.empty(nbd)
    cfm_b = np.empty(nbd)
    for j in range(nj):
        k = child_of[j]
        gb[j, 0] = k
        gb[j, 1] = parents[k]
        for a in range(3):
            gj[j, 0, 3 + a] = motor_dir[j, a]
            gj[j, 1, 3 + a] = -motor_dir[j, a]
        bb[j] = motor_target[j]
        lo[j] = motor_lo[j]
        hi[j] = motor_hi[j]
        cfm_b[j] = motor_cfm
    for i in range(nc):
        r = nj + i
        gb[r, 0] = c_body[i]
        for a in range(6):
            gj[r, 0, a] = jn[i, a]
        bb[r] = cn[i]
        lo[r] = 0.0
        hi[r] = np.inf
        cfm_b[r] = c_surface[i, CFM]
    p_tangents = np.empty((npc, 2, 3))
    for i in range(npc):
        k1 = p_body1[i]
        k2 = p_body2[i]
        normal = p_normal[i].copy()
        t1, t2 = _plane_space(normal)
        p_tangents[i, 0] = t1
        p_tangents[i, 1] = t2
        arm1 = p_point[i] - pos[k1]
        arm2 = p_point[i] - pos[k2]
        sf = p_surface[i]
        for x in range(3):
            r = nj + nc + 3 * i + x
            d = normal if x == 0 else (t1 if x == 1 else t2)
            g1 = _cross(arm1, d)
            g2 = _cross(arm2, d)
            gb[r, 0] = k1
            gb[r, 1] = k2
            for a in range(3):
                gj[r, 0, a] = d[a]
                gj[r, 0, 3 + a] = g1[a]
                gj[r, 1, a] = -d[a]
                gj[r, 1, 3 + a] = -g2[a]
            if x == 0:
                outgoing = 0.0
                for a in range(3):
                    outgoing += gj[r, 0, a] * vel[k1, a] + gj[r, 0, 3 + a] * spin[k1, a]
                    outgoing += gj[r, 1, a] * vel[k2, a] + gj[r, 1, 3 + a] * spin[k2, a]
                bb[r] = _contact_c(sf[ERP], p_depth[i], surface_layer, h, sf[BOUNCE], sf[BOUNCE_VEL], outgoing)
                lo[r] = 0.0
                cfm_b[r] = sf[CFM]
            else:
                bb[r] = 0.0
                lo[r] = -np.inf
                cfm_b[r] = sf[SLIP]
            hi[r] = np.inf
    free = np.empty((nb, 6))
    for k in range(nb):
        for a in range(3):
            free[k, a] = vel[k, a] + h * force[k, a] / masses[k]
        ang = _mat_vec(inv_inertia[k], force[k, 3:6])
        for a in range(3):
            free[k, 3 + a] = spin[k, a] + h * ang[a]
    # factor H from the leaves to the roots
    dinv_body = np.empty((nb, 6, 6))
    dinv_joint = np.empty((nj, 5, 5))
    dinv_contact = np.zeros((nc, 2, 2))
    dj = np.empty((5, 5))
    for k in range(nb - 1, -1, -1):
        c = contact_first[k]
        while c >= 0:
            dinv_contact[c, 0, 0] = -1.0 / c_surface[c, SLIP]
            dinv_contact[c, 1, 1] = -1.0 / c_surface[c, SLIP]
            _mtdm_sub(jf[c], dinv_contact[c], dbody[k])
            c = contact_next[c]
        _inverse_definite(dbody[k], 1.0, dinv_body[k])
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        dj[:, :] = 0.0
        for a in range(5):
            dj[a, a] = -joint_cfm
        _mdmt(jc[j], dinv_body[k], dj)
        _inverse_definite(dj, -1.0, dinv_joint[j])
        _mtdm_sub(jp[j], dinv_joint[j], dbody[p])
    bj = cj.copy()
    for k in range(nb):
        if parents[k] >= 0:
            j = joint_of[k]
            _mv_sub(jc[j], free[k], bj[j])
            _mv_sub(jp[j], free[parents[k]], bj[j])
    bf = np.zeros((nc, 2))
    for i in range(nc):
        _mv_sub(jf[i], free[c_body[i]], bf[i])
    for r in range(nbd):
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    bb[r] -= gj[r, x, a] * free[k, a]
    yb = np.zeros((nb, 6))
    yj = bj.copy()
    yf = bf.copy()
    _forest_solve(
        nb, parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact, yb, yj, yf
    )
    # forward passes of the bounded rows along the union of their bodies' paths to the roots
    path_b = np.empty((nbd, nb), dtype=np.int64)
    path_j = np.empty((nbd, nb), dtype=np.int64)
    len_b = np.zeros(nbd, dtype=np.int64)
    len_j = np.zeros(nbd, dtype=np.int64)
    zb = np.zeros((nbd, nb, 6))
    zj = np.zeros((nbd, nj, 5))
    wb = np.zeros((nbd, nb, 6))
    wj = np.zeros((nbd, nj, 5))
    mark = np.zeros(nb, dtype=np.bool_)
    for r in range(nbd):
        mark[:] = False
        top = -1
        for x in range(2):
            k = gb[r, x]
            if k < 0:
                continue
            for a in range(6):
                zb[r, k, a] += gj[r, x, a]
            if k > top:
                top = k
            while k >= 0 and not mark[k]:
                mark[k] = True
                k = parents[k]
        for k in range(top, -1, -1):
            if not mark[k]:
                continue
            path_b[r, len_b[r]] = k
            len_b[r] += 1
            _mv(dinv_body[k], zb[r, k], wb[r, k])
            p = parents[k]
            if p < 0:
                continue
            j = joint_of[k]
            _mv_sub(jc[j], wb[r, k], zj[r, j])
            _mv(dinv_joint[j], zj[r, j], wj[r, j])
            _mtv_sub(jp[j], wj[r, j], zb[r, p])
            path_j[r, len_j[r]] = j
            len_j[r] += 1
    schur = np.zeros((nbd, nbd))
    for r in range(nbd):
        for s in range(r, nbd):
            v = 0.0
            for m in range(len_b[r]):
                k = path_b[r, m]
                for a in range(6):
                    v += zb[s, k, a] * wb[r, k, a]
            for m in range(len_j[r]):
                j = path_j[r, m]
                for a in range(5):
                    v += zj[s, j, a] * wj[r, j, a]
            schur[r, s] = v
            schur[s, r] = v
        schur[r, r] += cfm_b[r]
    for r in range(nbd):
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    bb[r] -= gj[r, x, a] * yb[k, a]
    state = np.zeros(nbd, dtype=np.int64)
    for j in range(nj):
        state[j] = motor_state[j]
    converged = False
    if nbd > BLOCK_PIVOT_ROWS:
        lam_b, converged, iterations = _block_pivot(schur, bb, lo, hi, state)
    if not converged:
        lam_b, iterations = box_qp(schur, bb, lo, hi, state)
    for j in range(nj):
        motor_state[j] = state[j]
    rb = np.zeros((nb, 6))
    for r in range(nbd):
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    rb[k, a] += gj[r, x, a] * lam_b[r]
    _forest_solve(
        nb, parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact, rb, bj, bf
    )
    out_pos = pos.copy()
    out_quat = quat.copy()
    out_vel = np.empty((nb, 3))
    out_spin = np.empty((nb, 3))
    for k in range(nb):
        for a in range(3):
            out_vel[k, a] = free[k, a] + rb[k, a]
            out_spin[k, a] = free[k, 3 + a] + rb[k, 3 + a]
            out_pos[k, a] = pos[k, a] + h * out_vel[k, a]
        w = np.array([out_spin[k, 0], out_spin[k, 1], out_spin[k, 2], 0.0])
        dq = _qmul(w, quat[k])
        qn = quat[k] + 0.5 * h * dq
        out_quat[k] = qn / np.sqrt(qn[0] ** 2 + qn[1] ** 2 + qn[2] ** 2 + qn[3] ** 2)
    forces = np.empty((nc, 3))
    for i in range(nc):
        forces[i, 0] = lam_b[nj + i]
        forces[i, 1] = -bf[i, 0]
        forces[i, 2] = -bf[i, 1]
    p_forces = np.empty((npc, 3))
    for i in range(npc):
        for x in range(3):
            p_forces[i, x] = lam_b[nj + nc + 3 * i + x]
    torques = lam_b[:nj].copy()
    return out_pos, out_quat, out_vel, out_spin, forces, tangents, p_forces, p_tangents, torques, iterations


def warm_up() -> None:
    """Compile (or load from numba's disk cache) ``step_island`` on a ball on the ground touching
    a second ball."""
    one = np.ones(2)
    none = np.zeros((0, 3))
    step_island(
        *(np.full(2, 0.026), np.full((2, 3), 1.8e-5), np.array([-1, -1]), np.array([0, 0]), none, none, none),
        *(np.array([[0.0, 0.0, 0.042], [0.08, 0.0, 0.042]]), np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))),
        *(np.zeros((2, 3)), np.zeros((2, 3)), np.array([0.0, 0.0, -9.81]), 0.01 * one, 5e-5 * one),
        *(np.zeros((2, 3)), np.zeros((2, 3)), True, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)),
        *(np.zeros(0, dtype=np.int64), np.array([0]), np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])),
        *(np.array([0.001]), np.array([[0.35, 0.05, 0.3, 0.8, 0.8]]), np.array([1]), np.array([0])),
        *(np.array([[0.04, 0.0, 0.042]]), np.array([[1.0, 0.0, 0.0]]), np.array([0.004])),
        *(np.array([[0.5, 0.05, 0.6, 0.8, 1.0]]), 0.02, 0.2, 1e-5, 1e-8, 0.001),
    )
