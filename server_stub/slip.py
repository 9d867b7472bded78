"""Force-dependent slip of the contacts (NAO_MODEL_FACTS.md section 4), solved outside Bullet.

ODE, the real server's engine, gives each contact two friction rows with CFM = slip (0.005 m/s
per N) and no Coulomb limit: a contact point slides at slip x its tangential force, and the
solver finds those forces together with everything else. Bullet has no such row, and pybullet
offers only one global CFM, which would soften every motor and contact as well (tried: the robot
sagged and fell). So the stub applies the slip force as an external force at each contact point,
from the linearly implicit damper over one step of length h::

    v + h A F = -slip F        (tangential components of every point at once)

where v holds the points' tangential velocities at the start of the step and A their mobility
(velocity per unit force) if the whole robot were one rigid body, its joints held by their
motors. Solving for all points together is what keeps this stable at one step per cycle, however
many points share a foot; a damper per point with a guessed mass (what this replaced) needed
three sub-steps per cycle and still depended on how many points a foot had.

The rigid-body damper holds only while the motors hold. A point behind a motor at its torque
limit (a flailing or fallen robot's limb) has far less mass behind it; treating it as rigid made
such robots explode, so those points get a damper sized by their own link's mass instead.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: v @ _CROSS, reshaped to (3, 3), is the cross-product matrix [v]x of a row vector v.
_CROSS = np.zeros((3, 3, 3))
for _i, _j, _k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    _CROSS[_i, _k, _j], _CROSS[_i, _j, _k] = 1.0, -1.0
_CROSS = _CROSS.reshape(3, 9)
_EYE = np.eye(3)


def cross_matrices(v: np.ndarray) -> np.ndarray:
    """[v]x for each row of an (n, 3) array, as (n, 3, 3): [v]x u = v x u."""
    return (v @ _CROSS).reshape(-1, 3, 3)


def composite_body(masses: np.ndarray, centres: np.ndarray, rotations: np.ndarray,
                   principal_moments: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about it) of parts welded together. ``centres`` (n, 3)
    and ``rotations`` (n, 3, 3) give each part's centre and axes in a common frame, in which the
    result is expressed; ``principal_moments`` (n, 3) are the parts' own diagonal inertias."""
    mass = float(masses.sum())
    com = masses @ centres / mass
    d = centres - com
    own = ((rotations * principal_moments[:, None, :]) @ rotations.transpose(0, 2, 1)).sum(axis=0)
    spread = (d.T * masses) @ d
    return mass, com, own + np.trace(spread) * _EYE - spread


def slip_forces(points: np.ndarray, normals: np.ndarray, velocities: np.ndarray, com: np.ndarray,
                mass: float, inertia: np.ndarray, slip: float, h: float) -> np.ndarray:
    """Force (n, 3) at each contact point that solves v + h A F = -slip F in the contact planes.

    ``points``, unit ``normals`` and ``velocities`` (of the robot's material at each point) are
    (n, 3); ``com``, ``mass`` and ``inertia`` (world frame) describe the rigid body the points
    belong to. Forces have no normal component (the constraint solver handles that direction):
    with P the projector onto each contact plane, (slip I + h P A P) F = -P v.
    """
    n = len(points)
    plane = _EYE - normals[:, :, None] * normals[:, None, :]      # (n, 3, 3) projectors
    turn = (plane @ cross_matrices(points - com)).reshape(3 * n, 3)  # P [r]x: the levers
    shift = plane.reshape(3 * n, 3)                               # P: point velocity per m/s
    system = (h / mass) * (shift @ shift.T) + (h * turn) @ np.linalg.solve(inertia, turn.T)
    system.flat[:: 3 * n + 1] += slip
    return np.linalg.solve(system, -(plane @ velocities[:, :, None]).reshape(3 * n)).reshape(n, 3)


def loose_slip_forces(normals: np.ndarray, velocities: np.ndarray, masses: np.ndarray,
                      slip: float, h: float) -> np.ndarray:
    """The same damper for points that each move on their own with ``masses`` (n,) behind them:
    F = -P v / (slip + h / m), what an implicit damper leaves after a step of h."""
    tangential = velocities - (velocities * normals).sum(axis=1)[:, None] * normals
    return -tangential / (slip + h / masses)[:, None]


