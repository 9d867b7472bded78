"""The step kernels' arguments, in named bundles: what the bodies are (``Model``), where they are and
how they move (``State``), the forces before the step (``Forces``), the motor rows (``Motors``),
the contacts (``GroundContacts`` for one robot on the ground; ``Contacts`` and ``PairContacts`` in
an island) and the world's numbers (``Params``). The Python code passes them around whole; a
kernel takes each as a plain tuple of its fields (``tuple(state)``) and unpacks it by name. numba
types a named tuple argument in Python at every call (measured: two bundles of 16 fields, 22 us a
call against 7 us for the fields one by one), a plain tuple of arrays and numbers by its C fast
path (a robot's six bundles: 0.3 us a call more than their 33 fields, 1.2 us with the reference
counts of unpacking them in the kernel); a jitclass is as fast to pass but takes 100 us to make (a
new state every step), a record scalar 11 us to pass.

Every per-body array has the bodies on its first axis (per-hinge and per-contact arrays their
hinges and contacts), so that a batch of robots can later be stepped at once by a leading axis.

Bodies: 0 is the torso (in an island, each tree's root), k = j + 1 the child of hinge j. Every
array is in the world frame; a quaternion is (x, y, z, w).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Model(NamedTuple):
    """What the bodies are: masses, principal moments, the tree (``parents``: -1 at a root; its
    index below its children's) and which hinge joins each body to its parent, the hinges' axes
    in their child's frame and each hinge's anchor in its child's and its parent's frame."""

    masses: np.ndarray
    principal: np.ndarray
    parents: np.ndarray
    joint_of: np.ndarray
    local_axes: np.ndarray
    anchor_child: np.ndarray
    anchor_parent: np.ndarray


class State(NamedTuple):
    """Every body's centre, quaternion, velocity and spin."""

    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    spin: np.ndarray


class Forces(NamedTuple):
    """The forces before the step: gravity, and SimSpark's drag (per body in an island, one value
    for a robot alone) acting on the velocities ``drag_vel`` / ``drag_spin`` (the bodies' own, but
    a beamed torso's from before the beam)."""

    gravity: np.ndarray
    drag_linear: object
    drag_angular: object
    drag_vel: np.ndarray
    drag_spin: np.ndarray


class Motors(NamedTuple):
    """Each hinge's motor or stop row: target speed, force bounds, the motor's push at a stop, and
    which row each hinge held in the last step (updated in place)."""

    target: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    push: np.ndarray
    state: np.ndarray


class GroundContacts(NamedTuple):
    """A robot's contacts with the ground: the body, the point and the depth of each (the normal is
    +z and the surface ``Params``' robot-ground one)."""

    body: np.ndarray
    point: np.ndarray
    depth: np.ndarray


class Contacts(NamedTuple):
    """Contacts of one body with something static (the ground, a goal, a wall): the normal points
    into the body; surfaces as rows of (ERP, CFM, slip, bounce, minimum bounce velocity)."""

    body: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    surface: np.ndarray


class PairContacts(NamedTuple):
    """Contacts between two bodies: the normal points from body 2 into body 1."""

    body1: np.ndarray
    body2: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    surface: np.ndarray


class Params(NamedTuple):
    """The step's numbers: its length, the hinges' world ERP and CFM, the motor rows' CFM, the
    contact surface layer, whether the gyroscopic torque is implicit, and the robot-ground
    contact's ERP, CFM and slip."""

    h: float
    joint_erp: float
    joint_cfm: float
    motor_cfm: float
    surface_layer: float
    implicit_gyro: bool
    contact_erp: float
    contact_cfm: float
    slip: float


class IslandSolve(NamedTuple):
    """How an island's bounded rows are solved: exactly up to ``exact_rows`` rows, past them by
    ``gauss_seidel`` with at most ``sweeps`` sweeps, stopping when no multiplier moves by more
    than ``tolerance`` of the largest (``PhysicsConfig``'s island settings)."""

    exact_rows: int
    sweeps: int
    tolerance: float
