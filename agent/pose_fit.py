"""The vision fit of ``agent.localization.VisionPose`` as one compiled kernel.

In numpy the fit took some 60 small array operations a step (1.5 to 2 ms a vision cycle, numpy's
overhead per call, not arithmetic); compiled, the same arithmetic over a few dozen rows takes
about 40 us, which matters to an optimizer that walks thousands of episodes. Compiling it takes
seconds, loading it from numba's cache (``__pycache__``) some 0.1 s: ``warm_up`` does that before
the first vision cycle needs it.

The fit (``fit``): unknowns s = (x, y, heading, z, pitch, roll) of the torso, the torso's rotation
``R = Rz(heading - 90 deg) Rx(pitch) Ry(roll)`` (torso frame x right, y forward, z up). A seen
point with torso-frame position q lands in the field at w = t + R q, t = (x, y, z). Every
residual is g . w - b for a direction g and a number b:

- a named landmark: its three axes against its known place;
- a line point (either end of a seen line piece): its height against the ground (z 0);
- a line point whose piece matched a known line: its distance across that line, and, for an end
  the view did not cut (``cut``), its distance along it from the line's nearer end.

The derivatives of R q: axis x (R q), with the axes z for the heading, the level right axis
(sin h, -cos h, 0) for the pitch and the pitched forward axis (cos p cos h, cos p sin h, sin p)
for the roll. Gauss-Newton with the prior as extra rows (information ``info`` about ``prior``):
an iterated Kalman update. The first steps use the landmarks and the ground only, which fixes
the heading well enough to match lines; the lines are matched again before each later step,
within gates from the previous step's covariance.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _rotation(h: float, p: float, r: float) -> np.ndarray:
    """``Rz(h - 90 deg) Rx(p) Ry(r)``."""
    ch, sh, cp, sp, cr, sr = math.cos(h), math.sin(h), math.cos(p), math.sin(p), math.cos(r), math.sin(r)
    z = np.array([[sh, ch, 0.0], [-ch, sh, 0.0], [0.0, 0.0, 1.0]])
    x = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    y = np.array([[cr, 0.0, sr], [0.0, 1.0, 0.0], [-sr, 0.0, cr]])
    return z @ x @ y


@njit(cache=True)
def _cholesky(a: np.ndarray) -> np.ndarray:
    """The lower factor L of a symmetric positive definite matrix, a = L L' (numba's LAPACK
    wrappers copy and check more than a 6 x 6 system costs)."""
    n = a.shape[0]
    low = np.zeros_like(a)
    for i in range(n):
        for j in range(i + 1):
            total = a[i, j]
            for k in range(j):
                total -= low[i, k] * low[j, k]
            low[i, j] = math.sqrt(total) if i == j else total / low[j, j]
    return low


@njit(cache=True)
def _solve(low: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with L L' x = b."""
    n = b.shape[0]
    y = np.empty(n)
    for i in range(n):
        total = b[i]
        for k in range(i):
            total -= low[i, k] * y[k]
        y[i] = total / low[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        total = y[i]
        for k in range(i + 1, n):
            total -= low[k, i] * x[k]
        x[i] = total / low[i, i]
    return x


@njit(cache=True)
def _inverse(low: np.ndarray) -> np.ndarray:
    n = low.shape[0]
    out = np.empty((n, n))
    unit = np.zeros(n)
    for j in range(n):
        unit[:] = 0.0
        unit[j] = 1.0
        out[:, j] = _solve(low, unit)
    return out


@njit(cache=True)
def fit(
    polar: np.ndarray,
    neck: np.ndarray,
    camera: np.ndarray,
    landmarks: np.ndarray,
    lines: np.ndarray,
    prior: np.ndarray,
    covariance: np.ndarray,
    settings: np.ndarray,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray, float]:
    """The maximum a posteriori torso pose: ((x, y, heading), its covariance 3 x 3, the squared
    Mahalanobis distance of the change from the prior in the prior's covariance).

    ``polar``: the seen points as the camera reports them (distance m, horizontal and vertical
    deg), the landmarks' first (``landmarks`` holds their field places, one row each), then the
    line pieces' ends in pairs. ``neck``, ``camera``: the head's rotation in the torso frame and
    the camera's place there. ``lines``: the known lines, rows of start x, y, unit direction x,
    y, length. ``prior``: (x, y, heading) predicted, with ``covariance``, then height, pitch and
    roll. ``settings``: the camera's error at no distance and per metre (m), the tangent of the
    angle beyond which a line end was cut by the view, the matching gate (m), its widening in
    the prior's standard deviations, its cap, the shortest piece matched (m), the height's and
    the tilt's standard deviations (m, rad).

    A piece matches the known line both its ends lie nearest to, across it, within a gate that
    widens with the prior's spread at the piece's distance."""
    point_sigma, angle_sigma, cut_tangent, gate_base, gate_sigmas, gate_max = settings[:6]
    min_length, height_sigma, tilt_sigma = settings[6:9]
    n = polar.shape[0]
    q = np.empty((n, 3))
    weight = np.empty(n)
    cut = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        d, hr, vr = polar[i, 0], math.radians(polar[i, 1]), math.radians(polar[i, 2])
        flat = d * math.cos(vr)
        px, py, pz = -flat * math.sin(hr), flat * math.cos(hr), d * math.sin(vr)
        # cut by a side of the view pyramid: |x| / y or |z| / y beyond the edge's tangent
        cut[i] = abs(px) > cut_tangent * py or abs(pz) > cut_tangent * py
        for k in range(3):
            q[i, k] = camera[k] + neck[k, 0] * px + neck[k, 1] * py + neck[k, 2] * pz
        weight[i] = 1.0 / (point_sigma**2 + (angle_sigma * d) ** 2)
    distance = polar[:, 0]
    prior_info = _inverse(_cholesky(covariance))
    info = np.zeros((6, 6))
    info[:3, :3] = prior_info
    info[3, 3] = 1.0 / height_sigma**2
    info[4, 4] = info[5, 5] = 1.0 / tilt_sigma**2
    sigma_xy = math.sqrt(max(covariance[0, 0], covariance[1, 1]))
    sigma_heading = math.sqrt(covariance[2, 2])
    n_land = landmarks.shape[0]
    n_pieces = (n - n_land) // 2
    n_known = lines.shape[0]
    matched = np.full(n_pieces, -1)
    # two steps on the landmarks before the lines are matched: from a heading some degrees off
    # (a beam's noise) the first step alone leaves lines looking near the wrong ones
    first_match = 2 if n_land > 0 else 1
    s = prior.copy()
    hessian = info.copy()
    known = covariance
    jac = np.empty(6)
    w = np.empty((n, 3))
    origin = np.empty(3)
    for step in range(iterations):
        h, p = s[2], s[4]
        origin[0], origin[1], origin[2] = s[0], s[1], s[3]
        rot = _rotation(h, p, s[5])
        for i in range(n):
            for k in range(3):
                w[i, k] = origin[k] + rot[k, 0] * q[i, 0] + rot[k, 1] * q[i, 1] + rot[k, 2] * q[i, 2]
        if step >= first_match:
            for j in range(n_pieces):
                ax, ay = w[n_land + 2 * j, 0], w[n_land + 2 * j, 1]
                bx, by = w[n_land + 2 * j + 1, 0], w[n_land + 2 * j + 1, 1]
                matched[j] = -1
                if math.hypot(bx - ax, by - ay) < min_length:
                    continue
                far = max(distance[n_land + 2 * j], distance[n_land + 2 * j + 1])
                gate = min(gate_base + gate_sigmas * (sigma_xy + far * sigma_heading), gate_max)
                best = gate
                for m in range(n_known):
                    sx, sy, dx, dy, length = lines[m, 0], lines[m, 1], lines[m, 2], lines[m, 3], lines[m, 4]
                    along_a = (ax - sx) * dx + (ay - sy) * dy
                    along_b = (bx - sx) * dx + (by - sy) * dy
                    if min(along_a, along_b) < -gate or max(along_a, along_b) > length + gate:
                        continue
                    cost = max(abs((ay - sy) * dx - (ax - sx) * dy), abs((by - sy) * dx - (bx - sx) * dy))
                    if cost < best:
                        best = cost
                        matched[j] = m
        ch, sh, cp, sp = math.cos(h), math.sin(h), math.cos(p), math.sin(p)
        hessian = info.copy()
        gradient = np.zeros(6)
        for a in range(6):
            for c in range(6):
                gradient[a] += info[a, c] * (s[c] - prior[c])
        for i in range(q.shape[0]):
            vx, vy, vz = w[i, 0] - s[0], w[i, 1] - s[1], w[i, 2] - s[3]
            # the turns' effect on w: z x v, right x v, forward x v
            t_h = (-vy, vx, 0.0)
            t_p = (-ch * vz, -sh * vz, sh * vy + ch * vx)
            fx, fy, fz = cp * ch, cp * sh, sp
            t_r = (fy * vz - fz * vy, fz * vx - fx * vz, fx * vy - fy * vx)
            if i < n_land:
                rows = 3
            else:
                piece = matched[(i - n_land) // 2]
                rows = 1 if piece < 0 else (2 if cut[i] else 3)
            for k in range(rows):
                if i < n_land:
                    gx, gy, gz = (1.0 if k == 0 else 0.0), (1.0 if k == 1 else 0.0), (1.0 if k == 2 else 0.0)
                    b = landmarks[i, k]
                elif k == 0:  # on the ground
                    gx, gy, gz, b = 0.0, 0.0, 1.0, 0.0
                else:
                    m = matched[(i - n_land) // 2]
                    sx, sy, dx, dy, length = lines[m, 0], lines[m, 1], lines[m, 2], lines[m, 3], lines[m, 4]
                    if k == 1:  # across the line: along its normal (-dy, dx)
                        gx, gy, gz, b = -dy, dx, 0.0, -dy * sx + dx * sy
                    else:  # along it, from its nearer end
                        along = (w[i, 0] - sx) * dx + (w[i, 1] - sy) * dy
                        gx, gy, gz = dx, dy, 0.0
                        b = sx * dx + sy * dy + (length if along > 0.5 * length else 0.0)
                residual = gx * w[i, 0] + gy * w[i, 1] + gz * w[i, 2] - b
                jac[0], jac[1], jac[3] = gx, gy, gz
                jac[2] = gx * t_h[0] + gy * t_h[1] + gz * t_h[2]
                jac[4] = gx * t_p[0] + gy * t_p[1] + gz * t_p[2]
                jac[5] = gx * t_r[0] + gy * t_r[1] + gz * t_r[2]
                wi = weight[i]
                for a in range(6):
                    wj = wi * jac[a]
                    gradient[a] += wj * residual
                    for c in range(a + 1):
                        hessian[a, c] += wj * jac[c]
        for a in range(6):  # the lower triangle was summed
            for c in range(a):
                hessian[c, a] = hessian[a, c]
        low = _cholesky(hessian)
        s = s - _solve(low, gradient)
        if step + 1 >= first_match and step + 1 < iterations:
            # the gates of the next matching from what this step knows
            known = _inverse(low)
            sigma_xy = math.sqrt(max(known[0, 0], known[1, 1]))
            sigma_heading = math.sqrt(known[2, 2])
    known = _inverse(_cholesky(hessian))
    change = s[:3] - prior[:3]
    return s[:3], known[:3, :3], change @ prior_info @ change


def warm_up() -> None:
    """Compile the fit (or load it from numba's disk cache) now rather than in the first vision
    cycle of a run."""
    fit(
        np.array([[10.0, 0.0, -3.0], [10.0, 30.0, -3.0], [10.0, -30.0, -3.0]]),
        np.eye(3),
        np.array([0.0, 0.0, 0.155]),
        np.array([[15.0, 0.0, 0.0]]),
        np.array([[0.0, 10.0, 0.0, -1.0, 20.0]]),
        np.array([0.0, 0.0, 0.0, 0.37, 0.0, 0.0]),
        np.eye(3),
        np.array([0.008, 0.003, 1.6, 0.25, 3.0, 1.5, 0.3, 0.05, 0.07]),
        3,
    )
