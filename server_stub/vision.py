"""The ``See`` perceptor: what the NAO's head camera reports, as rcssserver3d 0.7.3 prints it.

Grammar of the text produced (facts sheet section 5; fixture ``agent_perceptions_first20.txt``)::

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

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class VisionConfig:
    """Camera and noise of the real vision perceptor (facts sheet section 5, naoneckhead.rsg)."""

    half_cone_h_deg: float = 60.0
    half_cone_v_deg: float = 60.0
    min_distance: float = 0.1
    #: distance x (1 + N(0, sigma)/100)
    distance_sigma_percent: float = 0.0965
    h_sigma_deg: float = 0.1480
    v_sigma_deg: float = 0.1225
    #: fixed per-robot offset, uniform in +-this on each axis of every relative position (m)
    calibration_error: float = 0.005


# Facts sheet section 7. Order: as the fixtures list the objects they show.
LANDMARKS: tuple[tuple[str, Vec3], ...] = (
    ("G1L", (-15.0, 1.05, 0.8)), ("G2L", (-15.0, -1.05, 0.8)),
    ("G2R", (15.0, -1.05, 0.8)), ("G1R", (15.0, 1.05, 0.8)),
    ("F1L", (-15.0, 10.0, 0.0)), ("F2L", (-15.0, -10.0, 0.0)),
    ("F1R", (15.0, 10.0, 0.0)), ("F2R", (15.0, -10.0, 0.0)),
)
#: Body parts of a robot the camera reports, in the server's order inside ``P``.
PLAYER_PARTS: tuple[str, ...] = ("head", "rlowerarm", "llowerarm", "rfoot", "lfoot")


def _field_lines() -> tuple[tuple[Vec3, Vec3], ...]:
    half_len, half_wid = 15.0, 10.0
    box_front, box_half = 15.0 - 1.8, 3.0
    lines: list[tuple[Vec3, Vec3]] = [
        ((0.0, half_wid, 0.0), (0.0, -half_wid, 0.0)),
        ((half_len, -half_wid, 0.0), (half_len, half_wid, 0.0)),
        ((-half_len, -half_wid, 0.0), (-half_len, half_wid, 0.0)),
        ((half_len, half_wid, 0.0), (-half_len, half_wid, 0.0)),
        ((half_len, -half_wid, 0.0), (-half_len, -half_wid, 0.0)),
    ]
    for s in (-1.0, 1.0):
        lines += [
            ((s * box_front, box_half, 0.0), (s * box_front, -box_half, 0.0)),
            ((s * box_front, box_half, 0.0), (s * half_len, box_half, 0.0)),
            ((s * box_front, -box_half, 0.0), (s * half_len, -box_half, 0.0)),
        ]
    corners = [(2.0 * math.cos(math.radians(36 * k)), 2.0 * math.sin(math.radians(36 * k)), 0.0)
               for k in range(11)]
    lines += [(corners[k], corners[k + 1]) for k in range(10)]
    return tuple(lines)


FIELD_LINES: tuple[tuple[Vec3, Vec3], ...] = _field_lines()


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

    def __init__(self, rng: np.random.Generator, noise: bool = True, sense_mypos: bool = False,
                 config: VisionConfig = VisionConfig()) -> None:
        self._rng = rng
        self._noise = noise
        self._sense_mypos = sense_mypos
        self._cfg = config
        self._offset = (rng.uniform(-config.calibration_error, config.calibration_error, 3)
                        if noise else np.zeros(3))
        #: what never moves, in the order ``see`` transforms it: landmarks, line starts, line ends
        self._fixed = np.array([p for _, p in LANDMARKS] + [a for a, _ in FIELD_LINES]
                               + [b for _, b in FIELD_LINES], dtype=float)
        self._n_lines = len(FIELD_LINES)
        h, v = math.radians(config.half_cone_h_deg), math.radians(config.half_cone_v_deg)
        # Inward normals of the 4 sides of the view pyramid (head frame x right, y fwd, z up).
        self._planes_t = np.array([
            [math.cos(h), math.sin(h), 0.0], [-math.cos(h), math.sin(h), 0.0],
            [0.0, math.sin(v), -math.cos(v)], [0.0, math.sin(v), math.cos(v)],
        ]).T

    def see(self, camera_pos: Vec3, camera_rot: np.ndarray, side: str, ball: Vec3,
            robots: Sequence[SeenRobot]) -> str:
        """The ``(See ...)`` entry. ``camera_rot``: 3x3 world rotation of the head (columns = head
        x right, y forward, z up); ``side`` ('left'/'right') only mirrors the ground truth
        (``mypos``, ``myorien``, ``ballpos``); ``robots`` includes the observer itself."""
        cam = np.asarray(camera_pos, dtype=float)
        rot = np.asarray(camera_rot, dtype=float)
        # One batch: landmarks, ball, every robot part, then the ends of the visible lines.
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
        head = self._to_head(np.concatenate([self._fixed, np.array(moving, dtype=float)]), cam, rot)
        line_a, line_b = self._clip_lines(head[n_land:n_land + self._n_lines],
                                          head[n_land + self._n_lines:n_land + 2 * self._n_lines])
        n_lines = len(line_a)
        exact = self._polar(np.concatenate([head[:n_land], head[n_land + 2 * self._n_lines:], line_a, line_b]))
        visible = self._in_view(exact[:n_points]).tolist()   # the cone cuts before the noise
        polar = self._with_noise(exact)

        out = ["(See"]
        flat = polar[:n_points].ravel().tolist()
        for k, (name, _) in enumerate(LANDMARKS):
            if visible[k]:
                out.append(_NAMED_POL % (name, flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]))
        if visible[n_land]:
            out.append(_NAMED_POL % ("B", flat[3 * n_land], flat[3 * n_land + 1], flat[3 * n_land + 2]))
        out.extend(self._players(robots, owners, flat[3 * (n_land + 1):], visible[n_land + 1:]))
        if self._sense_mypos:
            out.append(self._ground_truth(cam, rot, side, ball))
        if n_lines:
            ends = np.concatenate([polar[n_points:n_points + n_lines], polar[n_points + n_lines:]], axis=1)
            out.append(_LINE * n_lines % tuple(ends.ravel().tolist()))
        out.append(")")
        return "".join(out)

    def _to_head(self, world: np.ndarray, cam: np.ndarray, rot: np.ndarray) -> np.ndarray:
        return (world - cam) @ rot + self._offset

    @staticmethod
    def _polar(rel: np.ndarray) -> np.ndarray:
        """(d, h, v) per row of head-frame points."""
        x, y, z = rel[:, 0], rel[:, 1], rel[:, 2]
        flat = np.hypot(x, y)
        out = np.empty_like(rel)
        out[:, 0] = np.hypot(flat, z)
        out[:, 1] = np.arctan2(-x, y)
        out[:, 2] = np.arctan2(z, flat)
        out[:, 1:] *= 180.0 / math.pi
        return out

    def _with_noise(self, polar: np.ndarray) -> np.ndarray:
        if not self._noise:
            return polar
        c = self._cfg
        e = self._rng.standard_normal(polar.shape)
        scale = np.array([0.0, c.h_sigma_deg, c.v_sigma_deg])
        noisy = polar + e * scale
        noisy[:, 0] = polar[:, 0] * (1.0 + e[:, 0] * (c.distance_sigma_percent / 100.0))
        return noisy

    def _in_view(self, polar: np.ndarray) -> np.ndarray:
        c = self._cfg
        return ((polar[:, 0] >= c.min_distance) & (np.abs(polar[:, 1]) <= c.half_cone_h_deg)
                & (np.abs(polar[:, 2]) <= c.half_cone_v_deg))

    def _players(self, robots: Sequence[SeenRobot], owners: list[tuple[int, str]],
                 flat: list[float], visible: list[bool]) -> list[str]:
        """``(P ...)`` of each robot with a part in view; ``flat`` holds (d, h, v) per owner."""
        seen: dict[int, list[str]] = {}
        for k, ((i, part), ok) in enumerate(zip(owners, visible)):
            if ok:
                seen.setdefault(i, []).append(_NAMED_POL % (part, flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]))
        return [f" (P (team {robots[i].team}) (id {robots[i].unum}){''.join(parts)})"
                for i, parts in seen.items()]

    def _ground_truth(self, cam: np.ndarray, rot: np.ndarray, side: str, ball: Vec3) -> str:
        """``mypos`` is the head centre, ``myorien`` the heading of the head's forward axis; the
        right team gets them mirrored through the field centre (x and y negated)."""
        s = -1.0 if side == "right" else 1.0
        heading = math.degrees(math.atan2(s * rot[1, 1], s * rot[0, 1]))
        return (f" (mypos {s * cam[0]:.2f} {s * cam[1]:.2f} {cam[2]:.2f})"
                f" (myorien {heading:.2f})"
                f" (ballpos {s * ball[0]:.2f} {s * ball[1]:.2f} {ball[2]:.2f})")

    def _clip_lines(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ends (head frame) of the field lines from ``a`` to ``b`` cut to the view pyramid. Each
        line is a + t (b - a), t in [0, 1]; every side plane bounds t from below or above (the
        plane's signed distance is linear in t), and a line is visible where the bounds leave an
        interval."""
        da, db = a @ self._planes_t, b @ self._planes_t          # (lines, planes)
        a_out, b_out = da < 0.0, db < 0.0
        diff = da - db
        diff[diff == 0.0] = 1.0  # a line parallel to a plane: its crossing is never used
        cross = da / diff
        t0 = np.where(a_out & ~b_out, cross, 0.0).max(axis=1)
        t1 = np.where(b_out & ~a_out, cross, 1.0).min(axis=1)
        keep = ~(a_out & b_out).any(axis=1) & (t0 <= t1)
        a, step = a[keep], b[keep] - a[keep]
        return a + t0[keep, None] * step, a + t1[keep, None] * step
