"""Solvers of the step's LCP, scaled by h: A = h J M^-1 J' + diag(cfm), b = c - J (v + h M^-1 f).

- The unbounded rows (hinges' joint rows, friction) are eliminated along the bodies' tree by
  Baraff's 1996 method (``factor``, ``tree_solve``, ``unbounded_rhs``), in linear time.
- The bounded rows (motors, stops, contact normals, and every row of a contact between two bodies)
  are solved on their Schur complement (``schur_complement``) as a boxed LCP: exactly, by the
  active-set ``box_qp``; in large islands block principal pivoting (``block_pivot``) first.
- ``contact_forces``: the solved contact rows as forces.
- ``hinged`` (the last argument of the four above), for a robot's step (``tree_step``): the
  structural zeros of the hinges' Jacobian blocks skipped (``linalg.hinge_mv_sub``) and, in S,
  the terms of bodies and hinges two rows' paths do not share: the same bits whenever every value
  a zero is skipped against is finite, which each reports (when one is not, the step is redone by
  them told not to skip, as an island is solved: one code for both).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.linalg import (
    cho_solve,
    cholesky_rows,
    finite,
    hinge_mdmt,
    hinge_mtdm_sub,
    hinge_mtv_sub,
    hinge_mv_sub,
    inverse_definite,
    mdmt,
    mtdm_sub,
    mtv_sub,
    mv,
    mv_sub,
)


@njit(cache=True)
def free_system(a, b, x, state, free):
    """The boxed LCP's rows ``free`` (``state`` 0) with every other row held where ``x`` has it:
    A_FF x_F = b_F - A_FB x_B, as (A_FF, right side); the inner system of the island solve's block
    pivoting (``box_qp`` sums the same right side and factors A_FF in place)."""
    nf = free.size
    sub = np.empty((nf, nf))
    rhs = np.empty(nf)
    for ii in range(nf):
        i = free[ii]
        s = b[i]
        for k in range(b.shape[0]):
            if state[k] != 0:
                s -= a[i, k] * x[k]
        rhs[ii] = s
        for jj in range(nf):
            sub[ii, jj] = a[i, free[jj]]
    return sub, rhs


@njit(cache=True)
def box_qp(a, b, lo, hi, state):
    """x minimising 1/2 x'Ax - b'x within lo <= x <= hi, A symmetric positive definite: the
    boxed LCP w = Ax - b, x at lo => w >= 0, x at hi => w <= 0, inside => w = 0, solved exactly
    by a primal active-set method (finite; each iterate feasible). ``state`` (in/out): -1 at lo,
    +1 at hi, 0 free, the guess to start from (the last step's). Returns (x, iterations)."""
    n = b.shape[0]
    x = np.zeros(n)
    for i in range(n):
        if state[i] < 0 and np.isfinite(lo[i]):
            x[i] = lo[i]
        elif state[i] > 0 and np.isfinite(hi[i]):
            x[i] = hi[i]
        else:
            state[i] = 0
            x[i] = min(max(0.0, lo[i]), hi[i])
            if x[i] != 0.0:  # 0 outside the box: start at the nearer bound
                state[i] = -1 if x[i] == lo[i] else 1
    # the free rows' factor, kept from pass to pass: a pass changes one row's state, and the
    # factor's rows before the first changed one stay (``linalg.cholesky_rows``)
    lower = np.empty((n, n))
    free = np.empty(n, dtype=np.int64)
    rhs = np.empty(n)
    target = np.empty(n)
    nf = 0
    it = 0
    while it < 4 * n + 19:  # the count of passes is returned
        it += 1
        # the free rows, and how many of them lead the last pass's in the same places
        kept = 0
        count = 0
        for i in range(n):
            if state[i] == 0:
                if kept == count and count < nf and free[count] == i:
                    kept += 1
                free[count] = i
                count += 1
        nf = count
        for i in range(n):
            target[i] = x[i]
        if nf > 0:
            # A_FF x_F = b_F - A_FB x_B (``free_system``)
            for ii in range(nf):
                i = free[ii]
                t = b[i]
                for k in range(n):
                    if state[k] != 0:
                        t -= a[i, k] * x[k]
                rhs[ii] = t
            if not cholesky_rows(a, free, nf, lower, kept):
                break
            sol = cho_solve(lower, rhs[:nf])
            for ii in range(nf):
                target[free[ii]] = sol[ii]
        # step towards target, stopping at the first bound crossed
        t = 1.0
        block = -1
        for ii in range(nf):
            i = free[ii]
            d = target[i] - x[i]
            if d < 0.0 and target[i] < lo[i]:
                s = (lo[i] - x[i]) / d
                if s < t:
                    t = s
                    block = i
            elif d > 0.0 and target[i] > hi[i]:
                s = (hi[i] - x[i]) / d
                if s < t:
                    t = s
                    block = i
        for ii in range(nf):
            i = free[ii]
            x[i] += t * (target[i] - x[i])
        if block >= 0:
            if target[block] < lo[block]:
                x[block] = lo[block]
                state[block] = -1
            else:
                x[block] = hi[block]
                state[block] = 1
            continue
        # at the subspace optimum: release the clamped variable whose multiplier is most wrong
        worst = 0.0
        release = -1
        for i in range(n):
            if state[i] == 0:
                continue
            w = -b[i]
            for k in range(n):
                w += a[i, k] * x[k]
            bad = -w if state[i] < 0 else w  # at lo we need w >= 0, at hi w <= 0
            if bad > worst * 1.0 and bad > 1e-12 * (1.0 + abs(b[i])):
                if bad > worst:
                    worst = bad
                    release = i
        if release < 0:
            break
        state[release] = 0
    return x, it


#: Where ``tree_solve`` starts on a whole forest, as an int64: called with a literal 0 it would be
#: compiled a second time, for that literal (about 1.5 s of a cold start).
FIRST_BODY = np.int64(0)

#: Islands with more bounded rows than this are solved by block principal pivoting first
#: (``block_pivot``), the active-set ``box_qp`` only finishing; smaller ones by ``box_qp`` alone.
BLOCK_PIVOT_ROWS = 100


#: Most block-pivoting passes before ``box_qp`` takes over from the last guess.
BLOCK_PIVOT_PASSES = 12


@njit(cache=True)
def block_pivot(a, b, lo, hi, state):
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
        nf = free.size
        if nf > 0:
            sub, rhs = free_system(a, b, x, state, free)
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
def dense():
    """``hinged`` for an island's solve (every term taken): ``False`` as a value numba types
    ``bool``, as the robot's step passes it; a literal ``False`` (a plain ``return False`` too)
    would compile each of the solver's functions a second time."""
    return np.bool_(False)


@njit(cache=True)
def schur_of_rows(parents, joint_of, jc, jp, dinv_body, dinv_joint, gb, gj, cfm_b):
    """The bounded rows' dense Schur complement (``schur_complement``), for the exact
    solve (all of an island's rows) and for Gauss-Seidel (one tree's own rows)."""
    nbd = gb.shape[0]
    nb = parents.shape[0]
    # the bounded rows' Jacobians on their bodies and the union of their paths to the roots
    path_b = np.empty((nbd, nb), dtype=np.int64)
    len_b = np.zeros(nbd, dtype=np.int64)
    zb = np.zeros((nbd, nb, 6))
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
            if mark[k]:
                path_b[r, len_b[r]] = k
                len_b[r] += 1
    return schur_complement(parents, joint_of, jc, jp, dinv_body, dinv_joint, path_b, len_b, zb, cfm_b, dense())[0]


@njit(cache=True)
def contact_forces(lam_b, first, bf):
    """One-body contacts' forces (normal, t1, t2): the normals' from the bounded rows (from row
    ``first``), the friction's from the unbounded solve."""
    nc = bf.shape[0]
    forces = np.empty((nc, 3))
    for i in range(nc):
        forces[i, 0] = lam_b[first + i]
        forces[i, 1] = -bf[i, 0]
        forces[i, 2] = -bf[i, 1]
    return forces


@njit(cache=True)
def factor(parents, joint_of, contact_first, contact_next, jc, jp, jf, dbody, slip, joint_cfm, hinged):
    """Factor H from the leaves to the roots (``parents`` -1 there): ``dbody`` (M/h) is
    overwritten by each body's block; ``slip`` per contact. ``hinged`` (a robot's own step): the
    hinge blocks' structural zeros skipped (``linalg.hinge_mdmt``); else (an island, the dense
    redo) every term taken. Returns the inverted blocks (dinv_body, dinv_joint, dinv_contact) and
    whether the skipped terms were all +-0."""
    nb = dbody.shape[0]
    nj = jc.shape[0]
    dinv_body = np.empty((nb, 6, 6))
    dinv_joint = np.empty((nj, 5, 5))
    dinv_contact = np.zeros((jf.shape[0], 2, 2))
    dj = np.empty((5, 5))
    tmp = np.empty((6, 6))
    ok = True
    for k in range(nb - 1, -1, -1):
        c = contact_first[k]
        while c >= 0:
            dinv_contact[c, 0, 0] = -1.0 / slip[c]
            dinv_contact[c, 1, 1] = -1.0 / slip[c]
            mtdm_sub(jf[c], dinv_contact[c], dbody[k], tmp)
            c = contact_next[c]
        inverse_definite(dbody[k], 1.0, dinv_body[k], tmp, 6)
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        dj[:, :] = 0.0
        for a in range(5):
            dj[a, a] = -joint_cfm
        if hinged:
            ok &= hinge_mdmt(jc[j], dinv_body[k], dj, tmp)
        else:
            mdmt(jc[j], dinv_body[k], dj, tmp)
        inverse_definite(dj, -1.0, dinv_joint[j], tmp, 5)
        if hinged:
            ok &= hinge_mtdm_sub(jp[j], dinv_joint[j], dbody[p], tmp)
        else:
            mtdm_sub(jp[j], dinv_joint[j], dbody[p], tmp)
    return dinv_body, dinv_joint, dinv_contact, ok


@njit(cache=True)
def unbounded_rhs(parents, joint_of, c_body, jc, jp, jf, cj, free, hinged):
    """The unbounded rows' right-hand sides b = c - J free: hinge nodes (bj) and friction nodes
    (bf; c = 0); ``hinged``: the hinge blocks' structural zeros skipped. Returns (bj, bf, whether
    the skipped terms were all +-0)."""
    bj = cj.copy()
    ok = True
    for k in range(parents.shape[0]):
        if parents[k] >= 0:
            j = joint_of[k]
            if hinged:
                ok &= hinge_mv_sub(jc[j], free[k], bj[j])
                ok &= hinge_mv_sub(jp[j], free[parents[k]], bj[j])
            else:
                mv_sub(jc[j], free[k], bj[j])
                mv_sub(jp[j], free[parents[k]], bj[j])
    bf = np.zeros((jf.shape[0], 2))
    for i in range(jf.shape[0]):
        mv_sub(jf[i], free[c_body[i]], bf[i])
    return bj, bf, ok


@njit(cache=True)
def tree_solve(first, end, tree, rb, rj, rf, hinged):
    """Solve H x = r on the factored forest (``step_tree``, ``island_step.step_island``; roots
    have parent -1), r given per body (rb, nb x 6), hinge node (rj, nj x 5) and friction node
    (rf, nc x 2); overwritten by x. Only the bodies [first, end) are visited: the whole forest,
    or whole trees of it (``gauss_seidel.body_blocks``). ``tree`` is the factored forest: parents,
    joint_of, contact_first, contact_next, jc, jp, jf and the inverted blocks of ``factor``.
    ``hinged``: the hinge blocks' structural zeros skipped. Returns whether the skipped terms were
    all +-0."""
    parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact = tree
    t6 = np.empty(6)
    t5 = np.empty(5)
    t2 = np.empty(2)
    ok = True
    for k in range(end - 1, first - 1, -1):
        c = contact_first[k]
        while c >= 0:
            mv(dinv_contact[c], rf[c], t2)
            mtv_sub(jf[c], t2, rb[k])
            c = contact_next[c]
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        mv(dinv_body[k], rb[k], t6)
        if hinged:
            ok &= hinge_mv_sub(jc[j], t6, rj[j])
        else:
            mv_sub(jc[j], t6, rj[j])
        mv(dinv_joint[j], rj[j], t5)
        if hinged:
            ok &= hinge_mtv_sub(jp[j], t5, rb[p])
        else:
            mtv_sub(jp[j], t5, rb[p])
    for k in range(first, end):
        p = parents[k]
        if p >= 0:
            j = joint_of[k]
            if hinged:
                ok &= hinge_mv_sub(jp[j], rb[p], rj[j])
            else:
                mv_sub(jp[j], rb[p], rj[j])
            mv(dinv_joint[j], rj[j], t5)
            for a in range(5):
                rj[j, a] = t5[a]
            if hinged:
                ok &= hinge_mtv_sub(jc[j], rj[j], rb[k])
            else:
                mtv_sub(jc[j], rj[j], rb[k])
        mv(dinv_body[k], rb[k], t6)
        for a in range(6):
            rb[k, a] = t6[a]
        c = contact_first[k]
        while c >= 0:
            mv_sub(jf[c], rb[k], rf[c])
            mv(dinv_contact[c], rf[c], t2)
            for a in range(2):
                rf[c, a] = t2[a]
            c = contact_next[c]
    return ok


@njit(cache=True)
def schur_complement(parents, joint_of, jc, jp, dinv_body, dinv_joint, path_b, len_b, zb, cfm_b, hinged):
    """S = cfm_B + G' H^-1 G of the bounded rows, from one forward pass each: row r's z starts as
    its Jacobian on its bodies (zb[r]) and is carried through the bodies path_b[r, :len_b[r]]
    (leaves first, the union of its bodies' paths to their roots; z is zero off them) and the
    hinges between them, w = D^-1 z there. Then S[r, s] = cfm + sum over row r's path of
    z_s' w_r, four entries S[r, s..s+3] at a time: four independent sums, each in the order of one
    at a time (row r's path bodies, then its hinges), which the CPU overlaps. ``zb`` is
    overwritten.

    ``hinged``, for rows whose paths are chains, each one body's path to the root (a robot's own
    rows, ``step_tree``): the hinge blocks' structural zeros skipped in the forward passes. Two
    chains share their tail from their lowest common body to the root (rows in different limbs
    the torso alone), and row s's z is exactly +0 off its path: so S[r, s]'s terms before that
    tail of row r's path add 0 w, +-0 when w is finite, and are skipped, from the earliest of the
    four entries' tails (the few terms of the others' before theirs add +-0 again). Returns (S,
    whether every skipped term was +-0)."""
    nbd = zb.shape[0]
    nb = zb.shape[1]
    nj = jc.shape[0]
    path_j = np.empty((nbd, nb), dtype=np.int64)
    len_j = np.zeros(nbd, dtype=np.int64)
    zj = np.zeros((nbd, nj, 5))
    wb = np.empty((nbd, nb, 6))
    wj = np.empty((nbd, nj, 5))
    on_b = np.zeros((nbd, nb), dtype=np.bool_)
    ok = True
    for r in range(nbd):
        for m in range(len_b[r]):
            k = path_b[r, m]
            on_b[r, k] = True
            mv(dinv_body[k], zb[r, k], wb[r, k])
            p = parents[k]
            if p < 0:
                for a in range(6):  # (below the root, the hinge helpers check w)
                    ok &= finite(wb[r, k, a])
                continue
            j = joint_of[k]
            if hinged:
                ok &= hinge_mv_sub(jc[j], wb[r, k], zj[r, j])
            else:
                mv_sub(jc[j], wb[r, k], zj[r, j])
            mv(dinv_joint[j], zj[r, j], wj[r, j])
            if hinged:
                ok &= hinge_mtv_sub(jp[j], wj[r, j], zb[r, p])
            else:
                mtv_sub(jp[j], wj[r, j], zb[r, p])
            path_j[r, len_j[r]] = j
            len_j[r] += 1
    schur = np.zeros((nbd, nbd))
    for r in range(nbd):
        for s in range(r, nbd, 4):
            s1, s2, s3 = min(s + 1, nbd - 1), min(s + 2, nbd - 1), min(s + 3, nbd - 1)
            # where row r's path first meets any of the four rows' (path body m has hinge m)
            first = 0
            while (
                hinged
                and first < len_b[r]
                and not (
                    on_b[s, path_b[r, first]]
                    or on_b[s1, path_b[r, first]]
                    or on_b[s2, path_b[r, first]]
                    or on_b[s3, path_b[r, first]]
                )
            ):
                first += 1
            v0 = v1 = v2 = v3 = 0.0
            for m in range(first, len_b[r]):
                k = path_b[r, m]
                for a in range(6):
                    w = wb[r, k, a]
                    v0 += zb[s, k, a] * w
                    v1 += zb[s1, k, a] * w
                    v2 += zb[s2, k, a] * w
                    v3 += zb[s3, k, a] * w
            for m in range(first, len_j[r]):
                j = path_j[r, m]
                for a in range(5):
                    w = wj[r, j, a]
                    v0 += zj[s, j, a] * w
                    v1 += zj[s1, j, a] * w
                    v2 += zj[s2, j, a] * w
                    v3 += zj[s3, j, a] * w
            for x, v in ((s3, v3), (s2, v2), (s1, v1), (s, v0)):  # past the end: the last entry again, same value
                schur[r, x] = v
                schur[x, r] = v
        schur[r, r] += cfm_b[r]
    return schur, ok
