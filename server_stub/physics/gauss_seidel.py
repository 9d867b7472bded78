"""The bounded rows of a large island (a pile of robots) by block Gauss-Seidel, in time that grows
with the rows rather than with their cube.

Why: the exact solve (``solver.schur_complement``, then block pivoting and ``box_qp``) forms the
dense Schur complement of the bounded rows and factors it. A pile of six robots makes 1,200 rows
and took seconds a step (``bench/bench_pile.py``). Here the same boxed LCP (S = G' H^-1 G +
diag(cfm), the same right side and bounds, ``solver``'s scaling) is solved without forming S:

- ``body_blocks``: each tree's body block K of H^-1 (one tree solve per body coordinate: the hinges
  and one-body friction eliminated as the exact solve eliminates them), so that the bodies'
  velocity change u = K G lambda is kept as lambda changes;
- the blocks of the sweep: each tree's own rows (its motors and its one-body contact normals),
  solved exactly by ``box_qp`` on their small Schur complement; then each two-body contact point's
  three rows (normal >= 0, friction free) by a 3x3 solve, the points between one pair of bodies
  one after another on those two bodies' velocities, their trees told once per sweep;
- sweeps until no multiplier moves by more than ``tolerance`` (relative to the largest) or
  ``sweeps`` are done.

Each block solve is exact for its rows with the others held, so every one lowers the same strictly
convex quadratic: the sweeps converge to the exact solve's answer (``tests/test_stub_ode.py``
checks it). Stopped early, the answer is the softer one of ODE's own iterative step (QuickStep);
the stand-in takes this path only past ``PhysicsConfig.island_exact_rows``, which no walk, kick or
bump of two robots reaches.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.solver import box_qp, tree_solve


@njit(cache=True)
def trees_of(parents):
    """The forest's trees as ranges of bodies (each tree's bodies are consecutive, its root
    first): (first body of each tree, one past its last, each body's tree)."""
    nb = parents.shape[0]
    count = 0
    for k in range(nb):
        if parents[k] < 0:
            count += 1
    first = np.empty(count, dtype=np.int64)
    end = np.empty(count, dtype=np.int64)
    tree_of = np.empty(nb, dtype=np.int64)
    t = -1
    for k in range(nb):
        if parents[k] < 0:
            t += 1
            first[t] = k
        tree_of[k] = t
        end[t] = k + 1
    return first, end, tree_of


@njit(cache=True)
def body_blocks(
    first, end, parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact
):
    """K as 6x6 blocks: ``kb[k, m]`` = the block of H^-1 between body k and body ``first[t] + m``
    of k's tree t (zero across trees: no hinge joins them), one tree solve per column."""
    nb = parents.shape[0]
    width = 1
    for t in range(first.shape[0]):
        width = max(width, end[t] - first[t])
    kb = np.zeros((nb, width, 6, 6))
    rb = np.zeros((nb, 6))
    rj = np.zeros((jc.shape[0], 5))
    rf = np.zeros((jf.shape[0], 2))
    for t in range(first.shape[0]):
        for m in range(end[t] - first[t]):
            col = first[t] + m
            for a in range(6):
                for k in range(first[t], end[t]):
                    rb[k, :] = 0.0
                    if parents[k] >= 0:
                        rj[joint_of[k], :] = 0.0
                    c = contact_first[k]
                    while c >= 0:
                        rf[c, :] = 0.0
                        c = contact_next[c]
                rb[col, a] = 1.0
                tree_solve(
                    first[t],
                    end[t],
                    parents,
                    joint_of,
                    contact_first,
                    contact_next,
                    jc,
                    jp,
                    jf,
                    dinv_body,
                    dinv_joint,
                    dinv_contact,
                    rb,
                    rj,
                    rf,
                )
                for k in range(first[t], end[t]):
                    for x in range(6):
                        kb[k, m, x, a] = rb[k, x]
    return kb


@njit(cache=True)
def _spread(kb, first, end, tree_of, k, impulse, u):
    """u += K[:, k] impulse over k's tree."""
    t = tree_of[k]
    m = k - first[t]
    for i in range(first[t], end[t]):
        block = kb[i, m]
        for x in range(6):
            s = 0.0
            for a in range(6):
                s += block[x, a] * impulse[a]
            u[i, x] += s


@njit(cache=True)
def _coupling(kb, first, tree_of, gb, gj, r, s):
    """S[r, s] without CFM: the sum over the rows' bodies of g_r' K g_s (zero across trees)."""
    v = 0.0
    for x in range(2):
        k = gb[r, x]
        if k < 0:
            continue
        for y in range(2):
            q = gb[s, y]
            if q < 0 or tree_of[q] != tree_of[k]:
                continue
            block = kb[k, q - first[tree_of[q]]]
            for a in range(6):
                g = gj[r, x, a]
                if g == 0.0:
                    continue
                for b in range(6):
                    v += g * block[a, b] * gj[s, y, b]
    return v


@njit(cache=True)
def _row_velocity(gb, gj, u, r):
    """g_r . u: the bounded row's velocity change from every multiplier so far."""
    v = 0.0
    for x in range(2):
        k = gb[r, x]
        if k >= 0:
            for a in range(6):
                v += gj[r, x, a] * u[k, a]
    return v


@njit(cache=True)
def _solve3(a, rhs, out):
    """out = a^-1 rhs for a 3x3 symmetric positive definite a (Cholesky)."""
    l00 = np.sqrt(a[0, 0])
    l10 = a[1, 0] / l00
    l20 = a[2, 0] / l00
    l11 = np.sqrt(a[1, 1] - l10 * l10)
    l21 = (a[2, 1] - l20 * l10) / l11
    l22 = np.sqrt(a[2, 2] - l20 * l20 - l21 * l21)
    y0 = rhs[0] / l00
    y1 = (rhs[1] - l10 * y0) / l11
    y2 = (rhs[2] - l20 * y0 - l21 * y1) / l22
    out[2] = y2 / l22
    out[1] = (y1 - l21 * out[2]) / l11
    out[0] = (y0 - l10 * out[1] - l20 * out[2]) / l00


@njit(cache=True)
def block_gauss_seidel(kb, first, end, tree_of, gb, gj, bb, lo, hi, cfm_b, state, nj, nc, sweeps, tolerance):
    """The bounded rows' boxed LCP (``box_qp``'s, with S = G' K G + diag(cfm_b) never formed):
    rows [0, nj) motors, [nj, nj + nc) one-body contact normals, then three rows (normal,
    friction, friction) per two-body contact point. ``state`` (in/out) as ``box_qp``'s. Returns
    (multipliers, sweeps taken)."""
    nbd = bb.shape[0]
    nb = kb.shape[0]
    nt = first.shape[0]
    lam = np.zeros(nbd)
    for r in range(nbd):
        if state[r] < 0 and np.isfinite(lo[r]):
            lam[r] = lo[r]
        elif state[r] > 0 and np.isfinite(hi[r]):
            lam[r] = hi[r]
    # u = K G lambda
    u = np.zeros((nb, 6))
    impulse = np.empty(6)
    for r in range(nbd):
        if lam[r] == 0.0:
            continue
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    impulse[a] = gj[r, x, a] * lam[r]
                _spread(kb, first, end, tree_of, k, impulse, u)
    # each tree's own rows and their Schur complement
    owned = nj + nc
    count = np.zeros(nt, dtype=np.int64)
    for r in range(owned):
        count[tree_of[gb[r, 0]]] += 1
    start = np.zeros(nt + 1, dtype=np.int64)
    for t in range(nt):
        start[t + 1] = start[t] + count[t]
    rows = np.empty(owned, dtype=np.int64)
    fill = start[:nt].copy()
    for r in range(owned):
        t = tree_of[gb[r, 0]]
        rows[fill[t]] = r
        fill[t] += 1
    blocks = []
    for t in range(nt):
        mine = rows[start[t] : start[t + 1]]
        s = np.empty((mine.size, mine.size))
        for i in range(mine.size):
            for j in range(i, mine.size):
                v = _coupling(kb, first, tree_of, gb, gj, mine[i], mine[j])
                s[i, j] = v
                s[j, i] = v
            s[i, i] += cfm_b[mine[i]]
        blocks.append(s)
    # the contact points, those between one pair of bodies together, and each point's 3x3 block
    npc = (nbd - owned) // 3
    order = np.argsort(gb[owned::3, 0] * nb + gb[owned::3, 1], kind="mergesort")
    local = np.empty((npc, 3, 3))
    for i in range(npc):
        r0 = owned + 3 * i
        for x in range(3):
            for y in range(x, 3):
                v = _coupling(kb, first, tree_of, gb, gj, r0 + x, r0 + y)
                local[i, x, y] = v
                local[i, y, x] = v
            local[i, x, x] += cfm_b[r0 + x]
    rhs3 = np.empty(3)
    new3 = np.empty(3)
    u1 = np.empty(6)
    u2 = np.empty(6)
    push1 = np.empty(6)
    push2 = np.empty(6)
    d1 = np.empty(6)
    d2 = np.empty(6)
    done = 0
    while done < sweeps:
        done += 1
        moved = 0.0
        largest = 0.0
        for t in range(nt):
            mine = rows[start[t] : start[t + 1]]
            m = mine.size
            if m == 0:
                continue
            s = blocks[t]
            q = np.empty(m)
            old = np.empty(m)
            sub_lo = np.empty(m)
            sub_hi = np.empty(m)
            sub_state = np.empty(m, dtype=np.int64)
            for i in range(m):
                r = mine[i]
                old[i] = lam[r]
                sub_lo[i] = lo[r]
                sub_hi[i] = hi[r]
                sub_state[i] = state[r]
            # the block's right side: b less what every other row's multiplier does to its rows
            for i in range(m):
                v = bb[mine[i]] - _row_velocity(gb, gj, u, mine[i]) - cfm_b[mine[i]] * old[i]
                for j in range(m):
                    v += s[i, j] * old[j]
                q[i] = v
            x, _ = box_qp(s, q, sub_lo, sub_hi, sub_state)
            for i in range(m):
                r = mine[i]
                state[r] = sub_state[i]
                delta = x[i] - old[i]
                lam[r] = x[i]
                moved = max(moved, abs(delta))
                largest = max(largest, abs(x[i]))
                if delta == 0.0:
                    continue
                for y in range(2):
                    k = gb[r, y]
                    if k >= 0:
                        for a in range(6):
                            impulse[a] = gj[r, y, a] * delta
                        _spread(kb, first, end, tree_of, k, impulse, u)
        g = 0
        while g < npc:
            head = owned + 3 * order[g]
            k1 = gb[head, 0]
            k2 = gb[head, 1]
            same = tree_of[k1] == tree_of[k2]
            b11 = kb[k1, k1 - first[tree_of[k1]]]
            b22 = kb[k2, k2 - first[tree_of[k2]]]
            b12 = kb[k1, k2 - first[tree_of[k2]]]
            b21 = kb[k2, k1 - first[tree_of[k1]]]
            u1[:] = u[k1]
            u2[:] = u[k2]
            push1[:] = 0.0
            push2[:] = 0.0
            while g < npc:
                i = order[g]
                r0 = owned + 3 * i
                if gb[r0, 0] != k1 or gb[r0, 1] != k2:
                    break
                g += 1
                a3 = local[i]
                for x in range(3):
                    r = r0 + x
                    v = bb[r] - cfm_b[r] * lam[r]
                    for a in range(6):
                        v -= gj[r, 0, a] * u1[a] + gj[r, 1, a] * u2[a]
                    for y in range(3):
                        v += a3[x, y] * lam[r0 + y]
                    rhs3[x] = v
                _solve3(a3, rhs3, new3)
                if new3[0] < lo[r0]:  # the normal may only push: held at 0, the friction solved alone
                    new3[0] = lo[r0]
                    det = a3[1, 1] * a3[2, 2] - a3[1, 2] * a3[2, 1]
                    f1 = rhs3[1] - a3[1, 0] * new3[0]
                    f2 = rhs3[2] - a3[2, 0] * new3[0]
                    new3[1] = (a3[2, 2] * f1 - a3[1, 2] * f2) / det
                    new3[2] = (a3[1, 1] * f2 - a3[2, 1] * f1) / det
                d1[:] = 0.0
                d2[:] = 0.0
                for x in range(3):
                    r = r0 + x
                    delta = new3[x] - lam[r]
                    lam[r] = new3[x]
                    moved = max(moved, abs(delta))
                    largest = max(largest, abs(new3[x]))
                    for a in range(6):
                        d1[a] += gj[r, 0, a] * delta
                        d2[a] += gj[r, 1, a] * delta
                for a in range(6):
                    push1[a] += d1[a]
                    push2[a] += d2[a]
                for x in range(6):
                    s1 = 0.0
                    s2 = 0.0
                    for a in range(6):
                        s1 += b11[x, a] * d1[a]
                        s2 += b22[x, a] * d2[a]
                        if same:
                            s1 += b12[x, a] * d2[a]
                            s2 += b21[x, a] * d1[a]
                    u1[x] += s1
                    u2[x] += s2
            _spread(kb, first, end, tree_of, k1, push1, u)
            _spread(kb, first, end, tree_of, k2, push2, u)
        if moved <= tolerance * max(largest, 1.0):
            break
    return lam, done
