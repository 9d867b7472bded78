"""The ``See`` perceptor: what the NAO's head camera reports, as rcssserver3d 0.7.3 prints it.

Grammar of the text produced (docs/robot_and_server.md section 5; fixture ``agent_perceptions_first20.txt``)::

    (See (<flag|post> (pol <d> <h> <v>))... [(B (pol <d> <h> <v>))]
         (P (team <name>) (id <n>) (<part> (pol <d> <h> <v>))...)...
         [(mypos <x> <y> <z>) (myorien <deg>) (ballpos <x> <y> <z>)]
         (L (pol <d> <h> <v>) (pol <d> <h> <v>))...)

``pol``: distance (m), horizontal angle (deg, + = left of the camera's forward axis), vertical
angle (deg, + = up), in the head frame (x right, y forward, z up). Points are kept inside the
120 x 120 deg view cone and farther than 0.1 m; field lines are cut to the view pyramid, which is
why the fixtures show line ends at exactly +-60 deg. No occlusion.

Field lines (reconstructed from the fixtures' line ends with ``mypos``/``myorien``; all 21 match
the 21 unnamed line transforms in the monitor scene): halfway line, the two goal lines, the two
side lines, each penalty area as 3 segments (1.8 m deep, 6.0 m wide), and the centre circle
(radius 2 m) as 10 chords with corners every 36 deg starting on the +x axis.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from server_stub import field

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class VisionConfig:
    """Camera and noise of the real vision perceptor (docs/robot_and_server.md section 5, naoneckhead.rsg)."""

    half_cone_h_deg: float = 60.0
    half_cone_v_deg: float = 60.0
    min_distance: float = 0.1
    #: distance x (1 + N(0, sigma)/100)
    distance_sigma_percent: float = 0.0965
    h_sigma_deg: float = 0.1480
    v_sigma_deg: float = 0.1225
    #: fixed per-robot offset, uniform in +-this on each axis of every relative position (m)
    calibration_error: float = 0.005


LANDMARKS = field.LANDMARKS
#: Body parts of a robot the camera reports, in the server's order inside ``P``.
PLAYER_PARTS: tuple[str, ...] = ("head", "rlowerarm", "llowerarm", "rfoot", "lfoot")


FIELD_LINES = field.LINES


@dataclass(frozen=True)
class SeenRobot:
    """One robot as the camera can see it: world positions of the parts in ``PLAYER_PARTS``."""

    team: str
    unum: int
    parts: Mapping[str, Vec3]


_NAMED_POL = " (%s (pol %.2f %.2f %.2f))"
_LINE = " (L (pol %.2f %.2f %.2f) (pol %.2f %.2f %.2f))"


class VisionSensor:
    """The camera of one robot. It keeps that robot's fixed calibration offset (drawn once, as the
    real server draws it per perceptor), so make one sensor per robot."""

    def __init__(
        self,
        rng: np.random.Generator,
        noise: bool = True,
        sense_mypos: bool = False,
        config: VisionConfig = VisionConfig(),
    ) -> None:
        self._rng = rng
        self._noise = noise
        self._sense_mypos = sense_mypos
        self._cfg = config
        self._offset = rng.uniform(-config.calibration_error, config.calibration_error, 3) if noise else np.zeros(3)
        #: what never moves, in the order ``see`` transforms it: landmarks, line starts, line ends
        self._fixed = np.array(
            [p for _, p in LANDMARKS] + [a for a, _ in FIELD_LINES] + [b for _, b in FIELD_LINES], dtype=float
        )
        self._n_lines = len(FIELD_LINES)
        h, v = math.radians(config.half_cone_h_deg), math.radians(config.half_cone_v_deg)
        # Inward normals of the 4 sides of the view pyramid (head frame x right, y fwd, z up).
        self._planes_t = np.ascontiguousarray(
            np.array(
                [
                    [math.cos(h), math.sin(h), 0.0],
                    [-math.cos(h), math.sin(h), 0.0],
                    [0.0, math.sin(v), -math.cos(v)],
                    [0.0, math.sin(v), math.cos(v)],
                ]
            ).T
        )

    def see(self, camera_pos: Vec3, camera_rot: np.ndarray, side: str, ball: Vec3, robots: Sequence[SeenRobot]) -> str:
        """The ``(See ...)`` entry. ``camera_rot``: 3x3 world rotation of the head (columns = head
        x right, y forward, z up); ``side`` ('left'/'right') only mirrors the ground truth
        (``mypos``, ``myorien``, ``ballpos``); ``robots`` includes the observer itself."""
        cam = np.asarray(camera_pos, dtype=float)
        rot = np.asarray(camera_rot, dtype=float)
        owners: list[tuple[int, str]] = []
        moving = [ball]
        for i, robot in enumerate(robots):
            for part in PLAYER_PARTS:
                pos = robot.parts.get(part)
                if pos is not None:
                    owners.append((i, part))
                    moving.append(pos)
        n_land = len(LANDMARKS)
        n_points = n_land + len(moving)
        c = self._cfg
        exact, visible, n_lines = _view(
            self._fixed,
            np.array(moving, dtype=float),
            cam,
            rot,
            self._offset,
            self._planes_t,
            n_land,
            self._n_lines,
            c.min_distance,
            c.half_cone_h_deg,
            c.half_cone_v_deg,
        )
        visible = visible.tolist()  # the cone cuts before the noise
        polar = self._with_noise(exact)

        out = ["(See"]
        flat = polar[:n_points].ravel().tolist()
        for k, (name, _) in enumerate(LANDMARKS):
            if visible[k]:
                out.append(_NAMED_POL % (name, flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]))
        if visible[n_land]:
            out.append(_NAMED_POL % ("B", flat[3 * n_land], flat[3 * n_land + 1], flat[3 * n_land + 2]))
        out.extend(self._players(robots, owners, flat[3 * (n_land + 1) :], visible[n_land + 1 :]))
        if self._sense_mypos:
            out.append(self._ground_truth(cam, rot, side, ball))
        if n_lines:
            ends = np.concatenate([polar[n_points : n_points + n_lines], polar[n_points + n_lines :]], axis=1)
            out.append(_LINE * n_lines % tuple(ends.ravel().tolist()))
        out.append(")")
        return "".join(out)

    def _with_noise(self, polar: np.ndarray) -> np.ndarray:
        if not self._noise:
            return polar
        c = self._cfg
        e = self._rng.standard_normal(polar.shape)
        scale = np.array([0.0, c.h_sigma_deg, c.v_sigma_deg])
        noisy = polar + e * scale
        noisy[:, 0] = polar[:, 0] * (1.0 + e[:, 0] * (c.distance_sigma_percent / 100.0))
        return noisy

    def _players(
        self, robots: Sequence[SeenRobot], owners: list[tuple[int, str]], flat: list[float], visible: list[bool]
    ) -> list[str]:
        """``(P ...)`` of each robot with a part in view; ``flat`` holds (d, h, v) per owner."""
        seen: dict[int, list[str]] = {}
        for k, ((i, part), ok) in enumerate(zip(owners, visible)):
            if ok:
                seen.setdefault(i, []).append(_NAMED_POL % (part, flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]))
        return [f" (P (team {robots[i].team}) (id {robots[i].unum}){''.join(parts)})" for i, parts in seen.items()]

    def _ground_truth(self, cam: np.ndarray, rot: np.ndarray, side: str, ball: Vec3) -> str:
        """``mypos`` is the head centre, ``myorien`` the heading of the head's forward axis; the
        right team gets them mirrored through the field centre (x and y negated)."""
        s = -1.0 if side == "right" else 1.0
        heading = math.degrees(math.atan2(s * rot[1, 1], s * rot[0, 1]))
        return (
            f" (mypos {s * cam[0]:.2f} {s * cam[1]:.2f} {cam[2]:.2f})"
            f" (myorien {heading:.2f})"
            f" (ballpos {s * ball[0]:.2f} {s * ball[1]:.2f} {ball[2]:.2f})"
        )


@njit(cache=True)
def _polar_row(x: float, y: float, z: float, out: np.ndarray, k: int) -> None:
    """(distance, horizontal deg, vertical deg) of one head-frame point into ``out[k]``."""
    flat = np.hypot(x, y)
    out[k, 0] = np.hypot(flat, z)
    out[k, 1] = np.arctan2(-x, y) * (180.0 / np.pi)
    out[k, 2] = np.arctan2(z, flat) * (180.0 / np.pi)


@njit(cache=True)
def _view(
    fixed: np.ndarray,
    moving: np.ndarray,
    cam: np.ndarray,
    rot: np.ndarray,
    offset: np.ndarray,
    planes_t: np.ndarray,
    n_land: int,
    n_lines: int,
    min_distance: float,
    half_h: float,
    half_v: float,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The camera's exact view, before noise, in one compiled pass (numpy took ~30 small calls).

    ``fixed`` holds the landmarks, then the field lines' starts, then their ends; ``moving`` the
    ball and the robots' parts. Returns (polar rows: landmarks, moving points, then the starts and
    the ends of the visible line pieces; which points lie in the view cone; how many lines show).

    Points are moved to the head frame (x right, y forward, z up) with the robot's calibration
    offset. Each line a + t (b - a), t in [0, 1], is cut to the view pyramid: the signed distance
    to each side plane is linear in t, so every plane bounds t from below or above, and the line
    shows where the bounds leave an interval."""
    n_fixed = fixed.shape[0]
    total = n_fixed + moving.shape[0]
    head = np.empty((total, 3))
    for i in range(total):
        src = fixed[i] if i < n_fixed else moving[i - n_fixed]
        dx, dy, dz = src[0] - cam[0], src[1] - cam[1], src[2] - cam[2]
        for j in range(3):
            head[i, j] = dx * rot[0, j] + dy * rot[1, j] + dz * rot[2, j] + offset[j]
    n_points = n_land + moving.shape[0]
    kept_a = np.empty((n_lines, 3))
    kept_b = np.empty((n_lines, 3))
    shown = 0
    for line in range(n_lines):
        a = head[n_land + line]
        b = head[n_land + n_lines + line]
        t0, t1, outside = 0.0, 1.0, False
        for p in range(planes_t.shape[1]):
            da = a[0] * planes_t[0, p] + a[1] * planes_t[1, p] + a[2] * planes_t[2, p]
            db = b[0] * planes_t[0, p] + b[1] * planes_t[1, p] + b[2] * planes_t[2, p]
            if da < 0.0 and db < 0.0:
                outside = True
            elif da < 0.0:
                t0 = max(t0, da / (da - db))
            elif db < 0.0:
                t1 = min(t1, da / (da - db))
        if outside or t0 > t1:
            continue
        for j in range(3):
            step = b[j] - a[j]
            kept_a[shown, j] = a[j] + t0 * step
            kept_b[shown, j] = a[j] + t1 * step
        shown += 1
    polar = np.empty((n_points + 2 * shown, 3))
    visible = np.empty(n_points, dtype=np.bool_)
    for k in range(n_points):
        i = k if k < n_land else k + 2 * n_lines  # the moving points follow the line ends
        _polar_row(head[i, 0], head[i, 1], head[i, 2], polar, k)
        visible[k] = polar[k, 0] >= min_distance and abs(polar[k, 1]) <= half_h and abs(polar[k, 2]) <= half_v
    for k in range(shown):
        _polar_row(kept_a[k, 0], kept_a[k, 1], kept_a[k, 2], polar, n_points + k)
        _polar_row(kept_b[k, 0], kept_b[k, 1], kept_b[k, 2], polar, n_points + shown + k)
    return polar, visible, shown


def warm_up() -> None:
    """Compile (or load from numba's disk cache) the view kernel now rather than in the first
    vision cycle of a run."""
    VisionSensor(np.random.default_rng(0)).see((0.0, 0.0, 0.5), np.eye(3), "left", (1.0, 0.0, 0.04), ())
