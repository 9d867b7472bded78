"""One ODE island: several robots and the ball that touch each other, solved together in one LCP,
as ODE's dWorldStep solves every island of bodies connected by joints or contacts (``stepper``
makes the islands).

The kernel is ``tree_step.step_tree`` generalised (same facts, same Baraff 1996 tree solve, the
same stages: ``rows``, ``solver``, ``integrate``):

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
  bounce velocity, c = max(c, -bounce * u);
- the bounded rows are solved exactly (as ODE does) up to ``PhysicsConfig.island_exact_rows``,
  past it (a pile of robots) by ``gauss_seidel`` in bounded time (docs/physics.md, "Large
  islands").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.bundles import (
    Contacts,
    Forces,
    IslandSolve,
    Model,
    Motors,
    PairContacts,
    Params,
    State,
)
from server_stub.physics.gauss_seidel import block_gauss_seidel
from server_stub.physics.integrate import advance, body_terms, free_velocities
from server_stub.physics.linalg import cross, plane_space
from server_stub.physics.rows import (
    BOUNCE,
    BOUNCE_VEL,
    CFM,
    ERP,
    SLIP,
    bounded_rows,
    contact_c,
    contact_nodes,
    hinge_nodes,
    rows_sub,
)
from server_stub.physics.solver import (
    BLOCK_PIVOT_ROWS,
    FIRST_BODY,
    block_pivot,
    box_qp,
    contact_forces,
    dense,
    factor,
    schur_of_rows,
    tree_solve,
    unbounded_rhs,
)


def step_island(model, state, forces, motors, contacts, pairs, params, solve):
    """One dWorldStep of an island (``server_stub.physics.bundles``): the bodies of a forest, with
    ``parents`` -1 at each root and ``joint_of`` the hinge of each non-root; the drag per body.
    Contacts with one body in ``contacts`` (each with its own surface; ``params``' robot-ground
    surface is not used), between two in ``pairs``; ``solve`` says how the bounded rows are
    solved (exactly, or past ``solve.exact_rows`` by ``gauss_seidel``). Returns (positions,
    quaternions, velocities, spins, one-body contact forces (normal, t1, t2) and tangents, two-body
    contact forces (on body 1) and tangents, motor/stop torques, solver passes)."""
    prepared = _prepare(
        tuple(model), tuple(state), tuple(forces), tuple(motors), tuple(contacts), tuple(pairs), tuple(params)
    )
    free, gb, gj, bb, lo, hi, cfm_b, yb, bj, bf, tree, tangents, p_tangents = prepared
    parents, joint_of, _, _, jc, jp, _, dinv_body, dinv_joint, _ = tree
    nj = model.local_axes.shape[0]
    nbd = bb.shape[0]
    # each bounded row's state (-1 at lo, +1 at hi, 0 free): the motors' from the last step
    row_state = np.zeros(nbd, dtype=np.int64)
    row_state[:nj] = motors.state
    # the solvers are chosen here, not in a compiled kernel, so that a walk (a lone ball's island
    # of one row) never compiles the solvers of large islands (``bench/bench_cold_start.py``)
    if nbd <= solve.exact_rows:
        schur = schur_of_rows(parents, joint_of, jc, jp, dinv_body, dinv_joint, gb, gj, cfm_b)
        rows_sub(gb, gj, yb, bb)
        converged = False
        if nbd > BLOCK_PIVOT_ROWS:
            lam_b, converged, iterations = block_pivot(schur, bb, lo, hi, row_state)
        if not converged:
            lam_b, iterations = box_qp(schur, bb, lo, hi, row_state)
    else:
        rows_sub(gb, gj, yb, bb)
        lam_b, iterations = block_gauss_seidel(
            tree, gb, gj, bb, lo, hi, cfm_b, row_state, nj, contacts.point.shape[0], solve.sweeps, solve.tolerance
        )
    motors.state[:] = row_state[:nj]
    return _finish(nj, contacts.point.shape[0], params.h, tuple(state), prepared, lam_b, iterations)


@njit(cache=True)
def _prepare(model, state, forces, motors, contacts, pairs, params):
    """The island's rows: its tree factored with the unbounded rows (hinges, one-body friction;
    ``tree``: parents, joint_of, contact_first, contact_next, jc, jp, jf and the inverted blocks,
    what ``solver.tree_solve`` takes), the bounded rows (motors, one-body normals, two-body
    contacts: bodies ``gb``, Jacobians ``gj``, right side ``bb`` less the free motion, bounds,
    CFM), and the unbounded solve ``yb`` with no bounded row pushing. The arguments are
    ``step_island``'s bundles (but ``solve``), each as a plain tuple (``bundles``)."""
    masses, principal, parents, joint_of, local_axes, anchor_child, anchor_parent = model
    pos, quat, vel, spin = state
    gravity, drag_linear, drag_angular, drag_vel, drag_spin = forces
    motor_target, motor_lo, motor_hi, push, _ = motors  # the motors' states: ``step_island``'s
    c_body, c_point, c_normal, c_depth, c_surface = contacts
    p_body1, p_body2, p_point, p_normal, p_depth, p_surface = pairs
    h, joint_erp, joint_cfm, motor_cfm, surface_layer, implicit_gyro, _, _, _ = params  # robot-ground: unused
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    nc = c_point.shape[0]
    npc = p_point.shape[0]
    rot, inv_inertia, force, dbody = body_terms(
        masses, principal, quat, spin, gravity, drag_linear, drag_angular, drag_vel, drag_spin, h, implicit_gyro
    )
    jc, jp, cj, motor_dir, child_of = hinge_nodes(
        parents, joint_of, nj, rot, pos, anchor_child, anchor_parent, local_axes, push, force, h, joint_erp
    )
    # one-body contacts: friction nodes of the tree, normal rows bounded
    jn, jf, tangents, contact_first, contact_next = contact_nodes(nb, c_body, c_point, c_normal, pos)
    cn = np.zeros(nc)
    for i in range(nc):
        k = c_body[i]
        outgoing = 0.0
        for a in range(3):
            outgoing += jn[i, a] * vel[k, a] + jn[i, 3 + a] * spin[k, a]
        sf = c_surface[i]
        cn[i] = contact_c(sf[ERP], c_depth[i], surface_layer, h, sf[BOUNCE], sf[BOUNCE_VEL], outgoing)
    # bounded rows: motors, one-body normals, then 3 rows per two-body contact; each acts on up
    # to two bodies (gb: body, -1 none; gj: its 6 Jacobian entries)
    nbd = nj + nc + 3 * npc
    gb = np.full((nbd, 2), -1, dtype=np.int64)
    gj = np.zeros((nbd, 2, 6))
    bb, lo, hi, cfm_b = bounded_rows(nbd, motor_target, motor_lo, motor_hi, motor_cfm)
    for j in range(nj):
        k = child_of[j]
        gb[j, 0] = k
        gb[j, 1] = parents[k]
        for a in range(3):
            gj[j, 0, 3 + a] = motor_dir[j, a]
            gj[j, 1, 3 + a] = -motor_dir[j, a]
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
        t1, t2 = plane_space(normal)
        for a in range(3):  # not p_tangents[i, 0] = t1: a row copy compiles numba's shape error
            p_tangents[i, 0, a] = t1[a]
            p_tangents[i, 1, a] = t2[a]
        arm1 = p_point[i] - pos[k1]
        arm2 = p_point[i] - pos[k2]
        sf = p_surface[i]
        for x in range(3):
            r = nj + nc + 3 * i + x
            d = normal if x == 0 else (t1 if x == 1 else t2)
            g1 = cross(arm1, d)
            g2 = cross(arm2, d)
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
                bb[r] = contact_c(sf[ERP], p_depth[i], surface_layer, h, sf[BOUNCE], sf[BOUNCE_VEL], outgoing)
                lo[r] = 0.0
                cfm_b[r] = sf[CFM]
            else:
                bb[r] = 0.0
                lo[r] = -np.inf
                cfm_b[r] = sf[SLIP]
            hi[r] = np.inf
    free = free_velocities(vel, spin, force, masses, inv_inertia, h)
    # factor H from the leaves to the roots
    dinv_body, dinv_joint, dinv_contact, _ = factor(
        parents, joint_of, contact_first, contact_next, jc, jp, jf, dbody, c_surface[:, SLIP].copy(), joint_cfm, dense()
    )
    bj, bf, _ = unbounded_rhs(parents, joint_of, c_body, jc, jp, jf, cj, free, dense())
    rows_sub(gb, gj, free, bb)
    yb = np.zeros((nb, 6))
    yj = bj.copy()
    yf = bf.copy()
    tree = (parents, joint_of, contact_first, contact_next, jc, jp, jf, dinv_body, dinv_joint, dinv_contact)
    tree_solve(FIRST_BODY, nb, tree, yb, yj, yf, dense())
    return free, gb, gj, bb, lo, hi, cfm_b, yb, bj, bf, tree, tangents, p_tangents


