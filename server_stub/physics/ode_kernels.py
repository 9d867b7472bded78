"""Compiled kernels of the ODE-like step (``server_stub.physics.ode_step``): the robot's dynamics in
reduced coordinates, the constraint rows of one step and an exact solver for them.

Generalised velocity u = (torso centre velocity (3), torso spin (3), hinge rates (n)), all in the
world frame. Bodies: 0 is the torso, k = j + 1 the child of hinge j. Every kernel is written from
the equations in ``ode_step``'s docstring, as plain loops (numba).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.rotations import rotation_into, rotation_matrix

#: row kinds
NORMAL = 0
FRICTION = 1
MOTOR = 2


@njit(cache=True, inline="always")
def _cross3(a, b):
    """a x b as a tuple: no array is made (the step's per-body loops would make thousands)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def _cross(a, b):
    x, y, z = _cross3(a, b)
    return np.array([x, y, z])


@njit(cache=True)
def _point_jacobian(point, k, com0, chains, anchors, axes, out):
    """Rows (3, dof) of the velocity of the material point ``point`` of body ``k``: out = dv/du."""
    nu = out.shape[1]
    for a in range(3):
        for c in range(nu):
            out[a, c] = 0.0
        out[a, a] = 1.0
    r = point - com0
    # v = w x r = -[r]x w
    out[0, 4] = r[2]
    out[0, 5] = -r[1]
    out[1, 3] = -r[2]
    out[1, 5] = r[0]
    out[2, 3] = r[1]
    out[2, 4] = -r[0]
    for j in range(anchors.shape[0]):
        if chains[k, j]:
            col = _cross(axes[j], point - anchors[j])
            for a in range(3):
                out[a, 6 + j] = col[a]


@njit(cache=True)
def dynamics(
    masses,
    principal,
    chains,
    parents,
    joint_of,
    local_axes,
    coms,
    quats,
    anchors,
    v0,
    w0,
    qd,
    gravity,
    drag_linear,
    drag_angular,
):
    """Mass matrix M (dof x dof), generalised force of gravity, spin, velocity products and every
    body's drag (force -drag_linear v at its centre, torque -drag_angular w, as SimSpark's
    DragController applies before each step) Q (so that M du/dt = Q + applied), and the world
    axes of the hinges."""
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nu = 6 + nj
    rot = np.empty((nb, 3, 3))
    for k in range(nb):
        rot[k] = rotation_matrix(quats[k])
    axes = np.empty((nj, 3))
    for j in range(nj):
        r = rot[j + 1]
        la = local_axes[j]
        for a in range(3):
            axes[j, a] = r[a, 0] * la[0] + r[a, 1] * la[1] + r[a, 2] * la[2]
    # world inertia of every body
    inertia = np.zeros((nb, 3, 3))
    for k in range(nb):
        for a in range(3):
            for b in range(3):
                s = 0.0
                for c in range(3):
                    s += rot[k, a, c] * principal[k, c] * rot[k, b, c]
                inertia[k, a, b] = s
    # spins and velocity-product accelerations (zero du/dt), parents before children
    spin = np.zeros((nb, 3))
    dspin = np.zeros((nb, 3))
    acc = np.zeros((nb, 3))
    spin[0] = w0
    for k in range(1, nb):
        p = parents[k]
        j = joint_of[k]
        turn = qd[j] * axes[j]
        spin[k] = spin[p] + turn
        dspin[k] = dspin[p] + _cross(spin[p], turn)
        ro = anchors[j] - coms[p]
        ao = acc[p] + _cross(dspin[p], ro) + _cross(spin[p], _cross(spin[p], ro))
        rc = coms[k] - anchors[j]
        acc[k] = ao + _cross(dspin[k], rc) + _cross(spin[k], _cross(spin[k], rc))
    m = np.zeros((nu, nu))
    q = np.zeros(nu)
    jv = np.zeros((3, nu))
    for k in range(nb):
        _point_jacobian(coms[k], k, coms[0], chains, anchors, axes, jv)
        # the angular Jacobian: columns 3-5 identity, the chain's axes
        cols = np.empty(nu, dtype=np.int64)
        ncols = 0
        for c in range(6):
            cols[ncols] = c
            ncols += 1
        for j in range(nj):
            if chains[k, j]:
                cols[ncols] = 6 + j
                ncols += 1
        jw = np.zeros((3, nu))
        jw[0, 3] = 1.0
        jw[1, 4] = 1.0
        jw[2, 5] = 1.0
        for j in range(nj):
            if chains[k, j]:
                for a in range(3):
                    jw[a, 6 + j] = axes[j, a]
        iw = np.zeros((3, nu))  # I_k jw
        for a in range(3):
            for ci in range(ncols):
                c = cols[ci]
                iw[a, c] = inertia[k, a, 0] * jw[0, c] + inertia[k, a, 1] * jw[1, c] + inertia[k, a, 2] * jw[2, c]
        mk = masses[k]
        for xi in range(ncols):
            x = cols[xi]
            for yi in range(xi, ncols):
                y = cols[yi]
                s = mk * (jv[0, x] * jv[0, y] + jv[1, x] * jv[1, y] + jv[2, x] * jv[2, y])
                s += jw[0, x] * iw[0, y] + jw[1, x] * iw[1, y] + jw[2, x] * iw[2, y]
                m[x, y] += s
                if x != y:
                    m[y, x] += s
        # generalised force: m (g - a) - drag v through jv, -(I dspin + w x I w) - drag w through jw
        f = mk * (gravity - acc[k])
        for a in range(3):
            vk = 0.0
            for ci in range(ncols):
                col = cols[ci]
                vk += jv[a, col] * (v0[col] if col < 3 else (w0[col - 3] if col < 6 else qd[col - 6]))
            f[a] -= drag_linear * vk
        iwk = np.array(
            [
                inertia[k, 0, 0] * spin[k, 0] + inertia[k, 0, 1] * spin[k, 1] + inertia[k, 0, 2] * spin[k, 2],
                inertia[k, 1, 0] * spin[k, 0] + inertia[k, 1, 1] * spin[k, 1] + inertia[k, 1, 2] * spin[k, 2],
                inertia[k, 2, 0] * spin[k, 0] + inertia[k, 2, 1] * spin[k, 1] + inertia[k, 2, 2] * spin[k, 2],
            ]
        )
        tq = -_cross(spin[k], iwk) - drag_angular * spin[k]
        for a in range(3):
            tq[a] -= inertia[k, a, 0] * dspin[k, 0] + inertia[k, a, 1] * dspin[k, 1] + inertia[k, a, 2] * dspin[k, 2]
        for ci in range(ncols):
            c = cols[ci]
            q[c] += jv[0, c] * f[0] + jv[1, c] * f[1] + jv[2, c] * f[2]
            q[c] += jw[0, c] * tq[0] + jw[1, c] * tq[1] + jw[2, c] * tq[2]
    return m, q, axes


@njit(cache=True)
def _cholesky(a):
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
def _cho_solve(lower, b):
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
def free_system(a, b, x, state, free):
    """The boxed LCP's rows ``free`` (``state`` 0) with every other row held where ``x`` has it:
    A_FF x_F = b_F - A_FB x_B, as (A_FF, right side); the inner system of ``box_qp`` and of the
    island solve's block pivoting."""
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
    it = 0
    while it < 4 * n + 19:  # the count of passes is returned
        it += 1
        free = np.nonzero(state == 0)[0]
        nf = free.size
        target = x.copy()
        if nf > 0:
            sub, rhs = free_system(a, b, x, state, free)
            lower, ok = _cholesky(sub)
            if not ok:
                break
            sol = _cho_solve(lower, rhs)
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


@njit(cache=True, inline="always")
def _plane_space3(n):
    """Two unit tangents completing the unit normal n to a right-handed basis, as tuples."""
    if abs(n[2]) > 0.7071:
        x, y, z = 0.0, -n[2], n[1]
    else:
        x, y, z = -n[1], n[0], 0.0
    norm = np.sqrt(x**2 + y**2 + z**2)
    t1 = (x / norm, y / norm, z / norm)
    return t1, _cross3(n, t1)


@njit(cache=True)
def _plane_space(n):
    """``_plane_space3`` as arrays."""
    (x1, y1, z1), (x2, y2, z2) = _plane_space3(n)
    return np.array([x1, y1, z1]), np.array([x2, y2, z2])


@njit(cache=True)
def step(
    masses,
    principal,
    chains,
    parents,
    joint_of,
    local_axes,
    coms,
    quats,
    anchors,
    v0,
    w0,
    qd,
    gravity,
    drag_linear,
    drag_angular,
    contact_body,
    contact_point,
    contact_normal,
    contact_depth,
    motor_target,
    motor_lo,
    motor_hi,
    joint_torque,
    motor_state,
    h,
    erp,
    normal_cfm,
    slip,
    surface_layer,
    motor_cfm,
):
    """One ODE-like step of one robot: the new generalised velocity u (dof), the contact forces
    (points x 3: normal, along t1, along t2), the tangents (points x 2 x 3), the motor torques
    (hinges) and the solver's iterations. Hinge j's row drives its rate to ``motor_target[j]``
    with a torque in [``motor_lo[j]``, ``motor_hi[j]``]; ``joint_torque`` is applied to the hinges
    besides (a motor pushing against its stop). ``motor_state`` (hinges) is the rows' active-set
    guess, updated in place."""
    nj = local_axes.shape[0]
    nu = 6 + nj
    m, q, axes = dynamics(
        masses,
        principal,
        chains,
        parents,
        joint_of,
        local_axes,
        coms,
        quats,
        anchors,
        v0,
        w0,
        qd,
        gravity,
        drag_linear,
        drag_angular,
    )
    u = np.empty(nu)
    u[0:3] = v0
    u[3:6] = w0
    u[6:] = qd
    for j in range(nj):
        q[6 + j] += joint_torque[j]
    lm, ok = _cholesky(m)
    free_u = u + h * _cho_solve(lm, q)
    nc = contact_point.shape[0]
    nr = 3 * nc + nj
    jac = np.zeros((nr, nu))
    c = np.zeros(nr)
    cfm = np.zeros(nr)
    lo = np.empty(nr)
    hi = np.empty(nr)
    state = np.zeros(nr, dtype=np.int64)
    tangents = np.empty((nc, 2, 3))
    jp = np.zeros((3, nu))
    for i in range(nc):
        n = contact_normal[i]
        t1, t2 = _plane_space(n)
        tangents[i, 0] = t1
        tangents[i, 1] = t2
        _point_jacobian(contact_point[i], contact_body[i], coms[0], chains, anchors, axes, jp)
        for col in range(nu):
            jac[3 * i, col] = n[0] * jp[0, col] + n[1] * jp[1, col] + n[2] * jp[2, col]
            jac[3 * i + 1, col] = t1[0] * jp[0, col] + t1[1] * jp[1, col] + t1[2] * jp[2, col]
            jac[3 * i + 2, col] = t2[0] * jp[0, col] + t2[1] * jp[1, col] + t2[2] * jp[2, col]
        depth = contact_depth[i] - surface_layer
        c[3 * i] = erp * depth / h if depth > 0.0 else 0.0
        cfm[3 * i] = normal_cfm
        lo[3 * i] = 0.0
        hi[3 * i] = np.inf
        state[3 * i] = 0
        for r in (3 * i + 1, 3 * i + 2):
            cfm[r] = slip
            lo[r] = -np.inf
            hi[r] = np.inf
    for j in range(nj):
        r = 3 * nc + j
        jac[r, 6 + j] = 1.0
        c[r] = motor_target[j]
        cfm[r] = motor_cfm
        lo[r] = motor_lo[j]
        hi[r] = motor_hi[j]
        state[r] = motor_state[j]
    # A = h J M^-1 J' + cfm, b = c - J u_free: then J u_new = c - cfm lambda (ODE's soft rows)
    minv_jt = np.empty((nu, nr))
    for r in range(nr):
        minv_jt[:, r] = _cho_solve(lm, jac[r].copy())
    a = np.empty((nr, nr))
    for r in range(nr):
        for s in range(r, nr):
            v = 0.0
            for col in range(nu):
                v += jac[r, col] * minv_jt[col, s]
            a[r, s] = h * v
            a[s, r] = h * v
        a[r, r] += cfm[r]
    b = c.copy()
    for r in range(nr):
        v = 0.0
        for col in range(nu):
            v += jac[r, col] * free_u[col]
        b[r] -= v
    lam, iterations = box_qp(a, b, lo, hi, state)
    for j in range(nj):
        motor_state[j] = state[3 * nc + j]
    new_u = free_u.copy()
    for r in range(nr):
        if lam[r] != 0.0:
            for col in range(nu):
                new_u[col] += h * minv_jt[col, r] * lam[r]
    forces = np.empty((nc, 3))
    for i in range(nc):
        forces[i, 0] = lam[3 * i]
        forces[i, 1] = lam[3 * i + 1]
        forces[i, 2] = lam[3 * i + 2]
    torques = lam[3 * nc :].copy()
    return new_u, forces, tangents, torques, iterations


@njit(cache=True)
def integrate_orientation(quat, w, h):
    """Unit quaternion (x, y, z, w) turned by the world spin ``w`` over ``h`` (exact rotation)."""
    angle = np.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2) * h
    if angle < 1e-12:
        return quat.copy()
    axis = w * h / angle
    s = np.sin(angle / 2)
    dx, dy, dz, dw = axis[0] * s, axis[1] * s, axis[2] * s, np.cos(angle / 2)
    x, y, z, qw = quat[0], quat[1], quat[2], quat[3]
    out = np.array(
        [
            dw * x + dx * qw + dy * z - dz * y,
            dw * y - dx * z + dy * qw + dz * x,
            dw * z + dx * y - dy * x + dz * qw,
            dw * qw - dx * x - dy * y - dz * z,
        ]
    )
    return out / np.sqrt(np.sum(out * out))


