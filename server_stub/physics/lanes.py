"""Robots as lanes: one robot type's model once and every robot's bodies as a row of arrays with a
lane axis first (MuJoCo's model and data; MJX's batch axis), so that one compiled call steps every
robot that touches nothing but the ground.

Why: a robot's step against the ground is a few compiled kernels (its motor rows, its ground
contacts, ``tree_step.step_tree``, ``bodies.measured_state``) with Python between them, and that
Python, paid once per robot per cycle, cost as much as the solve itself. ``step_lanes`` runs
those kernels for every lane in one call; a field's lone robots (``stepper.Stepper``) are its
lanes, and one robot alone is one lane of the same code. Each lane's numbers are the very
operations of a robot stepped alone, on views of its rows, so its results are the same bits.

A ``LaneGroup`` holds the lanes of one robot type (one body layout; the constants of its first
robot, which every robot of the type shares): per lane its bodies' state, its hinges' anchors
in their bodies (read at its first placement), the motor rows' state, what the last step
measured (torso and hinges, ``bodies.measured_state``'s layout), this cycle's motor commands,
and the step's contacts with their solved forces. Rows are handed out and taken back as robots
come and go; the arrays grow by doubling, so a view of a row is good until the next robot is
added.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from server_stub.physics.bodies import measured_state
from server_stub.physics.bundles import State
from server_stub.physics.collision import ground_contacts
from server_stub.physics.rows import FUDGE_FACTOR, motor_rows
from server_stub.physics.tree_step import step_tree

#: Lanes a group makes room for at first.
_FIRST_CAPACITY = 1


class LaneModel(NamedTuple):
    """What every robot of a type shares, as the lane kernel takes it: the tree (``bundles.Model``'s
    first five fields), the hinges' upper limits and the collision shapes."""

    masses: np.ndarray
    principal: np.ndarray
    parents: np.ndarray
    joint_of: np.ndarray
    local_axes: np.ndarray
    upper: np.ndarray
    shape_body: np.ndarray
    shape_kind: np.ndarray
    shape_size: np.ndarray


def _same(a: LaneModel, b: LaneModel) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a, b))


class LaneGroup:
    """The lanes of one robot type: its model once, each robot a row of the lane arrays."""

    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    spin: np.ndarray
    anchor_child: np.ndarray
    anchor_parent: np.ndarray
    motor_state: np.ndarray
    written: np.ndarray
    angles: np.ndarray
    target: np.ndarray
    force: np.ndarray
    sticky: np.ndarray
    beamed: np.ndarray
    drag_vel: np.ndarray
    drag_spin: np.ndarray
    torques: np.ndarray
    iterations: np.ndarray
    contact_count: np.ndarray
    contact_body: np.ndarray
    contact_point: np.ndarray
    contact_depth: np.ndarray
    contact_force: np.ndarray
    contact_tangent: np.ndarray

    #: the arrays with a lane axis, by name, and each one's shape after it ("b" bodies, "j" hinges,
    #: "c" contact slots) and type
    _LAYOUT: dict[str, tuple[str, type]] = {
        "pos": ("b3", float),
        "quat": ("b4", float),
        "vel": ("b3", float),
        "spin": ("b3", float),
        "anchor_child": ("j3", float),
        "anchor_parent": ("j3", float),
        "motor_state": ("j", np.int64),
        "written": ("w", float),
        "angles": ("j", float),
        "target": ("j", float),
        "force": ("j", float),
        "sticky": ("j", float),
        "beamed": ("", np.bool_),
        "drag_vel": ("b3", float),
        "drag_spin": ("b3", float),
        "torques": ("j", float),
        "iterations": ("", np.int64),
        "contact_count": ("", np.int64),
        "contact_body": ("c", np.int64),
        "contact_point": ("c3", float),
        "contact_depth": ("c", float),
        "contact_force": ("c3", float),
        "contact_tangent": ("c23", float),
    }

    def __init__(self, model: LaneModel, box_points: int) -> None:
        self.model = model
        nb = model.masses.shape[0]
        nj = model.local_axes.shape[0]
        # ``collision.ground_contacts``' room: every shape's most contacts
        slots = model.shape_body.shape[0] * max(box_points, 2)
        self._dims = {"b": nb, "j": nj, "c": slots, "w": 13 + 2 * nj}
        self._free: list[int] = []
        self.capacity = 0
        self._grow(_FIRST_CAPACITY)

    def _shape(self, capacity: int, spec: str) -> tuple[int, ...]:
        return (capacity, *(self._dims.get(ch, int(ch) if ch.isdigit() else 0) for ch in spec))

    def _grow(self, capacity: int) -> None:
        """Room for ``capacity`` lanes, the rows in use kept."""
        old = self.capacity
        for name, (spec, kind) in self._LAYOUT.items():
            grown: np.ndarray = np.zeros(self._shape(capacity, spec), dtype=kind)
            if old:
                grown[:old] = getattr(self, name)
            setattr(self, name, grown)
        self._free.extend(range(capacity - 1, old - 1, -1))
        self.capacity = capacity

    def add(self) -> int:
        """A row for a new robot, its motor rows' state zeroed (the row of a robot that left may be
        handed out again)."""
        if not self._free:
            self._grow(2 * self.capacity)
        row = self._free.pop()
        self.motor_state[row] = 0
        return row

    def remove(self, row: int) -> None:
        """A robot has left: its row is free."""
        self._free.append(row)

    def matches(self, model: LaneModel) -> bool:
        """Whether a robot's model is this group's (the same type's robots share every constant)."""
        return _same(self.model, model)

    def state(self, row: int) -> State:
        """Views of a lane's bodies' state (good until the next ``add``)."""
        return State(self.pos[row], self.quat[row], self.vel[row], self.spin[row])

    def step(self, rows: np.ndarray, gravity: np.ndarray, config, params: tuple) -> None:
        """Step the lanes ``rows`` (their motor commands and ``beamed`` set this cycle): one call of
        ``step_lanes`` (``params``: ``robot_step.params_of(config)`` as a plain tuple)."""
        m = self.model
        step_lanes(
            rows,
            (m.masses, m.principal, m.parents, m.joint_of, m.local_axes),
            (m.upper, m.shape_body, m.shape_kind, m.shape_size),
            (self.pos, self.quat, self.vel, self.spin, self.anchor_child, self.anchor_parent),
            (self.angles, self.target, self.force, self.sticky, self.motor_state),
            (gravity, config.linear_damping, config.angular_damping, self.beamed, self.drag_vel, self.drag_spin),
            params,
            (config.ode_box_points, config.motor_torque),
            (self.written, self.torques, self.iterations),
            (
                self.contact_count,
                self.contact_body,
                self.contact_point,
                self.contact_depth,
                self.contact_force,
                self.contact_tangent,
            ),
        )


