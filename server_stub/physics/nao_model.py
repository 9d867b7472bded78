"""The simulated NAO's body: parts, hinges and heterogeneous types, and its URDF text.

Geometry lives here (not in ``protocol``) because only the physics needs it; joint names and
limits come from ``protocol.nao`` so those numbers exist once. Every table cites the section of
``docs/robot_and_server.md`` it was read from. All positions are in the robot (model) frame of the facts
sheet -- x = robot's right, y = forward, z = up -- relative to the torso centre, in the zero pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from protocol.nao import JOINTS, SPEED_CAP, joints_of

#: Every hinge's range in radians, in ``JOINTS`` order (docs/robot_and_server.md section 3).
JOINT_MIN = np.radians([j.min_deg for j in JOINTS])
JOINT_MAX = np.radians([j.max_deg for j in JOINTS])

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Part:
    """One rigid body: a uniform solid of ``shape`` (box: full sizes x, y, z; sphere: (radius,);
    capsule: (radius, cylinder length along z)), centred at ``centre``."""

    name: str
    shape: str
    size: tuple[float, ...]
    mass: float
    centre: Vec3
    collides: bool


@dataclass(frozen=True)
class Hinge:
    """One hinge joint; ``anchor_moves_with`` names the part whose type-dependent shift the anchor
    follows (the child for every joint but the hip pitch, which stays at the hip)."""

    effector: str
    parent: str
    child: str
    axis: Vec3
    anchor: Vec3
    anchor_moves_with: str


# docs/robot_and_server.md section 2 (type 0). Centre and middle parts once, right-side parts with their
# right-side centre; the left twin is built by mirroring x (see ``_mirror``).
_CENTRE_PARTS: tuple[Part, ...] = (
    Part("torso", "box", (0.10, 0.10, 0.18), 1.2171, (0.0, 0.0, 0.0), True),
    Part("neck", "capsule", (0.015, 0.08), 0.050, (0.0, 0.0, 0.090), True),
    Part("head", "sphere", (0.065,), 0.350, (0.0, 0.0, 0.155), True),
)
_RIGHT_PARTS: tuple[Part, ...] = (
    Part("rshoulder", "sphere", (0.01,), 0.070, (0.098, 0.0, 0.075), False),
    Part("rupperarm", "box", (0.07, 0.08, 0.06), 0.150, (0.108, 0.020, 0.075), True),
    Part("relbow", "sphere", (0.01,), 0.035, (0.098, 0.090, 0.084), False),
    Part("rlowerarm", "box", (0.05, 0.11, 0.05), 0.200, (0.098, 0.140, 0.084), True),
    Part("rhip1", "sphere", (0.01,), 0.090, (0.055, -0.010, -0.115), False),
    Part("rhip2", "sphere", (0.01,), 0.125, (0.055, -0.010, -0.115), False),
    Part("rthigh", "box", (0.07, 0.07, 0.14), 0.275, (0.055, 0.000, -0.155), True),
    Part("rshank", "box", (0.08, 0.07, 0.11), 0.225, (0.055, 0.005, -0.280), True),
    Part("rankle", "sphere", (0.01,), 0.125, (0.055, -0.005, -0.335), False),
    Part("rfoot", "box", (0.08, 0.16, 0.02), 0.200, (0.055, 0.025, -0.375), True),
)

# docs/robot_and_server.md section 3 (type 0): parent -> child, axis, anchor (right side for paired joints).
_CENTRE_HINGES: tuple[Hinge, ...] = (
    Hinge("he1", "torso", "neck", (0.0, 0.0, 1.0), (0.0, 0.0, 0.090), "neck"),
    Hinge("he2", "neck", "head", (1.0, 0.0, 0.0), (0.0, 0.0, 0.150), "head"),
)
_RIGHT_HINGES: tuple[Hinge, ...] = (
    Hinge("rae1", "torso", "rshoulder", (1.0, 0.0, 0.0), (0.098, 0.0, 0.075), "rshoulder"),
    Hinge("rae2", "rshoulder", "rupperarm", (0.0, 0.0, 1.0), (0.098, 0.0, 0.075), "rupperarm"),
    Hinge("rae3", "rupperarm", "relbow", (0.0, 1.0, 0.0), (0.098, 0.090, 0.084), "relbow"),
    Hinge("rae4", "relbow", "rlowerarm", (0.0, 0.0, 1.0), (0.098, 0.090, 0.084), "rlowerarm"),
    Hinge("rle1", "torso", "rhip1", (-0.7071, 0.0, 0.7071), (0.055, -0.010, -0.115), "rhip1"),
    Hinge("rle2", "rhip1", "rhip2", (0.0, 1.0, 0.0), (0.055, -0.010, -0.115), "rhip2"),
    Hinge("rle3", "rhip2", "rthigh", (1.0, 0.0, 0.0), (0.055, -0.010, -0.115), "rhip2"),
    Hinge("rle4", "rthigh", "rshank", (1.0, 0.0, 0.0), (0.055, -0.005, -0.235), "rshank"),
    Hinge("rle5", "rshank", "rankle", (1.0, 0.0, 0.0), (0.055, -0.005, -0.335), "rankle"),
    Hinge("rle6", "rankle", "rfoot", (0.0, 1.0, 0.0), (0.055, -0.005, -0.340), "rfoot"),
)
#: Section 3 lists a separate left axis only for the hip yaw-pitch; every other left joint shares
#: the right joint's axis (its limits are mirrored instead, see ``protocol.nao.JOINTS``).
_LEFT_AXIS: dict[str, Vec3] = {"lle1": (-0.7071, 0.0, -0.7071)}


@dataclass(frozen=True)
class Toes:
    """A type's foot split into a foot and a toe in front of it (docs/robot_and_server.md section
    3, "Robot type 4"; naolegtoe.rsg). Lengths along the foot (y), masses, and how far the shorter
    foot's centre and the toe hinge's anchor sit behind the type-0 foot's centre and the toe's."""

    foot_length: float
    foot_mass: float
    foot_back: float
    toe_length: float
    toe_mass: float
    anchor_back: float


@dataclass(frozen=True)
class RobotType:
    """One heterogeneous type (docs/robot_and_server.md section 3, "Heterogeneous types");
    ``toes`` None for a type without toes."""

    hip_x: float
    thigh_below_hip: float
    ankle_below_shank: float
    elbow_ahead: float
    ankle_pitch_speed: float
    ankle_roll_speed: float
    toes: Toes | None = None


#: docs/robot_and_server.md section 3, heterogeneous types table.
ROBOT_TYPES: dict[int, RobotType] = {
    0: RobotType(0.055, 0.04, 0.055, 0.07, SPEED_CAP, SPEED_CAP),
    1: RobotType(0.055, 0.05832, 0.07332, 0.10664, SPEED_CAP, SPEED_CAP),
    2: RobotType(0.055, 0.04, 0.055, 0.07, 8.80667, 3.47234),
    3: RobotType(0.072954, 0.067868, 0.082868, 0.125737, SPEED_CAP, SPEED_CAP),
    #: SimSpark evaluates each ``(eval ...)`` of a scene file into a float printed with 6
    #: significant digits, so type 4's bodies have the ToeLength 0.035517656 of naorobottypes.rb
    #: as 0.0355177, and every length and mass made from it rounded likewise (the real server's
    #: monitor shows the toe's mesh scaled by 0.0228259, which only these values give).
    4: RobotType(
        0.055,
        0.04,
        0.055,
        0.07,
        SPEED_CAP,
        SPEED_CAP,
        Toes(
            foot_length=0.124482,
            foot_mass=0.177801,
            foot_back=0.03 - 0.012241,
            toe_length=0.0355177,
            toe_mass=0.0221986,
            anchor_back=0.0177589,
        ),
    ),
}
_TYPE0 = ROBOT_TYPES[0]

#: A toe's centre from its foot's centre (half the type-0 foot's 0.16 m ahead, 5 mm lower), its
#: hinge's anchor below its centre, its thickness (naolegtoe.rsg): its underside is flush with
#: the sole, its hinge on the sole where foot and toe meet.
_TOE_FROM_FOOT: Vec3 = (0.0, 0.08, -0.005)
_TOE_ANCHOR_DROP = -0.005
_TOE_THICKNESS = 0.01

#: Right-side parts moved by each type dimension (the chain below the changed offset).
_LEG = ("rhip1", "rhip2", "rthigh", "rshank", "rankle", "rfoot")
_BELOW_THIGH_JOINT = ("rthigh", "rshank", "rankle", "rfoot")
_BELOW_ANKLE_JOINT = ("rankle", "rfoot")
_BELOW_ELBOW = ("relbow", "rlowerarm")

FOOT_PARTS: dict[str, str] = {"lf": "lfoot", "rf": "rfoot"}


def _shift(name: str, rtype: RobotType) -> Vec3:
    """How far a right-side part sits from its type-0 place in robot type ``rtype``."""
    dx = (rtype.hip_x - _TYPE0.hip_x) if name in _LEG else 0.0
    dy = (rtype.elbow_ahead - _TYPE0.elbow_ahead) if name in _BELOW_ELBOW else 0.0
    dz = 0.0
    if name in _BELOW_THIGH_JOINT:
        dz -= rtype.thigh_below_hip - _TYPE0.thigh_below_hip
    if name in _BELOW_ANKLE_JOINT:
        dz -= rtype.ankle_below_shank - _TYPE0.ankle_below_shank
    return (dx, dy, dz)


def _add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _mirror_name(name: str) -> str:
    return "l" + name[1:]


def _mirror(v: Vec3) -> Vec3:
    return (-v[0], v[1], v[2])


def body_parts(robot_type: int = 0) -> tuple[Part, ...]:
    """Every part of the robot of ``robot_type``: centre parts, then right, then left parts."""
    rtype = _robot_type(robot_type)
    right = tuple(
        Part(p.name, p.shape, p.size, p.mass, _add(p.centre, _shift(p.name, rtype)), p.collides) for p in _RIGHT_PARTS
    )
    if rtype.toes is not None:
        right = right[:-1] + _foot_and_toe(right[-1], rtype.toes)
    left = tuple(Part(_mirror_name(p.name), p.shape, p.size, p.mass, _mirror(p.centre), p.collides) for p in right)
    return _CENTRE_PARTS + right + left


def _foot_and_toe(foot: Part, toes: Toes) -> tuple[Part, Part]:
    """A type-0 ``foot`` split into a shorter foot (its heel where it was) and a toe in front of it."""
    width, _, height = foot.size
    centre = _add(foot.centre, (0.0, -toes.foot_back, 0.0))
    short = Part(foot.name, foot.shape, (width, toes.foot_length, height), toes.foot_mass, centre, foot.collides)
    toe_centre = _add(centre, _TOE_FROM_FOOT)
    toe = Part(_toe_name(foot.name), "box", (width, toes.toe_length, _TOE_THICKNESS), toes.toe_mass, toe_centre, True)
    return short, toe


def _toe_name(foot: str) -> str:
    return foot[0] + "toe"


def hinges(robot_type: int = 0) -> tuple[Hinge, ...]:
    """Every hinge of the robot of ``robot_type``, in ``protocol.nao.joints_of`` order."""
    rtype = _robot_type(robot_type)
    by_effector: dict[str, Hinge] = {h.effector: h for h in _CENTRE_HINGES}
    for h in _right_hinges(rtype):
        anchor = _add(h.anchor, _shift(h.anchor_moves_with, rtype))
        right = Hinge(h.effector, h.parent, h.child, h.axis, anchor, h.anchor_moves_with)
        left_effector = _mirror_name(h.effector)
        by_effector[h.effector] = right
        by_effector[left_effector] = Hinge(
            left_effector,
            h.parent if h.parent == "torso" else _mirror_name(h.parent),
            _mirror_name(h.child),
            _LEFT_AXIS.get(left_effector, h.axis),
            _mirror(anchor),
            _mirror_name(h.anchor_moves_with),
        )
    return tuple(by_effector[j.effector] for j in joints_of(robot_type))


def _right_hinges(rtype: RobotType) -> tuple[Hinge, ...]:
    """The right side's hinges of ``rtype``: the ankle roll moves with the foot (naolegtoe.rsg
    anchors it in the foot's frame, so it follows the shorter foot's centre back), and the toe
    hinge (rle7) joins the toe to the foot along the foot's front edge at the sole."""
    toes = rtype.toes
    if toes is None:
        return _RIGHT_HINGES
    back = (0.0, -toes.foot_back, 0.0)
    roll = _RIGHT_HINGES[-1]
    roll_anchor = _add(roll.anchor, back)
    toe_centre = _add(_add(_part("rfoot").centre, back), _TOE_FROM_FOOT)
    toe_anchor = _add(toe_centre, (0.0, -toes.anchor_back, _TOE_ANCHOR_DROP))
    return _RIGHT_HINGES[:-1] + (
        Hinge(roll.effector, roll.parent, roll.child, roll.axis, roll_anchor, roll.anchor_moves_with),
        Hinge("rle7", "rfoot", "rtoe", (1.0, 0.0, 0.0), toe_anchor, roll.anchor_moves_with),
    )