def at_most_stopping(forces: np.ndarray, normals: np.ndarray, velocities: np.ndarray,
                     slip: float) -> np.ndarray:
    """``forces`` scaled down, point by point, to at most |v| / slip: the force the damper puts
    on a point stopped dead. The rigid-body solve can ask more of a point whose neighbours move
    differently (limbs driven apart by their motors), which the articulated robot cannot take."""
    tangential = velocities - (velocities * normals).sum(axis=1)[:, None] * normals
    limit = np.sqrt((tangential * tangential).sum(axis=1)) / slip
    size = np.sqrt((forces * forces).sum(axis=1))
    return forces * np.minimum(1.0, limit / np.maximum(size, 1e-12))[:, None]


@dataclass(frozen=True)
class Skeleton:
    """What does not change about a robot: parts (torso first) and hinges (joint order)."""

    masses: np.ndarray  # (parts,)
    principal_moments: np.ndarray  # (parts, 3), in each part's own axes
    local_axes: np.ndarray  # (hinges, 3) each hinge's axis in its child part's axes
    #: (parts, hinges): True where the hinge lies between that part and the torso
    chains: np.ndarray
    torque_limit: float


@dataclass(frozen=True)
class Pose:
    """A robot at the start of a step, every vector in the world frame."""

    centres: np.ndarray  # (parts, 3) centres of mass
    rotations: np.ndarray  # (parts, 3, 3) columns = the part's axes
    velocities: np.ndarray  # (parts, 3) of the centres
    spins: np.ndarray  # (parts, 3) angular velocities
    anchors: np.ndarray  # (hinges, 3)
    axes: np.ndarray  # (hinges, 3) unit hinge axes

    @cached_property
    def axis_x_anchor(self) -> np.ndarray:
        """axis x anchor per hinge: the torque of F at p about a hinge is axis . (p x F) minus
        this . F, so levers need not be formed point by point."""
        return (cross_matrices(self.axes) @ self.anchors[:, :, None])[:, :, 0]


def hinge_torques(points: np.ndarray, forces: np.ndarray, chains: np.ndarray, pose: Pose) -> np.ndarray:
    """Torque about every hinge of the forces at ``points``, each counted on the hinges its
    row of ``chains`` (points x hinges) marks: axis . ((p - anchor) x F)."""
    moments = (cross_matrices(points) @ forces[:, :, None])[:, :, 0]   # p x F
    per_point = pose.axes @ moments.T - pose.axis_x_anchor @ forces.T  # (hinges, points)
    return (per_point * chains.T).sum(axis=1)


def contact_forces(skeleton: Skeleton, pose: Pose, parts: np.ndarray, points: np.ndarray,
                   normals: np.ndarray, motor_load: np.ndarray, yielding: np.ndarray,
                   last_torque: np.ndarray, slip: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Slip force at each contact point (on part ``parts[k]``), and the torque these put on every
    hinge (pass it back as ``last_torque`` next step).

    ``motor_load``: the torque each motor applied in the last step (0 for stops); ``yielding``:
    the motors at their limit then. A held point is one whose hinges all hold; the rigid-body
    damper is solved for the held points, and those whose forces would push a motor past its
    limit (a motor balances the change of external torque with its own) are let go and the rest
    solved again once.
    """
    spin = cross_matrices(pose.spins[parts]) @ (points - pose.centres[parts])[:, :, None]
    velocities = pose.velocities[parts] + spin[:, :, 0]
    mass, com, inertia = composite_body(skeleton.masses, pose.centres, pose.rotations,
                                        skeleton.principal_moments)
    chains = skeleton.chains[parts]
    held = ~(chains & yielding).any(axis=1)
    forces = np.zeros_like(points)
    torque = np.zeros_like(last_torque)
    for _ in range(2):
        if not held.any():
            break
        forces[held] = slip_forces(points[held], normals[held], velocities[held], com, mass, inertia, slip, h)
        torque = hinge_torques(points, forces, chains & held[:, None], pose)
        over = np.abs(motor_load - (torque - last_torque)) > skeleton.torque_limit
        overloaded = held & (chains & over).any(axis=1)
        if not overloaded.any():
            break
        held &= ~overloaded
    if not held.all():
        loose = parts[~held]
        share = skeleton.masses[loose] / np.array([np.count_nonzero(loose == p) for p in loose])
        forces[~held] = loose_slip_forces(normals[~held], velocities[~held], share, slip, h)
    capped = at_most_stopping(forces, normals, velocities, slip)
    if held.all() and np.array_equal(capped, forces):
        return forces, torque  # the usual case: the held points' torques are all there is
    return capped, hinge_torques(points, capped, chains, pose)