BOX = 3
SPHERE = 2
CAPSULE = 7


@njit(cache=True)
def box_plane(c, r, size, max_points):
    """ODE 0.16's box-plane contacts (plane z = 0, normal +z), at most ``max_points`` (<= 4): the
    deepest corner; the corner one side away along the side whose projection on the normal is
    shortest, as deep as the first less that projection; the corner one side away from the first
    along the side with the next shortest projection, as deep as the first less its projection;
    each only while that depth is >= 0. With 4 asked and those 3 made, the face's fourth corner
    (second + third - first), as deep as their depths' sum less the first's, only if that is > 0.
    So a box landing on an edge touches at 3 corners, never at the corner along its longest
    projection, however deep. Equal to libode 0.16.2's dCollide on 160,000 random poses to 1e-12
    (a scratch check; ``tests/test_ode_colliders.py`` keeps checking it). Returns (points, depths)."""
    a = np.empty(3)
    bb = np.empty(3)
    p = c.copy()
    for i in range(3):
        a[i] = size[i] * r[2, i]
        bb[i] = abs(a[i])
        sign = -0.5 if a[i] > 0.0 else 0.5
        for q in range(3):
            p[q] += sign * size[i] * r[q, i]
    depth = 0.5 * (bb[0] + bb[1] + bb[2]) - c[2]
    points = np.empty((4, 3))
    depths = np.empty(4)
    if depth < 0.0:
        return points[:0], depths[:0]
    points[0] = p
    depths[0] = depth
    # the two sides with the shortest projections, ties broken as ODE's comparisons break them
    if bb[0] < bb[1]:
        if bb[2] < bb[0]:
            first, second = 2, 0
        else:
            first, second = 0, (1 if bb[1] < bb[2] else 2)
    else:
        if bb[2] < bb[1]:
            first, second = 2, 1
        else:
            first, second = 1, (0 if bb[0] < bb[2] else 2)
    n = 1
    for side in (first, second):
        if n >= max_points or depth - bb[side] < 0.0:
            break
        sign = 1.0 if a[side] > 0.0 else -1.0
        for q in range(3):
            points[n, q] = p[q] + sign * size[side] * r[q, side]
        depths[n] = depth - bb[side]
        n += 1
    if max_points >= 4 and n == 3:
        d4 = depths[1] + depths[2] - depth
        if d4 > 0.0:
            for q in range(3):
                points[3, q] = points[1, q] + points[2, q] - p[q]
            depths[3] = d4
            n = 4
    return points[:n], depths[:n]


