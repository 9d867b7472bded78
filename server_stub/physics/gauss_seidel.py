"""The bounded rows of a large island (a pile of robots) by block Gauss-Seidel, in time that grows
with the rows rather than with their cube.

Why: the exact solve (``solver.schur_complement``, then block pivoting and ``box_qp``) forms the
dense Schur complement of the bounded rows and factors it. A pile of six robots makes 1,200 rows
and took seconds a step (``bench/bench_pile.py``). Here the same boxed LCP (S = G' H^-1 G +
diag(cfm), the same right side and bounds, ``solver``'s scaling) is solved without forming S. The
bodies' velocity change u = H^-1 G lambda (its body part) is kept up to date as lambda changes,
and each sweep solves, in turn:

- each tree's own rows (its motors and its one-body contact normals) exactly, by ``box_qp`` on
  their small Schur complement (``solver.schur_of_rows``); their change reaches u by one tree
  solve;
- each two-body contact point's three rows (normal >= 0, friction free) by a 3x3 solve on the
  two bodies' blocks of H^-1; the points between one pair of bodies one after another, their
  trees told once per sweep through those bodies' columns of H^-1 (``contact_columns``: six tree
  solves per body that touches another).

Sweeps end when no multiplier moved by more than ``tolerance`` of the largest, or after
``sweeps``. Each block solve is exact for its rows with the others held, so every one lowers the
same strictly convex quadratic: the sweeps converge to the exact solve's answer
(``tests/test_stub_ode.py`` checks it). Stopped early, the answer is the softer one of ODE's own
iterative step (QuickStep); the stand-in takes this path only past
``PhysicsConfig.island_exact_rows``, which no walk, kick or bump of two robots reaches.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.solver import box_qp, dense, schur_of_rows, tree_solve


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
def _tree_solve(t, first, end, tree, rb, rj, rf):
    """H^-1 r on tree t alone: r given on its bodies in ``rb`` (its hinge and friction nodes
    zeroed here), the body part of the answer left in ``rb``."""
    parents, joint_of, contact_first, contact_next = tree[:4]
    for k in range(first[t], end[t]):
        if parents[k] >= 0:
            rj[joint_of[k], :] = 0.0
        c = contact_first[k]
        while c >= 0:
            rf[c, :] = 0.0
            c = contact_next[c]
    tree_solve(first[t], end[t], tree, rb, rj, rf, dense())


@njit(cache=True)
def contact_columns(bodies, first, end, tree_of, tree, rb, rj, rf):
    """For each of ``bodies``: its columns of H^-1 over its tree, as 6x6 blocks: ``kc[s, m]`` =
    the block between body ``first[t] + m`` and ``bodies[s]`` (t its tree)."""
    width = 1
    for t in range(first.shape[0]):
        width = max(width, end[t] - first[t])
    kc = np.zeros((bodies.shape[0], width, 6, 6))
    for s in range(bodies.shape[0]):
        k = bodies[s]
        t = tree_of[k]
        for a in range(6):
            rb[first[t] : end[t]] = 0.0
            rb[k, a] = 1.0
            _tree_solve(t, first, end, tree, rb, rj, rf)
            for m in range(end[t] - first[t]):
                for x in range(6):
                    kc[s, m, x, a] = rb[first[t] + m, x]
    return kc


@njit(cache=True)
def _spread(kc, s, lo, hi, impulse, u):
    """u[lo:hi] += the column blocks ``kc[s]`` times ``impulse`` (a push on contact body s)."""
    for i in range(lo, hi):
        block = kc[s, i - lo]
        for x in range(6):
            v = 0.0
            for a in range(6):
                v += block[x, a] * impulse[a]
            u[i, x] += v


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
def _point_block(block1, block2, cross12, gj, r0, cfm_b, out):
    """The 3x3 block of S of one contact point's rows r0..r0+2 (bodies 1 and 2; ``cross12`` the
    block of H^-1 between them, zero when in different trees)."""
    for x in range(3):
        for y in range(3):
            v = 0.0
            for a in range(6):
                g1 = gj[r0 + x, 0, a]
                g2 = gj[r0 + x, 1, a]
                for b in range(6):
                    v += g1 * block1[a, b] * gj[r0 + y, 0, b] + g2 * block2[a, b] * gj[r0 + y, 1, b]
                    v += g1 * cross12[a, b] * gj[r0 + y, 1, b] + g2 * cross12[b, a] * gj[r0 + y, 0, b]
            out[x, y] = v
        out[x, x] += cfm_b[r0 + x]


@njit(cache=True)
def block_gauss_seidel(tree, gb, gj, bb, lo, hi, cfm_b, state, nj, nc, sweeps, tolerance):
    """The bounded rows' boxed LCP (``box_qp``'s, with S never formed) on the factored forest
    ``tree`` (parents, joint_of, contact_first, contact_next, jc, jp, jf and the inverted
    blocks): rows [0, nj) motors, [nj, nj + nc) one-body contact normals, then three rows (normal,
    friction, friction) per two-body contact point. ``state`` (in/out) as ``box_qp``'s. Returns
    (multipliers, sweeps taken)."""
    parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact = tree
    nbd = bb.shape[0]
    nb = parents.shape[0]
    first, end, tree_of = trees_of(parents)
    nt = first.shape[0]
    rb = np.zeros((nb, 6))
    rj = np.zeros((jc.shape[0], 5))
    rf = np.zeros((jf.shape[0], 2))
    lam = np.zeros(nbd)
    for r in range(nbd):
        if state[r] < 0 and np.isfinite(lo[r]):
            lam[r] = lo[r]
        elif state[r] > 0 and np.isfinite(hi[r]):
            lam[r] = hi[r]
    # u = H^-1 G lambda, tree by tree
    for r in range(nbd):
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    rb[k, a] += gj[r, x, a] * lam[r]
    u = np.zeros((nb, 6))
    for t in range(nt):
        _tree_solve(t, first, end, tree, rb, rj, rf)
    u[:, :] = rb
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
        blocks.append(schur_of_rows(parents, joint_of, jc, jp, dinv_body, dinv_joint, gb[mine], gj[mine], cfm_b[mine]))
    # the bodies that touch another, their columns of H^-1, and the contact points by pair of bodies
    npc = (nbd - owned) // 3
    slot = np.full(nb, -1, dtype=np.int64)
    touching = np.empty(2 * npc, dtype=np.int64)
    nslots = 0
    for i in range(npc):
        for x in range(2):
            k = gb[owned + 3 * i, x]
            if slot[k] < 0:
                slot[k] = nslots
                touching[nslots] = k
                nslots += 1
    kc = contact_columns(touching[:nslots], first, end, tree_of, tree, rb, rj, rf)
    order = np.argsort(gb[owned::3, 0] * nb + gb[owned::3, 1], kind="mergesort")
    zero = np.zeros((6, 6))
    local = np.empty((npc, 3, 3))
    for i in range(npc):
        r0 = owned + 3 * i
        k1, k2 = gb[r0, 0], gb[r0, 1]
        t1, t2 = tree_of[k1], tree_of[k2]
        cross12 = kc[slot[k2], k1 - first[t1]] if t1 == t2 else zero
        _point_block(kc[slot[k1], k1 - first[t1]], kc[slot[k2], k2 - first[t2]], cross12, gj, r0, cfm_b, local[i])
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
            old = lam[mine]
            sub_state = state[mine]
            # the block's right side: b less what every other row's multiplier does to its rows
            for i in range(m):
                v = bb[mine[i]] - _row_velocity(gb, gj, u, mine[i]) - cfm_b[mine[i]] * old[i]
                for j in range(m):
                    v += s[i, j] * old[j]
                q[i] = v
            x, _ = box_qp(s, q, lo[mine], hi[mine], sub_state)
            rb[first[t] : end[t]] = 0.0
            changed = False
            for i in range(m):
                r = mine[i]
                state[r] = sub_state[i]
                delta = x[i] - old[i]
                lam[r] = x[i]
                moved = max(moved, abs(delta))
                largest = max(largest, abs(x[i]))
                if delta != 0.0:
                    changed = True
                    for y in range(2):
                        k = gb[r, y]
                        if k >= 0:
                            for a in range(6):
                                rb[k, a] += gj[r, y, a] * delta
            if changed:
                _tree_solve(t, first, end, tree, rb, rj, rf)
                for k in range(first[t], end[t]):
                    for a in range(6):
                        u[k, a] += rb[k, a]
        g = 0
        while g < npc:
            head = owned + 3 * order[g]
            k1 = gb[head, 0]
            k2 = gb[head, 1]
            t1, t2 = tree_of[k1], tree_of[k2]
            s1, s2 = slot[k1], slot[k2]
            b11 = kc[s1, k1 - first[t1]]
            b22 = kc[s2, k2 - first[t2]]
            same = t1 == t2
            b12 = kc[s2, k1 - first[t1]]  # H^-1 between k1 and k2, read only in one tree
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
                    v1 = 0.0
                    v2 = 0.0
                    for a in range(6):
                        v1 += b11[x, a] * d1[a]
                        v2 += b22[x, a] * d2[a]
                        if same:
                            v1 += b12[x, a] * d2[a]
                            v2 += b12[a, x] * d1[a]
                    u1[x] += v1
                    u2[x] += v2
            _spread(kc, s1, first[t1], end[t1], push1, u)
            _spread(kc, s2, first[t2], end[t2], push2, u)
        if moved <= tolerance * max(largest, 1.0):
            break
    return lam, done