@njit(cache=True)
def _finish(nj, nc, h, state, prepared, lam_b, iterations):
    """The solved bounded rows' push carried through the tree (``prepared``: ``_prepare``'s return),
    the bodies of ``state`` advanced, and the forces reported (``step_island``'s return)."""
    pos, quat, _, _ = state
    free, gb, gj, _, _, _, _, _, bj, bf, tree, tangents, p_tangents = prepared
    nb = tree[0].shape[0]
    nbd = lam_b.shape[0]
    npc = (nbd - nj - nc) // 3
    rb = np.zeros((nb, 6))
    for r in range(nbd):
        for x in range(2):
            k = gb[r, x]
            if k >= 0:
                for a in range(6):
                    rb[k, a] += gj[r, x, a] * lam_b[r]
    tree_solve(FIRST_BODY, nb, tree, rb, bj, bf, dense())
    out_pos, out_quat, out_vel, out_spin = advance(pos, quat, free + rb, h)
    forces = contact_forces(lam_b, nj, bf)
    p_forces = np.empty((npc, 3))
    for i in range(npc):
        for x in range(3):
            p_forces[i, x] = lam_b[nj + nc + 3 * i + x]
    torques = lam_b[:nj].copy()
    return out_pos, out_quat, out_vel, out_spin, forces, tangents, p_forces, p_tangents, torques, iterations


