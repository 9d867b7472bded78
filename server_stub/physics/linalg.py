"""Small linear algebra of the step, compiled, one copy of each for every stage: 3-vectors and
3x3 products as tuples, quaternions (x, y, z, w), the fused multiply-add that makes a 3x3 product
equal numba's ``@`` to the last bit, a Cholesky factor (whole, or from a row on), and the block
operations of the tree solve, dense and for a hinge's Jacobian blocks with their structural zeros
skipped (``hinge_mv_sub`` and the others).

The step's per-body and per-hinge loops work on tuples (``qmul4``, ``mv3``, ``cross3``) and on
scratch arrays made once per call: a small array made, or a helper called with array views, in
such a loop costs more than its arithmetic. LLVM inlines these helpers itself; asking numba to
inline them too (``inline="always"``) made no measurable difference to a step and cost 9 s of a
cold start's compile (``bench/bench_cold_start.py``). Every sum is taken in the same order either
way, so the results are the same bits.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic


@njit(cache=True)
def cross3(a, b):
    """a x b as a tuple: no array is made (the step's per-body loops would make thousands)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def cross(a, b):
    x, y, z = cross3(a, b)
    return np.array([x, y, z])


@njit(cache=True)
def cholesky(a):
    """Lower factor of a symmetric positive definite matrix (a copy; False when not positive)."""
    n = a.shape[0]
    lower = np.zeros((n, n))
    for j in range(n):
        d = a[j, j]
        for k in range(j):
            d -= lower[j, k] * lower[j, k]
        if d <= 0.0:
            return lower, False
        d = np.sqrt(d)
        lower[j, j] = d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= lower[i, k] * lower[j, k]
            lower[i, j] = s / d
    return lower, True


@njit(cache=True)
def cholesky_rows(a, index, n, lower, first):
    """``cholesky`` of a's rows and columns index[:n] into ``lower`` (n x n or more), from row
    ``first`` on: a factor's rows before ``first`` depend on the leading first x first block alone,
    so when only later rows and columns have changed (``solver.box_qp``'s free set, one row more
    or less) they are kept. Every entry is ``cholesky``'s to the bit, summed in its order. Returns
    False when a is not positive definite (rows from the failing one on are then not set)."""
    for j in range(n):
        if j >= first:
            d = a[index[j], index[j]]
            for k in range(j):
                d -= lower[j, k] * lower[j, k]
            if d <= 0.0:
                return False
            d = np.sqrt(d)
            lower[j, j] = d
        else:
            d = lower[j, j]
        aj = index[j]
        for i in range(max(j + 1, first), n):
            t = a[index[i], aj]
            for k in range(j):
                t -= lower[i, k] * lower[j, k]
            lower[i, j] = t / d
    return True


@njit(cache=True)
def cho_solve(lower, b):
    n = b.shape[0]
    x = b.copy()
    for i in range(n):
        s = x[i]
        for k in range(i):
            s -= lower[i, k] * x[k]
        x[i] = s / lower[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= lower[k, i] * x[k]
        x[i] = s / lower[i, i]
    return x


@njit(cache=True)
def plane_space3(n):
    """Two unit tangents completing the unit normal n to a right-handed basis, as tuples."""
    if abs(n[2]) > 0.7071:
        x, y, z = 0.0, -n[2], n[1]
    else:
        x, y, z = -n[1], n[0], 0.0
    norm = np.sqrt(x**2 + y**2 + z**2)
    t1 = (x / norm, y / norm, z / norm)
    return t1, cross3(n, t1)


@njit(cache=True)
def plane_space(n):
    """``plane_space3`` as arrays."""
    (x1, y1, z1), (x2, y2, z2) = plane_space3(n)
    return np.array([x1, y1, z1]), np.array([x2, y2, z2])


@njit(cache=True)
def qmul4(a, b):
    """Hamilton product of (x, y, z, w) quaternions, as a tuple."""
    return (
        a[3] * b[0] + b[3] * a[0] + a[1] * b[2] - a[2] * b[1],
        a[3] * b[1] + b[3] * a[1] + a[2] * b[0] - a[0] * b[2],
        a[3] * b[2] + b[3] * a[2] + a[0] * b[1] - a[1] * b[0],
        a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
    )


@njit(cache=True)
def qmul(a, b):
    """Hamilton product of (x, y, z, w) quaternions."""
    x, y, z, w = qmul4(a, b)
    return np.array([x, y, z, w])


@njit(cache=True)
def conj(a):
    return np.array([-a[0], -a[1], -a[2], a[3]])


@intrinsic
def fused_multiply_add(typingctx, a, b, c):
    """a b + c rounded once (LLVM's fma: the CPU's fused multiply-add, or libm's where it has none)."""

    def codegen(context, builder, signature, args):
        double = ir.DoubleType()
        fma = builder.module.declare_intrinsic("llvm.fma", [double], ir.FunctionType(double, [double] * 3))
        return builder.call(fma, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@njit(cache=True)
def mat_mul3(a, b):
    """a b for 3x3 matrices as numba's ``@`` computes it, without the library call (which costs
    more than the product): ``@`` calls OpenBLAS's dgemm, whose x86-64 kernels accumulate each
    entry as a chain of fused multiply-adds in k order; so does this (bit for bit the same on
    200 000 random products and every step of the test gaits)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = fused_multiply_add(a[i, 2], b[2, j], fused_multiply_add(a[i, 1], b[1, j], a[i, 0] * b[0, j]))
    return out


@njit(cache=True)
def mv3(m, v):
    """m v for a 3x3 m, as a tuple."""
    return (
        m[0, 0] * v[0] + m[0, 1] * v[1] + m[0, 2] * v[2],
        m[1, 0] * v[0] + m[1, 1] * v[1] + m[1, 2] * v[2],
        m[2, 0] * v[0] + m[2, 1] * v[1] + m[2, 2] * v[2],
    )


@njit(cache=True)
def mat_vec(m, v):
    x, y, z = mv3(m, v)
    return np.array([x, y, z])


@njit(cache=True)
def invert3(m):
    """Inverse of a 3x3 matrix (ok False when singular)."""
    c00 = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]
    c01 = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]
    c02 = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]
    det = m[0, 0] * c00 + m[0, 1] * c01 + m[0, 2] * c02
    out = np.zeros((3, 3))
    if det == 0.0:
        return out, False
    inv = 1.0 / det
    out[0, 0] = c00 * inv
    out[1, 0] = c01 * inv
    out[2, 0] = c02 * inv
    out[0, 1] = (m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2]) * inv
    out[1, 1] = (m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0]) * inv
    out[2, 1] = (m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1]) * inv
    out[0, 2] = (m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]) * inv
    out[1, 2] = (m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]) * inv
    out[2, 2] = (m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]) * inv
    return out, True


@njit(cache=True)
def inverse_definite(a, sign, out, low, n):
    """``out`` = the inverse of a small symmetric n x n matrix that is positive (sign 1) or negative
    (sign -1) definite: Cholesky factor of sign * a, inverted (``low``: scratch, n x n or more;
    only its lower triangle is used, each entry written before it is read). ``n`` is given, as a
    literal at each call, rather than read from ``a``'s shape: LLVM inlines this into its caller
    and, knowing n, unrolls the loops (a body's 6 x 6 block is inverted in about half the time;
    the same operations in the same order)."""
    for j in range(n):
        d = sign * a[j, j]
        for k in range(j):
            d -= low[j, k] * low[j, k]
        d = np.sqrt(d)
        low[j, j] = d
        for i in range(j + 1, n):
            t = sign * a[i, j]
            for k in range(j):
                t -= low[i, k] * low[j, k]
            low[i, j] = t / d
    # invert the factor in place (lower triangular)
    for j in range(n):
        low[j, j] = 1.0 / low[j, j]
        for i in range(j + 1, n):
            t = 0.0
            for k in range(j, i):
                t -= low[i, k] * low[k, j]
            low[i, j] = t / low[i, i]
    for i in range(n):
        for j in range(i + 1):
            t = 0.0
            for k in range(i, n):
                t += low[k, i] * low[k, j]
            out[i, j] = sign * t
            out[j, i] = sign * t


@njit(cache=True)
def mv_sub(m, v, out):
    """out -= m v."""
    for i in range(m.shape[0]):
        t = 0.0
        for j in range(m.shape[1]):
            t += m[i, j] * v[j]
        out[i] -= t


@njit(cache=True)
def mtv_sub(m, v, out):
    """out -= m' v."""
    for j in range(m.shape[1]):
        t = 0.0
        for i in range(m.shape[0]):
            t += m[i, j] * v[i]
        out[j] -= t


@njit(cache=True)
def mv(m, v, out):
    """out = m v."""
    for i in range(m.shape[0]):
        t = 0.0
        for j in range(m.shape[1]):
            t += m[i, j] * v[j]
        out[i] = t


@njit(cache=True)
def mtdm_sub(m, dinv, out, tmp):
    """out -= m' dinv m (m: rows x 6, dinv: rows x rows, out 6 x 6; ``tmp``: scratch, rows x 6 or more)."""
    r = m.shape[0]
    for i in range(r):
        for b in range(6):
            t = 0.0
            for k in range(r):
                t += dinv[i, k] * m[k, b]
            tmp[i, b] = t
    for a in range(6):
        for b in range(a, 6):
            t = 0.0
            for i in range(r):
                t += m[i, a] * tmp[i, b]
            out[a, b] -= t
            if b != a:
                out[b, a] -= t


@njit(cache=True)
def mdmt(m, dinv, out, tmp):
    """out -= m dinv m' (m: rows x 6, dinv 6 x 6, out rows x rows; ``tmp``: scratch, rows x 6 or more)."""
    r = m.shape[0]
    for i in range(r):
        for b in range(6):
            t = 0.0
            for k in range(6):
                t += m[i, k] * dinv[k, b]
            tmp[i, b] = t
    for i in range(r):
        for j in range(i, r):
            t = 0.0
            for k in range(6):
                t += tmp[i, k] * m[j, k]
            out[i, j] -= t
            if j != i:
                out[j, i] -= t


# ----- a hinge node's Jacobian blocks, their structural zeros skipped -----
#
# A hinge's 5 x 6 blocks on its child and parent (``rows.hinge_nodes``: jc, jp) have a fixed
# pattern of entries that are never written, so exactly +0: rows 0-2 are +-1 on their own linear
# column, 0 on the other two, 0 on their own angular column (a cross matrix); rows 3-4 are 0 on the
# linear columns. A term 0 x of a sum is +-0 when x is finite, and adding +-0 to a sum that starts
# at +0 (so is never -0: in round to nearest only -0 + -0 is -0) leaves it unchanged; so these
# helpers, which skip those terms and sum the others in the same order, give the bits of the dense
# ``mv_sub``, ``mtv_sub``, ``mdmt``, ``mtdm_sub`` whenever every value they skip a zero against is
# finite. Each returns whether it was (0 inf is nan: then the caller redoes the step densely).


@njit(cache=True)
def hinge_row(i):
    """The columns of row i of a hinge block that are not structural zeros, in increasing order:
    three (its linear one and the two angular ones of a cross matrix's row, or the angular ones)."""
    if i >= 3:
        return 3, 4, 5
    return i, 4 if i == 0 else 3, 4 if i == 2 else 5


@njit(cache=True)
def hinge_col(j):
    """The rows of column j (>= 3, angular) of a hinge block that are not structural zeros, in
    increasing order: two of the cross matrix's and the two axis rows (a linear column j has row j
    alone)."""
    return 1 if j == 3 else 0, 1 if j == 5 else 2, 3, 4


@njit(cache=True)
def finite(x):
    """x is neither inf nor nan."""
    return x - x == 0.0


@njit(cache=True)
def hinge_mv_sub(m, v, out):
    """out -= m v (``mv_sub``) for a hinge block m; whether v is finite."""
    ok = finite(v[0]) & finite(v[1]) & finite(v[2]) & finite(v[3]) & finite(v[4]) & finite(v[5])
    for i in range(5):
        k0, k1, k2 = hinge_row(i)
        t = 0.0
        t += m[i, k0] * v[k0]
        t += m[i, k1] * v[k1]
        t += m[i, k2] * v[k2]
        out[i] -= t
    return ok


@njit(cache=True)
def hinge_mtv_sub(m, v, out):
    """out -= m' v (``mtv_sub``) for a hinge block m; whether v is finite."""
    ok = finite(v[0]) & finite(v[1]) & finite(v[2]) & finite(v[3]) & finite(v[4])
    for j in range(3):
        t = 0.0
        t += m[j, j] * v[j]
        out[j] -= t
    for j in range(3, 6):
        i0, i1, i2, i3 = hinge_col(j)
        t = 0.0
        t += m[i0, j] * v[i0]
        t += m[i1, j] * v[i1]
        t += m[i2, j] * v[i2]
        t += m[i3, j] * v[i3]
        out[j] -= t
    return ok


@njit(cache=True)
def hinge_mdmt(m, dinv, out, tmp):
    """out -= m dinv m' (``mdmt``) for a hinge block m; whether dinv and m dinv are finite."""
    ok = True
    for i in range(5):
        k0, k1, k2 = hinge_row(i)
        m0, m1, m2 = m[i, k0], m[i, k1], m[i, k2]
        for b in range(6):
            t = 0.0
            t += m0 * dinv[k0, b]
            t += m1 * dinv[k1, b]
            t += m2 * dinv[k2, b]
            tmp[i, b] = t
            ok &= finite(t) & finite(dinv[i, b])
    ok &= finite(dinv[5, 0]) & finite(dinv[5, 1]) & finite(dinv[5, 2])
    ok &= finite(dinv[5, 3]) & finite(dinv[5, 4]) & finite(dinv[5, 5])
    for j in range(5):
        k0, k1, k2 = hinge_row(j)
        m0, m1, m2 = m[j, k0], m[j, k1], m[j, k2]
        for i in range(j + 1):
            t = 0.0
            t += tmp[i, k0] * m0
            t += tmp[i, k1] * m1
            t += tmp[i, k2] * m2
            out[i, j] -= t
            if j != i:
                out[j, i] -= t
    return ok


@njit(cache=True)
def hinge_mtdm_sub(m, dinv, out, tmp):
    """out -= m' dinv m (``mtdm_sub``) for a hinge block m; whether dinv and dinv m are finite."""
    ok = True
    for i in range(5):
        for b in range(3):
            t = 0.0
            t += dinv[i, b] * m[b, b]
            tmp[i, b] = t
            ok &= finite(t)
        for b in range(3, 6):
            k0, k1, k2, k3 = hinge_col(b)
            t = 0.0
            t += dinv[i, k0] * m[k0, b]
            t += dinv[i, k1] * m[k1, b]
            t += dinv[i, k2] * m[k2, b]
            t += dinv[i, k3] * m[k3, b]
            tmp[i, b] = t
            ok &= finite(t)
        ok &= finite(dinv[i, 0]) & finite(dinv[i, 1]) & finite(dinv[i, 2]) & finite(dinv[i, 3]) & finite(dinv[i, 4])
    for a in range(6):
        if a < 3:
            for b in range(a, 6):
                t = 0.0
                t += m[a, a] * tmp[a, b]
                out[a, b] -= t
                if b != a:
                    out[b, a] -= t
            continue
        i0, i1, i2, i3 = hinge_col(a)
        m0, m1, m2, m3 = m[i0, a], m[i1, a], m[i2, a], m[i3, a]
        for b in range(a, 6):
            t = 0.0
            t += m0 * tmp[i0, b]
            t += m1 * tmp[i1, b]
            t += m2 * tmp[i2, b]
            t += m3 * tmp[i3, b]
            out[a, b] -= t
            if b != a:
                out[b, a] -= t
    return ok
