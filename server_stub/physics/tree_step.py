"""One robot's step against the ground: every body integrated on its own, as ODE 0.16's
``dWorldStep`` does, the hinges held by constraint rows. The stages are in their own modules
(``rows``, ``solver``, ``integrate``); this is their order for one robot.

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
  targets and bounds are ``server_stub.physics.motors``' and ``rows.motor_rows``';
- (contacts with other robots, the ball and the goals: ``stepper`` / ``island_step``, the same
  rows generalised to islands of several robots)
- ground contacts as ODE's plane colliders make them (``collision.ground_contacts``, from the
  bodies' own poses): a normal row (>= 0, ERP 0.4 on depth less the surface layer 0.001,
  CFM 1e-4) and two friction rows (unbounded, CFM = slip 0.005);
- the LCP of dWorldStep, scaled by h: A = h J M^-1 J' + diag(cfm), b = c - J (v + h M^-1 f),
  solved exactly: the unbounded rows (hinges, friction) eliminated along the tree, the
  bounded ones (motors, stops, normals) by ``solver.box_qp`` on the Schur complement;
- v += h M^-1 (f + J' lambda), then x += h v and ODE's infinitesimal rotation
  q += h/2 (0, w) q, normalised (SimSpark does not turn on finite rotation);
- the hinge angle as dJointGetHingeAngle measures it from the two bodies' quaternions.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.integrate import advance, free_velocities, robot_body_terms
from server_stub.physics.rows import bounded_rows, contact_c, contact_nodes, hinge_nodes
from server_stub.physics.solver import (
    FIRST_BODY,
    box_qp,
    contact_forces,
    factor,
    schur_complement,
    tree_solve,
    unbounded_rhs,
)


@njit(cache=True, inline="always")
def step_tree(model, state, forces, contacts, motors, params):
    """``step`` solved in O(bodies) (Baraff 1996, "Linear-time dynamics using Lagrange
    multipliers"): the unbounded rows (5 per hinge, 2 friction rows per contact) and the bodies form
    a tree, so H = [[M/h, J_U'], [J_U, -cfm_U]] is factored block by block from the leaves to the
    torso; the bounded rows (motor or stop per hinge, normal per contact) get their Schur
    complement S = cfm_B + G' H^-1 G (G their Jacobians on the bodies) from one forward pass each
    along their path to the torso, and ``box_qp`` solves their LCP on S. The same results as one
    dense LCP (``tests/dense_step.py``, to rounding). Requires every parent index below its child's.

    The arguments are the bundles ``Model``, ``State``, ``Forces``, ``GroundContacts``, ``Motors``
    and ``Params``, each as a plain tuple (``bundles``). Inlined where it is called
    (``lanes.step_lanes``, for every lone robot): a cold start compiles it once, not once alone
    and again inside its caller.

    The solve skips the hinge Jacobians' structural zeros and the Schur complement's terms off the
    rows' common paths (``solver.factor`` and the others), which gives the same bits as the
    dense solve whenever every value a zero is skipped against is finite; when one is not (a
    robot whose state has blown up), the step is redone densely, from the motors' states given."""
    masses, principal, parents, joint_of, local_axes, anchor_child, anchor_parent = model
    pos, quat, vel, spin = state
    gravity, drag_linear, drag_angular, drag_vel, drag_spin = forces
    contact_body, contact_point, contact_depth = contacts
    motor_target, motor_lo, motor_hi, push, motor_state = motors
    h, joint_erp, joint_cfm, motor_cfm, surface_layer, implicit_gyro, contact_erp, contact_cfm, slip = params
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nc = contact_point.shape[0]
    saved = motor_state.copy()
    # the step skipping zeros, then, only if a skipped zero met a value not finite, densely from
    # the motors' states given: one body for both (``solver.factor`` and the others take
    # the choice), which compiles in far less time than two
    for attempt in range(2):
        hinged = attempt == 0
        roots = parents.copy()
        roots[0] = -1  # the torso: the tree's root
        rot, inv_inertia, force, dbody = robot_body_terms(
            masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
        )
        # hinge nodes (5 rows on child k and parent p) and their motor/stop rows (bounded)
        jc, jp, cj, motor_dir, child_of = hinge_nodes(
            roots, joint_of, nj, rot, pos, anchor_child, anchor_parent, local_axes, push, force, h, joint_erp
        )
        # contacts: friction nodes (2 rows) and normal rows (bounded), listed per body
        normals = np.zeros((nc, 3))
        normals[:, 2] = 1.0
        jn, jf, tangents, contact_first, contact_next = contact_nodes(nb, contact_body, contact_point, normals, pos)
        cn = np.zeros(nc)
        for i in range(nc):
            cn[i] = contact_c(contact_erp, contact_depth[i], surface_layer, h, 0.0, np.inf, 0.0)
        free = free_velocities(vel, spin, force, masses, inv_inertia, h)
        # factor H from the leaves to the torso
        dinv_body, dinv_joint, dinv_contact, ok = factor(
            roots, joint_of, contact_first, contact_next, jc, jp, jf, dbody, np.full(nc, slip), joint_cfm, hinged
        )
        # right-hand sides b = c - J free, unbounded and bounded
        bj, bf, fine = unbounded_rhs(roots, joint_of, contact_body, jc, jp, jf, cj, free, hinged)
        ok &= fine
        nbd = nj + nc
        bb, lo, hi, cfm_b = bounded_rows(nbd, motor_target, motor_lo, motor_hi, motor_cfm)
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
        tree = (roots, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact)
        ok &= tree_solve(FIRST_BODY, nb, tree, yb, yj, yf, hinged)
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
        schur, fine = schur_complement(roots, joint_of, jc, jp, dinv_body, dinv_joint, path_b, len_b, zb, cfm_b, hinged)
        ok &= fine
        # the bounded rows' right-hand side: b_B - J_B y0
        for j in range(nj):
            k = child_of[j]
            p = parents[k]
            for a in range(3):
                bb[j] -= motor_dir[j, a] * (yb[k, 3 + a] - yb[p, 3 + a])
        for i in range(nc):
            for a in range(6):
                bb[nj + i] -= jn[i, a] * yb[contact_body[i], a]
        row_state = np.zeros(nbd, dtype=np.int64)
        for j in range(nj):
            row_state[j] = motor_state[j]
        lam_b, iterations = box_qp(schur, bb, lo, hi, row_state)
        for j in range(nj):
            motor_state[j] = row_state[j]
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
        ok &= tree_solve(FIRST_BODY, nb, tree, rb, bj, bf, hinged)
        out_pos, out_quat, out_vel, out_spin = advance(pos, quat, free + rb, h)
        contact_f = contact_forces(lam_b, nj, bf)
        torques = lam_b[:nj].copy()

        if ok or not hinged:
            break
        for j in range(nj):
            motor_state[j] = saved[j]
    return out_pos, out_quat, out_vel, out_spin, contact_f, tangents, torques, iterations