@njit(cache=True)
def ground_contacts(shape_body, shape_kind, shape_size, coms, quats, max_points):
    """Contacts of a robot's shapes with the ground plane z = 0, as ODE's colliders make them:
    only for touching or overlapping geometry (depth >= 0); a box gets ODE's box-plane contacts
    (``box_plane``, at most ``max_points``, as many as SimSpark asks ODE for: 4); a sphere its
    lowest point; a capsule (size: length, radius, along its z) the lowest point of its lower end,
    then of the other (ODE's order). Shapes sit at their body's centre with its axes. Returns
    (body, point (n x 3), depth) per contact; the normal is +z."""
    n = shape_body.shape[0]
    cap = n * max(max_points, 2)
    bodies = np.empty(cap, dtype=np.int64)
    points = np.empty((cap, 3))
    depths = np.empty(cap)
    count = 0
    r = np.empty((3, 3))
    for s in range(n):
        k = shape_body[s]
        rotation_into(quats[k], r)
        c = coms[k]
        kind = shape_kind[s]
        if kind == BOX:
            bp, bd = box_plane(c, r, shape_size[s], max_points)
            for i in range(bd.shape[0]):
                bodies[count] = k
                points[count] = bp[i]
                depths[count] = bd[i]
                count += 1
        elif kind == SPHERE:
            rad = shape_size[s, 0]
            if c[2] - rad <= 0.0:
                bodies[count] = k
                points[count, 0] = c[0]
                points[count, 1] = c[1]
                points[count, 2] = c[2] - rad
                depths[count] = rad - c[2]
                count += 1
        elif kind == CAPSULE:
            # ODE's capsule-plane: the lower end's sphere first (none at all if it is clear of
            # the ground), then the other end's if at least 2 are asked for and it touches too
            half = shape_size[s, 0] / 2 * (-1.0 if r[2, 2] > 0.0 else 1.0)
            rad = shape_size[s, 1]
            for end in range(min(max_points, 2)):
                side = half if end == 0 else -half
                e2 = c[2] + r[2, 2] * side
                if e2 - rad > 0.0:
                    break
                bodies[count] = k
                points[count, 0] = c[0] + r[0, 2] * side
                points[count, 1] = c[1] + r[1, 2] * side
                points[count, 2] = e2 - rad
                depths[count] = rad - e2
                count += 1
    return bodies[:count], points[:count], depths[:count]


