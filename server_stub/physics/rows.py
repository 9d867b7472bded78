"""Constraint rows of the step (ODE 0.16's joints/hinge.cpp, joint.cpp, contact.cpp, as SimSpark
sets them up):

- a hinge: 3 rows keeping its anchor copies together and 2 keeping the child's axis on the
  parent's, with the world ERP and CFM (``hinge_nodes``); then one motor or limit row about the
  axis (``bounded_rows``, bounds from ``motor_rows``: a motor inside the range, ODE's one-sided
  limit row and the motor's push at a stop);
- a contact: a normal row (>= 0; ``contact_c``: ERP on the depth beyond the surface layer, or the
  bounce) and two friction rows, unbounded with CFM = slip (``contact_nodes``);
- the surface of a contact joint, two colliders' surfaces mixed as SimSpark mixes them
  (``surface``, ``Surfaces``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.linalg import cross3, mv3, plane_space3

#: columns of a surface row: soft ERP, soft CFM, slip, bounce, minimum bounce velocity (inf: none)
ERP, CFM, SLIP, BOUNCE, BOUNCE_VEL = range(5)


#: ODE joint rows' CFM (docs/robot_and_server.md section 3), used for the motor rows.
MOTOR_CFM = 1e-8


#: SimSpark's hinge fudge factor (hingejoint.rsg): a motor driving away from the stop it stands
#: at pushes with this fraction of its force (ODE's dxJointLimitMotor); the maximal step only.
FUDGE_FACTOR = 1e-5


@njit(cache=True)
def motor_rows(angles, upper, force, sticky, torque_limit, fudge):
    """Bounds of each hinge's row and the torque pushing hinges besides it (``upper``: each
    hinge's upper limit, rad, ``nao_model.joint_limits``). Inside its range a
    hinge's row is its motor's, |torque| <= 10 N m. Outside, ``server_stub.physics.motors`` has
    made the row its stop's (target: back by ERP 0.8 or the bounced speed, whichever is larger)
    and the row is ODE's limit row: one-sided (it only pushes the hinge back in), and the motor,
    which has no row of its own then, pushes with its full torque as an outside torque when its
    (sticky) target speed points into the stop or is 0, and with ``fudge`` of it when it points
    out (SimSpark's fudge factor 1e-5; docs/robot_and_server.md section 3)."""
    n = force.shape[0]
    lo = np.empty(n)
    hi = np.empty(n)
    push = np.zeros(n)
    for j in range(n):
        lo[j] = -force[j]
        hi[j] = force[j]
        if not force[j] > torque_limit:
            continue
        if angles[j] >= upper[j]:
            lo[j], hi[j] = -np.inf, 0.0
            push[j] = torque_limit if sticky[j] >= 0.0 else -fudge * torque_limit
        else:
            lo[j], hi[j] = 0.0, np.inf
            push[j] = -torque_limit if sticky[j] <= 0.0 else fudge * torque_limit
    return lo, hi, push


#: No bounce: a minimum bounce velocity no contact reaches.
_NO_BOUNCE = np.inf


def surface(a: tuple, b: tuple, config) -> np.ndarray:
    """Two colliders' surfaces combined as SimSpark does (``PhysicsConfig.ode_surface_robot``):
    (ERP, CFM, slip, bounce, minimum bounce velocity) of their contact joint."""

    def mix(x, y):
        if x is None:
            return y
        if y is None:
            return x
        return (x + y) / 2.0

    erp = mix(a[0], b[0])
    cfm = mix(a[1], b[1])
    slip = mix(a[2], b[2])
    bounce = mix(a[3], b[3])
    bounce_vel = mix(a[4], b[4])
    return np.array(
        [
            config.ode_joint_erp if erp is None else erp,
            config.global_cfm if cfm is None else cfm,
            config.global_cfm if slip is None else slip,
            0.0 if bounce is None else bounce,
            _NO_BOUNCE if bounce_vel is None else bounce_vel,
        ]
    )


class Surfaces:
    """Every pair's combined surface, per config (robot, ball, static, ground)."""

    def __init__(self, config) -> None:
        r, b, s, g = (
            config.ode_surface_robot,
            config.ode_surface_ball,
            config.ode_surface_static,
            config.ode_surface_ground,
        )
        self.robot_robot = surface(r, r, config)
        self.robot_ball = surface(r, b, config)
        self.robot_static = surface(r, s, config)
        self.ball_static = surface(b, s, config)
        self.ball_ground = surface(b, g, config)
        # the per-robot path's own ground values (the same mix, kept bit for bit)
        self.robot_ground = np.array([config.contact_erp, config.contact_cfm, config.slip, 0.0, _NO_BOUNCE])


@njit(cache=True)
def bounded_rows(nbd, motor_target, motor_lo, motor_hi, motor_cfm):
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
def hinge_nodes(parents, joint_of, nj, rot, pos, anchor_child, anchor_parent, local_axes, push, force, h, joint_erp):
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
        a1 = mv3(rot[k], anchor_child[j])
        a2 = mv3(rot[p], anchor_parent[j])
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
        ax1 = mv3(rot[k], local_axes[j])
        ax2 = mv3(rot[p], local_axes[j])
        t1, t2 = plane_space3(ax1)
        err = cross3(ax1, ax2)
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
def contact_nodes(nb, c_body, c_point, c_normal, pos):
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
            t1, t2 = plane_space3(normal)
        arm = (c_point[i, 0] - pos[k, 0], c_point[i, 1] - pos[k, 1], c_point[i, 2] - pos[k, 2])
        an = cross3(arm, normal)
        a1 = cross3(arm, t1)
        a2 = cross3(arm, t2)
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


@njit(cache=True)
def contact_c(erp, depth, surface_layer, h, bounce, bounce_vel, outgoing):
    """ODE 0.16's right-hand side of a contact's normal row (``bounce_vel`` inf: no bounce)."""
    d = depth - surface_layer
    c = erp * d / h if d > 0.0 else 0.0
    if bounce_vel >= 0.0 and -outgoing > bounce_vel:
        newc = -bounce * outgoing
        if newc > c:
            c = newc
    return c


@njit(cache=True)
def rows_sub(gb, gj, vel, out):
    """out -= J v for the bounded rows (each on up to two bodies: gb, gj) and body velocities v."""
    for r in range(out.shape[0]):
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    out[r] -= gj[r, x, a] * vel[k, a]
