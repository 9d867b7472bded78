"""The "ode" backend's maximal-coordinate step (``PhysicsConfig.ode_maximal``): every body of the
robot integrated on its own, as ODE 0.16's ``dWorldStep`` does, the hinges held by constraint rows.

Facts (read in ODE 0.16's step.cpp, joints/hinge.cpp, joints/joint.cpp (dxJointLimitMotor),
ode.cpp, and SimSpark's rsg/agent/nao/hingejoint.rsg, spark.rb, dragcontroller.cpp; our own code):

- each body (torso and the 22 hinge children) has a centre x, a quaternion q, a velocity v and a
  spin w (world), its mass and its uniform solid's principal moments (docs/robot_and_server.md
  section 2, no floor);
- forces before the step: gravity m g, SimSpark's DragController (-0.01 v, torque -0.01 w), and
  ODE's gyroscopic term, on by default in 0.16 (dBodyCreate sets dxBodyGyroscopic) and computed
  implicitly (Lacoursiere): with L = I w and I~ = I - h [L]x, the torque (I I~^-1 - 1) L / h;
- a hinge (ODE body 1 = the child, body 2 = the parent, as SimSpark's ``attach`` orders them):
  3 rows keep its anchor copies together (c = ERP/h times their gap), 2 rows keep the child's axis
  on the parent's (about the two directions across the child's axis, c = ERP/h times
  (a1 x a2) along each); ERP and CFM are the world's (ODE's default 0.2, SimSpark's 1e-5). Then
  one motor or limit row about the child's axis: inside the range a motor (target speed,
  |torque| <= 10 N m, CFM 1e-8); at a stop (angle at the step's start <= low or >= high) ODE's
  one-sided limit row (ERP 0.8, bounce 1, CFM 1e-8) and the motor's full torque as an outside
  torque when it drives into the stop (times the fudge factor 1e-5 when away, i.e. nothing): the
  targets and bounds are ``server_stub.physics.motors``' and ``ode_step._motor_rows``';
- (contacts with other robots, the ball and the goals: ``ode_contacts`` / ``ode_island``, the same
  rows generalised to islands of several robots)
- ground contacts as the reduced "ode" backend makes them (``ode_kernels.ground_contacts``, from
  the bodies' own poses): a normal row (>= 0, ERP 0.4 on depth less the surface layer 0.001,
  CFM 1e-4) and two friction rows (unbounded, CFM = slip 0.005);
- the LCP of dWorldStep, scaled by h: A = h J M^-1 J' + diag(cfm), b = c - J (v + h M^-1 f),
  solved exactly: the unbounded rows (hinges, friction) eliminated by a Cholesky factor, the
  bounded ones (motors, stops, normals) by ``ode_kernels.box_qp`` on the Schur complement;
- v += h M^-1 (f + J' lambda), then x += h v and ODE's infinitesimal rotation
  q += h/2 (0, w) q, normalised (SimSpark does not turn on finite rotation);
- the hinge angle as dJointGetHingeAngle measures it from the two bodies' quaternions.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from server_stub.physics.ode_kernels import (
    _cho_solve,
    _cholesky,
    _cross,
    _cross3,
    _plane_space,
    _plane_space3,
    box_qp,
)
from server_stub.physics.rotations import rotation_into, rotation_matrix

# The per-body and per-hinge loops below work on tuples (``_qmul4``, ``_mv3``, ``_cross3``) and
# scratch arrays made once per call, and their small helpers are inlined (``inline="always"``):
# a small array made, or a helper called with array views, in such a loop costs more than its
# arithmetic. Every sum is taken in the same order either way, so the results are the same bits.


@njit(cache=True, inline="always")
def _qmul4(a, b):
    """Hamilton product of (x, y, z, w) quaternions, as a tuple."""
    return (
        a[3] * b[0] + b[3] * a[0] + a[1] * b[2] - a[2] * b[1],
        a[3] * b[1] + b[3] * a[1] + a[2] * b[0] - a[0] * b[2],
        a[3] * b[2] + b[3] * a[2] + a[0] * b[1] - a[1] * b[0],
        a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
    )


@njit(cache=True)
def _qmul(a, b):
    """Hamilton product of (x, y, z, w) quaternions."""
    x, y, z, w = _qmul4(a, b)
    return np.array([x, y, z, w])


@njit(cache=True)
def _conj(a):
    return np.array([-a[0], -a[1], -a[2], a[3]])


@intrinsic
def _fma(typingctx, a, b, c):
    """a b + c rounded once (LLVM's fma: the CPU's fused multiply-add, or libm's where it has none)."""

    def codegen(context, builder, signature, args):
        double = ir.DoubleType()
        fma = builder.module.declare_intrinsic("llvm.fma", [double], ir.FunctionType(double, [double] * 3))
        return builder.call(fma, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@njit(cache=True, inline="always")
def _mat_mul3(a, b):
    """a b for 3x3 matrices as numba's ``@`` computes it, without the library call (which costs
    more than the product): ``@`` calls OpenBLAS's dgemm, whose x86-64 kernels accumulate each
    entry as a chain of fused multiply-adds in k order; so does this (bit for bit the same on
    200 000 random products and every step of the test gaits)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = _fma(a[i, 2], b[2, j], _fma(a[i, 1], b[1, j], a[i, 0] * b[0, j]))
    return out


@njit(cache=True, inline="always")
def _mv3(m, v):
    """m v for a 3x3 m, as a tuple."""
    return (
        m[0, 0] * v[0] + m[0, 1] * v[1] + m[0, 2] * v[2],
        m[1, 0] * v[0] + m[1, 1] * v[1] + m[1, 2] * v[2],
        m[2, 0] * v[0] + m[2, 1] * v[1] + m[2, 2] * v[2],
    )


@njit(cache=True)
def _mat_vec(m, v):
    x, y, z = _mv3(m, v)
    return np.array([x, y, z])


@njit(cache=True, inline="always")
def hinge_angle(q_child, q_parent, local_axis):
    """dJointGetHingeAngle for bodies whose frames agree at angle 0: from the child's orientation
    relative to the parent's, the rotation's size signed by its part along the axis (so a turn off
    the axis shows in the angle, as on the real server)."""
    rel = _qmul4((-q_child[0], -q_child[1], -q_child[2], q_child[3]), q_parent)  # the parent seen from the child
    s = np.sqrt(rel[0] ** 2 + rel[1] ** 2 + rel[2] ** 2)
    along = rel[0] * local_axis[0] + rel[1] * local_axis[1] + rel[2] * local_axis[2]
    if along >= 0.0:
        theta = 2.0 * np.arctan2(s, rel[3])
    else:
        theta = 2.0 * np.arctan2(s, -rel[3])
    if theta > np.pi:
        theta -= 2.0 * np.pi
    return -theta


@njit(cache=True)
def measure(quats, spins, parents, joint_of, local_axes):
    """Every hinge's angle and rate as the real server reads them (child = body 1)."""
    nj = local_axes.shape[0]
    angles = np.empty(nj)
    rates = np.empty(nj)
    rot = np.empty((3, 3))
    for k in range(1, quats.shape[0]):
        j = joint_of[k]
        p = parents[k]
        angles[j] = hinge_angle(quats[k], quats[p], local_axes[j])
        rotation_into(quats[k], rot)
        axis = _mv3(rot, local_axes[j])
        rel = (spins[k, 0] - spins[p, 0], spins[k, 1] - spins[p, 1], spins[k, 2] - spins[p, 2])
        rates[j] = axis[0] * rel[0] + axis[1] * rel[1] + axis[2] * rel[2]
    return angles, rates


@njit(cache=True)
def measured_state(pos, quat, vel, spin, parents, joint_of, local_axes):
    """What the torso and the hinges show after a step, in one array (what is written into
    pybullet and kept to compare with it): torso centre (3), quaternion (4), velocity (3), spin
    (3), then the hinge angles and rates (``measure``)."""
    angles, rates = measure(quat, spin, parents, joint_of, local_axes)
    nj = angles.shape[0]
    out = np.empty(13 + 2 * nj)
    out[0:3] = pos[0]
    out[3:7] = quat[0]
    out[7:10] = vel[0]
    out[10:13] = spin[0]
    out[13 : 13 + nj] = angles
    out[13 + nj :] = rates
    return out


@njit(cache=True)
def body_velocities(parents, joint_of, local_axes, coms, quats, anchors, v0, w0, qd):
    """Each body's centre velocity and spin from the torso's and the hinge rates (exact joints)."""
    nb = coms.shape[0]
    vel = np.zeros((nb, 3))
    spin = np.zeros((nb, 3))
    vel[0] = v0
    spin[0] = w0
    for k in range(1, nb):
        p = parents[k]
        j = joint_of[k]
        axis = _mat_vec(rotation_matrix(quats[k]), local_axes[j])
        spin[k] = spin[p] + qd[j] * axis
        vel[k] = vel[p] + _cross(spin[p], anchors[j] - coms[p]) + _cross(spin[k], coms[k] - anchors[j])
    return vel, spin


@njit(cache=True)
def local_anchors(parents, joint_of, coms, quats, anchors):
    """Each hinge's anchor in its child's and its parent's body frame (from an exact pose)."""
    nj = anchors.shape[0]
    child = np.empty((nj, 3))
    parent = np.empty((nj, 3))
    for k in range(1, coms.shape[0]):
        j = joint_of[k]
        p = parents[k]
        rc = rotation_matrix(quats[k])
        rp = rotation_matrix(quats[p])
        dc = anchors[j] - coms[k]
        dp = anchors[j] - coms[p]
        for a in range(3):
            child[j, a] = rc[0, a] * dc[0] + rc[1, a] * dc[1] + rc[2, a] * dc[2]
            parent[j, a] = rp[0, a] * dp[0] + rp[1, a] * dp[1] + rp[2, a] * dp[2]
    return child, parent


@njit(cache=True)
def anchor_gaps(parents, joint_of, coms, quats, anchor_child, anchor_parent):
    """Distance (m) between each hinge's two anchor copies."""
    nj = anchor_child.shape[0]
    gaps = np.empty(nj)
    for k in range(1, coms.shape[0]):
        j = joint_of[k]
        p = parents[k]
        a1 = coms[k] + _mat_vec(rotation_matrix(quats[k]), anchor_child[j])
        a2 = coms[p] + _mat_vec(rotation_matrix(quats[p]), anchor_parent[j])
        d = a1 - a2
        gaps[j] = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    return gaps


@njit(cache=True)
def move_rigidly(pos, quat, old_position, old_orientation, new_position, new_orientation):
    """Move every body (in place) by the rigid motion taking the torso from its old pose to its
    new one, as SimSpark's beam moves an agent's bodies."""
    turn = _qmul(new_orientation, _conj(old_orientation))
    r = rotation_matrix(turn)
    for k in range(pos.shape[0]):
        d = pos[k] - old_position
        moved = _mat_vec(r, d)
        for a in range(3):
            pos[k, a] = new_position[a] + moved[a]
        q = _qmul(turn, quat[k])
        quat[k] = q / np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)


@njit(cache=True, inline="always")
def _invert3(m):
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


@njit(cache=True, inline="always")
def gyroscopic_torque(inertia, w, h, implicit):
    """ODE 0.16's gyroscopic torque of one body: implicit (its default), (I I~^-1 - 1) L / h with
    L = I w and I~ = I - h [L]x; explicit, -w x I w. A tuple."""
    big_l = _mv3(inertia, w)
    if not implicit:
        x, y, z = _cross3(w, big_l)
        return (-x, -y, -z)
    tilde = inertia.copy()
    # -[L]x scaled by h: row-major cross matrix of -L
    tilde[0, 1] += h * big_l[2]
    tilde[0, 2] -= h * big_l[1]
    tilde[1, 0] -= h * big_l[2]
    tilde[1, 2] += h * big_l[0]
    tilde[2, 0] += h * big_l[1]
    tilde[2, 1] -= h * big_l[0]
    inv, ok = _invert3(tilde)
    if not ok:
        return (0.0, 0.0, 0.0)
    prod = _mat_mul3(inertia, inv)
    for a in range(3):
        prod[a, a] -= 1.0
    return _mv3(prod, (big_l[0] / h, big_l[1] / h, big_l[2] / h))


@njit(cache=True)
def step(
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
    contact_body,
    contact_point,
    contact_depth,
    motor_target,
    motor_lo,
    motor_hi,
    push,
    motor_state,
    h,
    joint_erp,
    joint_cfm,
    motor_cfm,
    contact_erp,
    contact_cfm,
    slip,
    surface_layer,
):
    """One dWorldStep of one robot's bodies. Returns (positions, quaternions, velocities, spins,
    contact forces (points x 3: normal, t1, t2), tangents (points x 2 x 3), motor/stop torques,
    solver passes). ``motor_state`` (hinges): the bounded rows' active-set guess, updated. The
    drag acts on ``drag_vel`` / ``drag_spin`` (the velocities SimSpark's DragControllers read: the
    bodies' own, except in the step after a beam)."""
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nc = contact_point.shape[0]
    rot, inv_inertia, force, _ = _robot_body_terms(
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
        a1 = _mat_vec(rot[k], anchor_child[j])
        a2 = _mat_vec(rot[p], anchor_parent[j])
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
            x1 = _cross(a1, e)  # row i of -[a1]x is (a1 x e_i)
            x2 = _cross(a2, e)
            for a in range(3):
                j1[r, 3 + a] = x1[a]
                j2[r, 3 + a] = -x2[a]
            c[r] = k_joint * gap[i]
            cfm[r] = joint_cfm
        ax1 = _mat_vec(rot[k], local_axes[j])
        ax2 = _mat_vec(rot[p], local_axes[j])
        t1, t2 = _plane_space(ax1)
        err = _cross(ax1, ax2)
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
        t1, t2 = _plane_space(normal)
        tangents[i, 0] = t1
        tangents[i, 1] = t2
        arm = contact_point[i] - pos[k]
        rn = n_unb + nj + i
        for r, d in ((rn, normal), (5 * nj + 2 * i, t1), (5 * nj + 2 * i + 1, t2)):
            b1[r] = k
            ang = _cross(arm, d)
            for a in range(3):
                j1[r, a] = d[a]
                j1[r, 3 + a] = ang[a]
        c[rn] = _contact_c(contact_erp, contact_depth[i], surface_layer, h, 0.0, np.inf, 0.0)
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
        ang = _mat_vec(inv_inertia[k], j1[r, 3:6])
        for a in range(3):
            m1[r, 3 + a] = ang[a]
        k = b2[r]
        if k >= 0:
            inv_m = 1.0 / masses[k]
            for a in range(3):
                m2[r, a] = j2[r, a] * inv_m
            ang = _mat_vec(inv_inertia[k], j2[r, 3:6])
            for a in range(3):
                m2[r, 3 + a] = ang[a]
    free = _free_velocities(vel, spin, force, masses, inv_inertia, h)
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
    lower, ok = _cholesky(big_a[:n_unb, :n_unb].copy())
    y = np.empty((n_unb, nbd))
    for s in range(nbd):
        y[:, s] = _cho_solve(lower, big_a[:n_unb, n_unb + s].copy())
    y0 = _cho_solve(lower, rhs[:n_unb].copy())
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
    out_pos, out_quat, out_vel, out_spin = _advance(pos, quat, new_vel, h)
    forces = np.empty((nc, 3))
    for i in range(nc):
        forces[i, 0] = lam[n_unb + nj + i]
        forces[i, 1] = lam[5 * nj + 2 * i]
        forces[i, 2] = lam[5 * nj + 2 * i + 1]
    torques = lam[n_unb : n_unb + nj].copy()
    return out_pos, out_quat, out_vel, out_spin, forces, tangents, torques, iterations


@njit(cache=True, inline="always")
def _inverse_definite(a, sign, out, low):
    """``out`` = the inverse of a small symmetric matrix that is positive (sign 1) or negative
    (sign -1) definite: Cholesky factor of sign * a, inverted (``low``: scratch, n x n or more;
    only its lower triangle is used, each entry written before it is read)."""
    n = a.shape[0]
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


@njit(cache=True, inline="always")
def _mv_sub(m, v, out):
    """out -= m v."""
    for i in range(m.shape[0]):
        t = 0.0
        for j in range(m.shape[1]):
            t += m[i, j] * v[j]
        out[i] -= t


@njit(cache=True, inline="always")
def _mtv_sub(m, v, out):
    """out -= m' v."""
    for j in range(m.shape[1]):
        t = 0.0
        for i in range(m.shape[0]):
            t += m[i, j] * v[i]
        out[j] -= t


@njit(cache=True, inline="always")
def _mv(m, v, out):
    """out = m v."""
    for i in range(m.shape[0]):
        t = 0.0
        for j in range(m.shape[1]):
            t += m[i, j] * v[j]
        out[i] = t


@njit(cache=True, inline="always")
def _mtdm_sub(m, dinv, out, tmp):
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


@njit(cache=True, inline="always")
def _mdmt(m, dinv, out, tmp):
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


@njit(cache=True)
def _tree_solve(
    nb, parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact, rb, rj, rf
):
    """Solve H x = r on the factored forest (``step_tree``, ``ode_island.step_island``; roots
    have parent -1), r given per body (rb, nb x 6), hinge node (rj, nj x 5) and friction node
    (rf, nc x 2); overwritten by x."""
    t6 = np.empty(6)
    t5 = np.empty(5)
    t2 = np.empty(2)
    # forward: leaves to roots
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
    # backward: roots to leaves
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
def _body_terms(
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
def _robot_body_terms(
    masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
):
    """``_body_terms`` with one drag coefficient for all bodies (one robot's)."""
    nb = masses.shape[0]
    dl = np.full(nb, drag_linear)
    da = np.full(nb, drag_angular)
    return _body_terms(masses, principal, quat, spin, gravity, dl, da, drag_vel, drag_spin, h, implicit_gyro)


@njit(cache=True)
def _bounded_rows(nbd, motor_target, motor_lo, motor_hi, motor_cfm):
    """The bounded rows' right-hand sides, bounds and CFM, the motor/stop rows' (the first, one
    per hinge: b = the target speed) filled in. Returns (b, lo, hi, cfm)."""
    bb = np.empty(nbd)
    lo = np.empty(nbd)
    hi = np.empty(nbd)
    cfm_b = np.empty(nbd)
    for j in range(motor_target.shape[0]):
        bb[j] = motor_target[j]
        lo[j] = motor_lo[j]
        hi[j] = motor_hi[j]
        cfm_b[j] = motor_cfm
    return bb, lo, hi, cfm_b


@njit(cache=True)
def _hinge_nodes(parents, joint_of, nj, rot, pos, anchor_child, anchor_parent, local_axes, push, force, h, joint_erp):
    """The hinges of a forest (``parents`` -1 at the roots): each one's node of 5 unbounded rows
    on its child k and parent p (Jacobians jc, jp, right-hand sides cj), its motor/stop row's
    direction (the child's axis) and child; the motor's outside torque ``push`` added to
    ``force``. Returns (jc, jp, cj, motor_dir, child_of)."""
    jc = np.zeros((nj, 5, 6))
    jp = np.zeros((nj, 5, 6))
    cj = np.zeros((nj, 5))
    motor_dir = np.zeros((nj, 3))
    child_of = np.zeros(nj, dtype=np.int64)
    k_joint = joint_erp / h
    for k in range(parents.shape[0]):
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        child_of[j] = k
        a1 = _mv3(rot[k], anchor_child[j])
        a2 = _mv3(rot[p], anchor_parent[j])
        for i in range(3):
            jc[j, i, i] = 1.0
            jp[j, i, i] = -1.0
            cj[j, i] = k_joint * (pos[p, i] + a2[i] - pos[k, i] - a1[i])
        # angular parts: row i of -[a1]x on the child (a1 x e_i), of [a2]x on the parent
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
        ax1 = _mv3(rot[k], local_axes[j])
        ax2 = _mv3(rot[p], local_axes[j])
        t1, t2 = _plane_space3(ax1)
        err = _cross3(ax1, ax2)
        for i in range(2):
            d = t1 if i == 0 else t2
            for a in range(3):
                jc[j, 3 + i, 3 + a] = d[a]
                jp[j, 3 + i, 3 + a] = -d[a]
            cj[j, 3 + i] = k_joint * (err[0] * d[0] + err[1] * d[1] + err[2] * d[2])
        for a in range(3):
            motor_dir[j, a] = ax1[a]
            force[k, 3 + a] += push[j] * ax1[a]
            force[p, 3 + a] -= push[j] * ax1[a]
    return jc, jp, cj, motor_dir, child_of


@njit(cache=True)
def _contact_nodes(nb, c_body, c_point, c_normal, pos):
    """Contacts with one body (the ground, a goal, a wall; ``c_normal`` into the body): each
    one's normal row (Jacobian jn, bounded) and friction node of 2 unbounded rows (jf), its
    tangents, and the contacts listed per body (``contact_first`` / ``contact_next``). Returns
    (jn, jf, tangents, contact_first, contact_next)."""
    nc = c_point.shape[0]
    jf = np.zeros((nc, 2, 6))
    jn = np.zeros((nc, 6))
    tangents = np.empty((nc, 2, 3))
    contact_first = np.full(nb, -1, dtype=np.int64)
    contact_next = np.full(nc, -1, dtype=np.int64)
    t1 = t2 = (0.0, 0.0, 0.0)
    for i in range(nc - 1, -1, -1):
        k = c_body[i]
        contact_next[i] = contact_first[k]
        contact_first[k] = i
        normal = c_normal[i]
        if i == nc - 1 or not (
            normal[0] == c_normal[i + 1, 0] and normal[1] == c_normal[i + 1, 1] and normal[2] == c_normal[i + 1, 2]
        ):  # else the last contact's tangents
            t1, t2 = _plane_space3(normal)
        arm = (c_point[i, 0] - pos[k, 0], c_point[i, 1] - pos[k, 1], c_point[i, 2] - pos[k, 2])
        an = _cross3(arm, normal)
        a1 = _cross3(arm, t1)
        a2 = _cross3(arm, t2)
        for a in range(3):
            tangents[i, 0, a] = t1[a]
            tangents[i, 1, a] = t2[a]
            jn[i, a] = normal[a]
            jn[i, 3 + a] = an[a]
            jf[i, 0, a] = t1[a]
            jf[i, 0, 3 + a] = a1[a]
            jf[i, 1, a] = t2[a]
            jf[i, 1, 3 + a] = a2[a]
    return jn, jf, tangents, contact_first, contact_next


@njit(cache=True, inline="always")
def _contact_c(erp, depth, surface_layer, h, bounce, bounce_vel, outgoing):
    """ODE 0.16's right-hand side of a contact's normal row (``bounce_vel`` inf: no bounce)."""
    d = depth - surface_layer
    c = erp * d / h if d > 0.0 else 0.0
    if bounce_vel >= 0.0 and -outgoing > bounce_vel:
        newc = -bounce * outgoing
        if newc > c:
            c = newc
    return c


@njit(cache=True)
def _free_velocities(vel, spin, force, masses, inv_inertia, h):
    """Each body's velocity and spin without the constraints: v + h M^-1 f."""
    nb = masses.shape[0]
    free = np.empty((nb, 6))
    for k in range(nb):
        for a in range(3):
            free[k, a] = vel[k, a] + h * force[k, a] / masses[k]
        ang = _mat_vec(inv_inertia[k], force[k, 3:6])
        for a in range(3):
            free[k, 3 + a] = spin[k, a] + h * ang[a]
    return free


@njit(cache=True)
def _factor(parents, joint_of, contact_first, contact_next, jc, jp, jf, dbody, slip, joint_cfm):
    """Factor H from the leaves to the roots (``parents`` -1 there): ``dbody`` (M/h) is
    overwritten by each body's block; ``slip`` per contact. Returns the inverted blocks
    (dinv_body, dinv_joint, dinv_contact)."""
    nb = dbody.shape[0]
    nj = jc.shape[0]
    dinv_body = np.empty((nb, 6, 6))
    dinv_joint = np.empty((nj, 5, 5))
    dinv_contact = np.zeros((jf.shape[0], 2, 2))
    dj = np.empty((5, 5))
    tmp = np.empty((6, 6))
    for k in range(nb - 1, -1, -1):
        c = contact_first[k]
        while c >= 0:
            dinv_contact[c, 0, 0] = -1.0 / slip[c]
            dinv_contact[c, 1, 1] = -1.0 / slip[c]
            _mtdm_sub(jf[c], dinv_contact[c], dbody[k], tmp)
            c = contact_next[c]
        _inverse_definite(dbody[k], 1.0, dinv_body[k], tmp)
        p = parents[k]
        if p < 0:
            continue
        j = joint_of[k]
        dj[:, :] = 0.0
        for a in range(5):
            dj[a, a] = -joint_cfm
        _mdmt(jc[j], dinv_body[k], dj, tmp)
        _inverse_definite(dj, -1.0, dinv_joint[j], tmp)
        _mtdm_sub(jp[j], dinv_joint[j], dbody[p], tmp)
    return dinv_body, dinv_joint, dinv_contact


@njit(cache=True)
def _unbounded_rhs(parents, joint_of, c_body, jc, jp, jf, cj, free):
    """The unbounded rows' right-hand sides b = c - J free: hinge nodes (bj) and friction nodes
    (bf; c = 0)."""
    bj = cj.copy()
    for k in range(parents.shape[0]):
        if parents[k] >= 0:
            j = joint_of[k]
            _mv_sub(jc[j], free[k], bj[j])
            _mv_sub(jp[j], free[parents[k]], bj[j])
    bf = np.zeros((jf.shape[0], 2))
    for i in range(jf.shape[0]):
        _mv_sub(jf[i], free[c_body[i]], bf[i])
    return bj, bf


@njit(cache=True)
def _schur(parents, joint_of, jc, jp, dinv_body, dinv_joint, path_b, len_b, zb, cfm_b):
    """S = cfm_B + G' H^-1 G of the bounded rows, from one forward pass each: row r's z starts as
    its Jacobian on its bodies (zb[r]) and is carried through the bodies path_b[r, :len_b[r]]
    (leaves first, the union of its bodies' paths to their roots; z is zero off them) and the
    hinges between them, w = D^-1 z there. Then S[r, s] = cfm + sum over row r's path of
    z_s' w_r. ``zb`` is overwritten."""
    nbd = zb.shape[0]
    nb = zb.shape[1]
    nj = jc.shape[0]
    path_j = np.empty((nbd, nb), dtype=np.int64)
    len_j = np.zeros(nbd, dtype=np.int64)
    zj = np.zeros((nbd, nj, 5))
    # w is read only where the pass has written it: on each row's path
    wb = np.empty((nbd, nb, 6))
    wj = np.empty((nbd, nj, 5))
    for r in range(nbd):
        for m in range(len_b[r]):
            k = path_b[r, m]
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
        # four entries S[r, s..s+3] at a time: four independent sums, each in the order of one
        # at a time (row r's path bodies, then its hinges), which the CPU overlaps
        for s in range(r, nbd, 4):
            s1, s2, s3 = min(s + 1, nbd - 1), min(s + 2, nbd - 1), min(s + 3, nbd - 1)
            v0 = v1 = v2 = v3 = 0.0
            for m in range(len_b[r]):
                k = path_b[r, m]
                for a in range(6):
                    w = wb[r, k, a]
                    v0 += zb[s, k, a] * w
                    v1 += zb[s1, k, a] * w
                    v2 += zb[s2, k, a] * w
                    v3 += zb[s3, k, a] * w
            for m in range(len_j[r]):
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
    return schur


@njit(cache=True)
def _advance(pos, quat, new_vel, h):
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
        dq = _qmul4((out_spin[k, 0], out_spin[k, 1], out_spin[k, 2], 0.0), quat[k])
        for a in range(4):
            qn[a] = quat[k, a] + half_h * dq[a]
        norm = np.sqrt(qn[0] ** 2 + qn[1] ** 2 + qn[2] ** 2 + qn[3] ** 2)
        for a in range(4):
            out_quat[k, a] = qn[a] / norm
    return out_pos, out_quat, out_vel, out_spin


@njit(cache=True)
def _contact_forces(lam_b, first, bf):
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
def step_tree(
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
    contact_body,
    contact_point,
    contact_depth,
    motor_target,
    motor_lo,
    motor_hi,
    push,
    motor_state,
    h,
    joint_erp,
    joint_cfm,
    motor_cfm,
    contact_erp,
    contact_cfm,
    slip,
    surface_layer,
):
    """``step`` solved in O(bodies) (Baraff 1996, "Linear-time dynamics using Lagrange
    multipliers"): the unbounded rows (5 per hinge, 2 friction rows per contact) and the bodies form
    a tree, so H = [[M/h, J_U'], [J_U, -cfm_U]] is factored block by block from the leaves to the
    torso; the bounded rows (motor or stop per hinge, normal per contact) get their Schur
    complement S = cfm_B + G' H^-1 G (G their Jacobians on the bodies) from one forward pass each
    along their path to the torso, and ``box_qp`` solves their LCP on S. Same arguments and
    results as ``step`` (equal to rounding). Requires every parent index below its child's."""
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nc = contact_point.shape[0]
    roots = parents.copy()
    roots[0] = -1  # the torso: the tree's root
    rot, inv_inertia, force, dbody = _robot_body_terms(
        masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
    )
    # hinge nodes (5 rows on child k and parent p) and their motor/stop rows (bounded)
    jc, jp, cj, motor_dir, child_of = _hinge_nodes(
        roots, joint_of, nj, rot, pos, anchor_child, anchor_parent, local_axes, push, force, h, joint_erp
    )
    # contacts: friction nodes (2 rows) and normal rows (bounded), listed per body
    normals = np.zeros((nc, 3))
    normals[:, 2] = 1.0
    jn, jf, tangents, contact_first, contact_next = _contact_nodes(nb, contact_body, contact_point, normals, pos)
    cn = np.zeros(nc)
    for i in range(nc):
        cn[i] = _contact_c(contact_erp, contact_depth[i], surface_layer, h, 0.0, np.inf, 0.0)
    free = _free_velocities(vel, spin, force, masses, inv_inertia, h)
    # factor H from the leaves to the torso
    dinv_body, dinv_joint, dinv_contact = _factor(
        roots, joint_of, contact_first, contact_next, jc, jp, jf, dbody, np.full(nc, slip), joint_cfm
    )
    # right-hand sides b = c - J free, unbounded and bounded
    bj, bf = _unbounded_rhs(roots, joint_of, contact_body, jc, jp, jf, cj, free)
    nbd = nj + nc
    bb, lo, hi, cfm_b = _bounded_rows(nbd, motor_target, motor_lo, motor_hi, motor_cfm)
    for j in range(nj):
        k = child_of[j]
        p = parents[k]
        rel = 0.0
        for a in range(3):
            rel += motor_dir[j, a] * (free[k, 3 + a] - free[p, 3 + a])
        bb[j] -= rel
    for i in range(nc):
        v = 0.0
        for a in range(6):
            v += jn[i, a] * free[contact_body[i], a]
        bb[nj + i] = cn[i] - v
        lo[nj + i] = 0.0
        hi[nj + i] = np.inf
        cfm_b[nj + i] = contact_cfm
    # y0: the velocity change with the bounded rows' forces 0
    yb = np.zeros((nb, 6))
    yj = bj.copy()
    yf = bf.copy()
    _tree_solve(
        nb, roots, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact, yb, yj, yf
    )
    # the bounded rows' Jacobians on their bodies and their paths to the torso
    path_b = np.empty((nbd, nb), dtype=np.int64)
    len_b = np.zeros(nbd, dtype=np.int64)
    zb = np.zeros((nbd, nb, 6))
    for r in range(nbd):
        if r < nj:
            k = child_of[r]
            p = parents[k]
            for a in range(3):
                zb[r, k, 3 + a] = motor_dir[r, a]
                zb[r, p, 3 + a] = -motor_dir[r, a]
        else:
            k = contact_body[r - nj]
            for a in range(6):
                zb[r, k, a] = jn[r - nj, a]
        while k >= 0:
            path_b[r, len_b[r]] = k
            len_b[r] += 1
            k = roots[k]
    schur = _schur(roots, joint_of, jc, jp, dinv_body, dinv_joint, path_b, len_b, zb, cfm_b)
    # the bounded rows' right-hand side: b_B - J_B y0
    for j in range(nj):
        k = child_of[j]
        p = parents[k]
        for a in range(3):
            bb[j] -= motor_dir[j, a] * (yb[k, 3 + a] - yb[p, 3 + a])
    for i in range(nc):
        for a in range(6):
            bb[nj + i] -= jn[i, a] * yb[contact_body[i], a]
    state = np.zeros(nbd, dtype=np.int64)
    for j in range(nj):
        state[j] = motor_state[j]
    lam_b, iterations = box_qp(schur, bb, lo, hi, state)
    for j in range(nj):
        motor_state[j] = state[j]
    # the final solve: body right-hand side G lambda_B, unbounded rows' b
    rb = np.zeros((nb, 6))
    for j in range(nj):
        k = child_of[j]
        p = parents[k]
        for a in range(3):
            rb[k, 3 + a] += motor_dir[j, a] * lam_b[j]
            rb[p, 3 + a] -= motor_dir[j, a] * lam_b[j]
    for i in range(nc):
        for a in range(6):
            rb[contact_body[i], a] += jn[i, a] * lam_b[nj + i]
    _tree_solve(
        nb, roots, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact, rb, bj, bf
    )
    out_pos, out_quat, out_vel, out_spin = _advance(pos, quat, free + rb, h)
    forces = _contact_forces(lam_b, nj, bf)
    torques = lam_b[:nj].copy()
    return out_pos, out_quat, out_vel, out_spin, forces, tangents, torques, iterations