@njit(cache=True)
def joint_drift(parents, joint_of, local_axes, coms, quats, anchors, w0, qd, h):
    """How far each hinge's two copies of its anchor move apart, and how far the child turns off
    the hinge, in one step when every body is integrated on its own, as ODE's maximal coordinates
    do (centre by h v, orientation turned by h w). Anchor: the chord-for-arc error
    h^2/2 (w_c x (w_c x r_c) - w_p x (w_p x r_p)), r from each body's centre to the anchor, w_c and
    w_p the child's and the parent's spins (child copy minus parent copy). Turn: the two turns do
    not commute, exp(-h w_p) exp(h w_c) = exp(h qd a + h^2/2 qd (a x w_p)), so the child ends
    turned by h^2/2 qd (a x w_p) off its hinge. Returns (anchor gaps, turns), hinges x 3 each; the
    joint's velocity rows keep both at zero to first order, and ODE's joint ERP then pulls these
    second-order errors back."""
    nb = coms.shape[0]
    nj = local_axes.shape[0]
    spin = np.zeros((nb, 3))
    spin[0] = w0
    gap = np.zeros((nj, 3))
    turn = np.zeros((nj, 3))
    for k in range(1, nb):
        p = parents[k]
        j = joint_of[k]
        r = rotation_matrix(quats[k])
        la = local_axes[j]
        axis = np.array(
            [
                r[0, 0] * la[0] + r[0, 1] * la[1] + r[0, 2] * la[2],
                r[1, 0] * la[0] + r[1, 1] * la[1] + r[1, 2] * la[2],
                r[2, 0] * la[0] + r[2, 1] * la[1] + r[2, 2] * la[2],
            ]
        )
        spin[k] = spin[p] + qd[j] * axis
        rc = anchors[j] - coms[k]
        rp = anchors[j] - coms[p]
        gap[j] = 0.5 * h * h * (_cross(spin[k], _cross(spin[k], rc)) - _cross(spin[p], _cross(spin[p], rp)))
        turn[j] = 0.5 * h * h * qd[j] * _cross(axis, spin[p])
    return gap, turn