def _part(name: str) -> Part:
    return next(p for p in _RIGHT_PARTS if p.name == name)


def part_names(robot_type: int = 0) -> tuple[str, ...]:
    """Every part in the monitor scene's order (the server's body tree): torso first, then each
    hinge's child in ``protocol.nao.JOINTS`` order, a toe right after its foot."""
    children = [h.child for h in hinges(robot_type)]
    for toe in ("rtoe", "ltoe"):
        if toe in children:
            children.remove(toe)
            children.insert(children.index(toe[0] + "foot") + 1, toe)
    return ("torso", *children)


def speed_caps(robot_type: int = 0) -> tuple[float, ...]:
    """Per-joint speed cap (rad/s) in JOINTS order; type 2 has its own ankle speeds (section 3)."""
    rtype = _robot_type(robot_type)
    special = {
        "rle5": rtype.ankle_pitch_speed,
        "lle5": rtype.ankle_pitch_speed,
        "rle6": rtype.ankle_roll_speed,
        "lle6": rtype.ankle_roll_speed,
    }
    return tuple(special.get(j.effector, SPEED_CAP) for j in joints_of(robot_type))


def joint_limits(robot_type: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Every hinge's range in radians (min, max), in ``protocol.nao.joints_of`` order."""
    joints = joints_of(robot_type)
    if joints is JOINTS:
        return JOINT_MIN, JOINT_MAX
    return np.radians([j.min_deg for j in joints]), np.radians([j.max_deg for j in joints])


def pressure_parts(robot_type: int = 0) -> dict[str, str]:
    """Every ``FRP`` name of the robot and the part whose contacts it sums: each foot (lf, rf),
    and each toe (lf1, rf1) on a type with toes (naolegtoe.rsg)."""
    if _robot_type(robot_type).toes is None:
        return dict(FOOT_PARTS)
    return {**FOOT_PARTS, "lf1": "ltoe", "rf1": "rtoe"}


def _robot_type(robot_type: int) -> RobotType:
    try:
        return ROBOT_TYPES[robot_type]
    except KeyError:
        raise ValueError(f"robot type {robot_type} is not modelled (have {sorted(ROBOT_TYPES)})") from None


def inertia_diagonal(part: Part) -> Vec3:
    """Principal moments of a uniform solid (ODE's dMassSetBox / Sphere / Capsule conventions)."""
    m = part.mass
    if part.shape == "box":
        x, y, z = part.size
        return (m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12)
    if part.shape == "sphere":
        i = 0.4 * m * part.size[0] ** 2
        return (i, i, i)
    if part.shape == "capsule":
        r, length = part.size
        v_cyl = math.pi * r * r * length
        v_caps = 4.0 / 3.0 * math.pi * r**3
        m_cyl = m * v_cyl / (v_cyl + v_caps)
        m_caps = m - m_cyl
        across = m_cyl * (length * length / 12 + r * r / 4) + m_caps * (
            0.4 * r * r + length * length / 4 + 3 * length * r / 8
        )
        along = 0.5 * m_cyl * r * r + 0.4 * m_caps * r * r
        return (across, across, along)
    raise ValueError(f"unknown shape {part.shape!r}")


def _num(value: float) -> str:
    """Plain decimal notation: pybullet's URDF reader rejects exponents such as 1e-05."""
    return f"{value:.10f}".rstrip("0").rstrip(".") or "0"


def _xyz(v: tuple[float, ...]) -> str:
    return " ".join(_num(c) for c in v)


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _unit(v: Vec3) -> Vec3:
    n = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return (v[0] / n, v[1] / n, v[2] / n)


def _geometry(part: Part) -> str:
    if part.shape == "box":
        return f'<box size="{_xyz(part.size)}"/>'
    if part.shape == "sphere":
        return f'<sphere radius="{_num(part.size[0])}"/>'
    return f'<capsule radius="{_num(part.size[0])}" length="{_num(part.size[1])}"/>'


def _link(part: Part, frame_origin: Vec3, inertia_floor: float) -> str:
    """A link whose frame sits at ``frame_origin`` (its joint anchor; the torso centre for the
    torso), axis-aligned with the robot frame; mass, shape and collision at the part centre."""
    ixx, iyy, izz = (max(i, inertia_floor) for i in inertia_diagonal(part))
    offset = _xyz(_sub(part.centre, frame_origin))
    collision = (
        (f'<collision><origin xyz="{offset}"/><geometry>{_geometry(part)}</geometry></collision>')
        if part.collides
        else ""
    )
    return (
        f'<link name="{part.name}"><inertial><origin xyz="{offset}"/>'
        f'<mass value="{_num(part.mass)}"/>'
        f'<inertia ixx="{_num(ixx)}" iyy="{_num(iyy)}" izz="{_num(izz)}" ixy="0" ixz="0" iyz="0"/>'
        f"</inertial>{collision}</link>"
    )


def urdf(robot_type: int = 0, inertia_floor: float = 0.0) -> str:
    """URDF text of the robot, links in ``JOINTS`` order so pybullet link i is joint i.

    Joints are ``continuous``: the real server's stops are soft for one step and bounce, which the
    stub reproduces itself (``server_stub.physics.robot``); pybullet's hard limits would not overshoot.
    ``inertia_floor`` (kg m^2) raises every principal moment to at least that value.
    """
    parts = {p.name: p for p in body_parts(robot_type)}
    joints = hinges(robot_type)
    frame_origin = {"torso": (0.0, 0.0, 0.0)}
    frame_origin.update({h.child: h.anchor for h in joints})
    text = ['<?xml version="1.0"?><robot name="nao">', _link(parts["torso"], frame_origin["torso"], inertia_floor)]
    for h in joints:
        text.append(_link(parts[h.child], frame_origin[h.child], inertia_floor))
        text.append(
            f'<joint name="{h.effector}" type="continuous"><parent link="{h.parent}"/>'
            f'<child link="{h.child}"/>'
            f'<origin xyz="{_xyz(_sub(h.anchor, frame_origin[h.parent]))}"/>'
            f'<axis xyz="{_xyz(_unit(h.axis))}"/></joint>'
        )
    text.append("</robot>")
    # a line each: pybullet's URDF reader fails on a line much longer than a 22-joint robot's
    return "\n".join(text)


def total_mass(robot_type: int = 0) -> float:
    return sum(p.mass for p in body_parts(robot_type))
