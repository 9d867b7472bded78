"""A robot in maximal coordinates, as ODE keeps it: every body's centre, quaternion, velocity and
spin. From pybullet's exact joints to bodies (``body_velocities``, ``local_anchors``), from bodies
back to what the real server measures (``measure``, ``measured_state``: the hinge angle as
dJointGetHingeAngle computes it), the joints' drift (``anchor_gaps``), and a beam's rigid move of
every body with the torso (``move_rigidly``)."""

from __future__ import annotations

import numpy as np
from numba import njit

from server_stub.physics.linalg import conj, cross3, mat_vec, mv3, qmul, qmul4
from server_stub.physics.rotations import rotation_into, rotation_matrix


@njit(cache=True)
def hinge_angle(q_child, q_parent, local_axis):
    """dJointGetHingeAngle for bodies whose frames agree at angle 0: from the child's orientation
    relative to the parent's, the rotation's size signed by its part along the axis (so a turn off
    the axis shows in the angle, as on the real server)."""
    rel = qmul4((-q_child[0], -q_child[1], -q_child[2], q_child[3]), q_parent)  # the parent seen from the child
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
        axis = mv3(rot, local_axes[j])
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
    # element by element: a slice copied from an array compiles numba's shape error (~4 s cold)
    for a in range(3):
        out[a] = pos[0, a]
        out[7 + a] = vel[0, a]
        out[10 + a] = spin[0, a]
    for a in range(4):
        out[3 + a] = quat[0, a]
    for j in range(nj):
        out[13 + j] = angles[j]
        out[13 + nj + j] = rates[j]
    return out


@njit(cache=True)
def body_velocities(parents, joint_of, local_axes, coms, quats, anchors, v0, w0, qd):
    """Each body's centre velocity and spin from the torso's and the hinge rates (exact joints)."""
    nb = coms.shape[0]
    vel = np.zeros((nb, 3))
    spin = np.zeros((nb, 3))
    # component by component, no array expressions: the same sums, and numba compiles no
    # broadcasting (with its error messages' text) for them (``bench/bench_cold_start.py``)
    for a in range(3):
        vel[0, a] = v0[a]
        spin[0, a] = w0[a]
    arm_p = np.empty(3)
    arm_k = np.empty(3)
    for k in range(1, nb):
        p = parents[k]
        j = joint_of[k]
        axis = mv3(rotation_matrix(quats[k]), local_axes[j])
        for a in range(3):
            spin[k, a] = spin[p, a] + qd[j] * axis[a]
            arm_p[a] = anchors[j, a] - coms[p, a]
            arm_k[a] = coms[k, a] - anchors[j, a]
        around_p = cross3(spin[p], arm_p)
        around_k = cross3(spin[k], arm_k)
        for a in range(3):
            vel[k, a] = vel[p, a] + around_p[a] + around_k[a]
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
        a1 = coms[k] + mat_vec(rotation_matrix(quats[k]), anchor_child[j])
        a2 = coms[p] + mat_vec(rotation_matrix(quats[p]), anchor_parent[j])
        d = a1 - a2
        gaps[j] = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    return gaps


@njit(cache=True)
def move_rigidly(pos, quat, old_position, old_orientation, new_position, new_orientation):
    """Move every body (in place) by the rigid motion taking the torso from its old pose to its
    new one, as SimSpark's beam moves an agent's bodies."""
    turn = qmul(new_orientation, conj(old_orientation))
    r = rotation_matrix(turn)
    for k in range(pos.shape[0]):
        d = pos[k] - old_position
        moved = mat_vec(r, d)
        for a in range(3):
            pos[k, a] = new_position[a] + moved[a]
        q = qmul(turn, quat[k])
        norm = np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
        for a in range(4):  # written out: an array assignment would compile numba's shape-error text
            quat[k, a] = q[a] / norm