@njit(cache=True)
def step_lanes(rows, model, limits, data, commands, forces, params, settings, measured, contacts):
    """One cycle of the lanes ``rows``, each a robot against the ground alone: its motor rows
    (``rows.motor_rows``), its ground contacts (``collision.ground_contacts``), its step
    (``tree_step.step_tree``) and what the step measures (``bodies.measured_state``), each on views
    of the lane's rows, written back into them. A ``beamed`` lane's drag acts on ``drag_vel`` and
    ``drag_spin`` (its velocities before a beam), any other's on its bodies' own."""
    masses, principal, parents, joint_of, local_axes = model
    upper, shape_body, shape_kind, shape_size = limits
    pos, quat, vel, spin, anchor_child, anchor_parent = data
    angles, target, force, sticky, motor_state = commands
    gravity, drag_linear, drag_angular, beamed, drag_vel, drag_spin = forces
    box_points, torque_limit = settings
    written, torques, iterations = measured
    count, c_body, c_point, c_depth, c_force, c_tangent = contacts
    nb = masses.shape[0]
    nj = local_axes.shape[0]
    for i in range(rows.shape[0]):
        r = rows[i]
        lo, hi, push = motor_rows(angles[r], upper, force[r], sticky[r], torque_limit, FUDGE_FACTOR)
        ground = ground_contacts(shape_body, shape_kind, shape_size, pos[r], quat[r], box_points)
        if beamed[r]:
            dv = drag_vel[r]
            ds = drag_spin[r]
        else:
            dv = vel[r]
            ds = spin[r]
        out = step_tree(
            (masses, principal, parents, joint_of, local_axes, anchor_child[r], anchor_parent[r]),
            (pos[r], quat[r], vel[r], spin[r]),
            (gravity, drag_linear, drag_angular, dv, ds),
            ground,
            (target[r], lo, hi, push, motor_state[r]),
            params,
        )
        npos, nquat, nvel, nspin, solved, tangents, torque, its = out
        for k in range(nb):
            for a in range(3):
                pos[r, k, a] = npos[k, a]
                vel[r, k, a] = nvel[k, a]
                spin[r, k, a] = nspin[k, a]
            for a in range(4):
                quat[r, k, a] = nquat[k, a]
        w = measured_state(npos, nquat, nvel, nspin, parents, joint_of, local_axes)
        for a in range(w.shape[0]):
            written[r, a] = w[a]
        for j in range(nj):
            torques[r, j] = torque[j]
        iterations[r] = its
        bodies, points, depths = ground
        n = bodies.shape[0]
        count[r] = n
        for c in range(n):
            c_body[r, c] = bodies[c]
            c_depth[r, c] = depths[c]
            for a in range(3):
                c_point[r, c, a] = points[c, a]
                c_force[r, c, a] = solved[c, a]
                c_tangent[r, c, 0, a] = tangents[c, 0, a]
                c_tangent[r, c, 1, a] = tangents[c, 1, a]
