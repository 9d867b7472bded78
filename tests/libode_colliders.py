"""libode's own plane colliders through ctypes: the reference the stand-in's ground contacts are
checked against (``tests/test_ode_colliders.py``). libode 0.16.2 is the library the real
rcssserver3d links (Debian's libode8; ``docker/rcssserver3d/build-from-upstream.sh`` installs it
with the real server).

``python tests/libode_colliders.py`` rewrites ``tests/data/libode/plane_contacts.json``: random
shape poses with libode's contacts, so that a clone without libode still checks against them.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import sys
from pathlib import Path

import numpy as np

FIXTURE = Path(__file__).resolve().parent / "data" / "libode" / "plane_contacts.json"

#: the stand-in's shape kinds (``server_stub.physics.collision``): box, sphere, capsule
BOX, SPHERE, CAPSULE = "box", "sphere", "capsule"

_D = ctypes.c_double


class _ContactGeom(ctypes.Structure):
    _fields_ = [
        ("pos", _D * 4),
        ("normal", _D * 4),
        ("depth", _D),
        ("g1", ctypes.c_void_p),
        ("g2", ctypes.c_void_p),
        ("side1", ctypes.c_int),
        ("side2", ctypes.c_int),
    ]


class LibOde:
    """One loaded libode (double precision, as Debian builds it) with a ground plane z = 0."""

    def __init__(self) -> None:
        name = ctypes.util.find_library("ode") or "libode.so.8"
        self._lib = ctypes.CDLL(name)  # OSError when it is not installed
        lib = self._lib
        lib.dInitODE2(0)
        for fn in ("dCreatePlane", "dCreateBox", "dCreateSphere", "dCreateCapsule"):
            getattr(lib, fn).restype = ctypes.c_void_p
        lib.dGeomGetRotation.restype = ctypes.POINTER(_D)
        self._plane = ctypes.c_void_p(lib.dCreatePlane(None, _D(0), _D(0), _D(1), _D(0)))
        self._buffer = (_ContactGeom * 4)()

    def contacts(
        self, kind: str, size: list[float], centre: list[float], quat_xyzw: list[float], max_points: int
    ) -> tuple[np.ndarray, list[tuple[list[float], float]]]:
        """libode's contacts of one shape with the plane, and the rotation matrix libode made of
        the quaternion (it normalises it itself). ``size``: a box's side lengths; a sphere's
        radius first; a capsule's length (along its z) then radius, as the stand-in stores them."""
        lib = self._lib
        if kind == BOX:
            geom = lib.dCreateBox(None, _D(size[0]), _D(size[1]), _D(size[2]))
        elif kind == SPHERE:
            geom = lib.dCreateSphere(None, _D(size[0]))
        else:
            geom = lib.dCreateCapsule(None, _D(size[1]), _D(size[0]))
        geom = ctypes.c_void_p(geom)
        try:
            lib.dGeomSetPosition(geom, *(_D(v) for v in centre))
            x, y, z, w = quat_xyzw
            lib.dGeomSetQuaternion(geom, (_D * 4)(w, x, y, z))
            m = lib.dGeomGetRotation(geom)
            rotation = np.array([[m[4 * i + j] for j in range(3)] for i in range(3)])
            n = lib.dCollide(geom, self._plane, max_points, self._buffer, ctypes.sizeof(_ContactGeom))
            found = [(list(self._buffer[i].pos[:3]), float(self._buffer[i].depth)) for i in range(n)]
        finally:
            lib.dGeomDestroy(geom)
        return rotation, found


def random_pose(rng: np.random.Generator, kind: str) -> dict:
    """A pose near the ground: flat-ish (as a walking foot), exactly flat (ties) or any turn."""
    if kind == BOX:
        size = [0.08, 0.16, 0.02] if rng.random() < 0.5 else list(rng.uniform(0.01, 0.2, 3))
    elif kind == SPHERE:
        size = [float(rng.uniform(0.01, 0.1)), 0.0, 0.0]
    else:
        size = [float(rng.uniform(0.02, 0.2)), float(rng.uniform(0.01, 0.05)), 0.0]
    draw = rng.random()
    if draw < 0.15:
        quat = [0.0, 0.0, 0.0, 1.0]
    elif draw < 0.5:
        quat = [*rng.normal(scale=0.05, size=3), 1.0]
    else:
        quat = list(rng.normal(size=4))
    norm = float(np.linalg.norm(quat))
    centre = [*rng.uniform(-1.0, 1.0, 2), float(rng.uniform(-0.05, 0.15))]
    return {"kind": kind, "size": size, "centre": centre, "quat": [q / norm for q in quat]}


def main() -> None:
    ode = LibOde()
    rng = np.random.default_rng(20261202)
    cases = []
    for i in range(600):
        pose = random_pose(rng, (BOX, BOX, BOX, SPHERE, CAPSULE)[i % 5])
        for max_points in (3, 4):
            rotation, found = ode.contacts(pose["kind"], pose["size"], pose["centre"], pose["quat"], max_points)
            cases.append({**pose, "max_points": max_points, "rotation": rotation.tolist(), "contacts": found})
    FIXTURE.parent.mkdir(parents=True, exist_ok=True)
    FIXTURE.write_text(
        json.dumps({"source": "libode 0.16.2 (Debian libode8), dCollide with a plane z = 0", "cases": cases})
    )
    print(f"{len(cases)} cases -> {FIXTURE}", file=sys.stderr)


if __name__ == "__main__":
    main()