@njit(cache=True)
def _rotvec_matrix(v):
    angle = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    out = np.eye(3)
    if angle < 1e-15:
        return out
    k = v / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    s = np.sin(angle)
    c = 1.0 - np.cos(angle)
    for a in range(3):
        for b in range(3):
            kk = 0.0
            for m in range(3):
                kk += kx[a, m] * kx[m, b]
            out[a, b] += s * kx[a, b] + c * kk
    return out


@njit(cache=True)
def drifted_poses(parents, joint_of, coms, quats, anchors, gap, turn):
    """Where ODE would have the bodies: each hinge's subtree turned by its ``turn`` about the
    hinge's anchor and moved by its anchor ``gap``, from the torso down. Returns (centres,
    quaternions)."""
    nb = coms.shape[0]
    acc_r = np.empty((nb, 3, 3))
    acc_t = np.zeros((nb, 3))
    acc_r[0] = np.eye(3)
    out_c = coms.copy()
    out_q = quats.copy()
    for k in range(1, nb):
        p = parents[k]
        j = joint_of[k]
        d = _rotvec_matrix(turn[j])
        # the parent's correction, then this hinge's: x -> D (x - a) + a + gap, a the anchor
        ra = acc_r[p]
        ta = acc_t[p]
        a = anchors[j]
        for x in range(3):
            for y in range(3):
                s = 0.0
                for m in range(3):
                    s += ra[x, m] * d[m, y]
                acc_r[k, x, y] = s
        da = np.zeros(3)
        for x in range(3):
            da[x] = a[x] + gap[j, x] - (d[x, 0] * a[0] + d[x, 1] * a[1] + d[x, 2] * a[2])
        for x in range(3):
            acc_t[k, x] = ta[x] + ra[x, 0] * da[0] + ra[x, 1] * da[1] + ra[x, 2] * da[2]
        c = coms[k]
        for x in range(3):
            out_c[k, x] = acc_r[k, x, 0] * c[0] + acc_r[k, x, 1] * c[1] + acc_r[k, x, 2] * c[2] + acc_t[k, x]
        # turn the orientation: q' = quat(acc_r) * q
        m = acc_r[k]
        tr = m[0, 0] + m[1, 1] + m[2, 2]
        w = np.sqrt(max(0.0, 1.0 + tr)) / 2.0
        if w > 1e-6:
            qx = (m[2, 1] - m[1, 2]) / (4.0 * w)
            qy = (m[0, 2] - m[2, 0]) / (4.0 * w)
            qz = (m[1, 0] - m[0, 1]) / (4.0 * w)
        else:
            qx, qy, qz, w = 0.0, 0.0, 0.0, 1.0
        q0 = quats[k]
        out_q[k, 0] = w * q0[0] + qx * q0[3] + qy * q0[2] - qz * q0[1]
        out_q[k, 1] = w * q0[1] - qx * q0[2] + qy * q0[3] + qz * q0[0]
        out_q[k, 2] = w * q0[2] + qx * q0[1] - qy * q0[0] + qz * q0[3]
        out_q[k, 3] = w * q0[3] - qx * q0[0] - qy * q0[1] - qz * q0[2]
    return out_c, out_q