def _two_balls(solve: IslandSolve) -> None:
    """One step of a ball on the ground touching a second ball, solved as ``solve`` says."""
    one = np.ones(2)
    none = np.zeros((0, 3))
    step_island(
        Model(np.full(2, 0.026), np.full((2, 3), 1.8e-5), np.array([-1, -1]), np.array([0, 0]), none, none, none),
        State(
            np.array([[0.0, 0.0, 0.042], [0.08, 0.0, 0.042]]),
            np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)),
            np.zeros((2, 3)),
            np.zeros((2, 3)),
        ),
        Forces(np.array([0.0, 0.0, -9.81]), 0.01 * one, 5e-5 * one, np.zeros((2, 3)), np.zeros((2, 3))),
        Motors(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.int64)),
        Contacts(
            np.array([0]),
            np.array([[0.0, 0.0, 0.0]]),
            np.array([[0.0, 0.0, 1.0]]),
            np.array([0.001]),
            np.array([[0.35, 0.05, 0.3, 0.8, 0.8]]),
        ),
        PairContacts(
            np.array([1]),
            np.array([0]),
            np.array([[0.04, 0.0, 0.042]]),
            np.array([[1.0, 0.0, 0.0]]),
            np.array([0.004]),
            np.array([[0.5, 0.05, 0.6, 0.8, 1.0]]),
        ),
        Params(0.02, 0.2, 1e-5, 1e-8, 0.001, True, 0.4, 1e-4, 0.005),
        solve,
    )


def warm_up() -> None:
    """Compile (or load from numba's disk cache) what a small island takes (the exact solve; a
    lone ball's every step on a walk)."""
    _two_balls(IslandSolve(10**6, 1, 0.0))


def warm_up_large() -> None:
    """Compile (or load) the solvers only large islands take: block pivoting and Gauss-Seidel."""
    _two_balls(IslandSolve(0, 10, 1e-6))
    block_pivot(np.eye(2), np.ones(2), np.zeros(2), np.full(2, np.inf), np.zeros(2, dtype=np.int64))