@njit(cache=True)
def far_apart(pos, owner, count, ball, reach, ball_reach, static_lo, static_hi):
    """Whether no two of ``count`` robots (their bodies' centres ``pos``, body b of robot
    ``owner[b]``, each grown by ``reach``), the ball (grown by ``ball_reach``) and the static boxes
    (``static_lo``/``static_hi`` corners) have overlapping boxes: then nothing can touch."""
    lo = np.full((count + 1, 3), np.inf)
    hi = np.full((count + 1, 3), -np.inf)
    for b in range(pos.shape[0]):
        o = owner[b]
        for d in range(3):
            lo[o, d] = min(lo[o, d], pos[b, d] - reach)
            hi[o, d] = max(hi[o, d], pos[b, d] + reach)
    for d in range(3):
        lo[count, d] = ball[d] - ball_reach
        hi[count, d] = ball[d] + ball_reach
    for i in range(count + 1):
        for j in range(i + 1, count + 1):
            if _boxes_overlap(lo[i], hi[i], lo[j], hi[j]):
                return False
        for s in range(static_lo.shape[0]):
            if _boxes_overlap(lo[i], hi[i], static_lo[s], static_hi[s]):
                return False
    return True


@njit(cache=True, inline="always")
def _boxes_overlap(lo_a, hi_a, lo_b, hi_b):
    return (
        lo_a[0] <= hi_b[0]
        and lo_b[0] <= hi_a[0]
        and lo_a[1] <= hi_b[1]
        and lo_b[1] <= hi_a[1]
        and lo_a[2] <= hi_b[2]
        and lo_b[2] <= hi_a[2]
    )
