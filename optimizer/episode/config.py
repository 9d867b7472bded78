"""What an episode is: where it starts, how long it walks, when the robot counts as fallen, and
what it gives back."""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

from agent import AgentConfig
from gait import DEFAULT_FAMILY, family_named
from protocol.nao import ROBOT_TYPES

if TYPE_CHECKING:
    from optimizer.episode.course import Course

#: A start point on the field: x, y (m) and heading (deg, 0 = +x).
Start = tuple[float, float, float]

#: Where walks start unless told otherwise: 5 m into the own half, facing the opponent goal. Not
#: the paper's x = y = 0: that is the origin of the measurement (the distance is counted from where
#: the torso stands at PlayOn), not a field position. A real server's referee moves a left-team
#: robot whose body reaches into the right half (x > 0) 2.5 m back before kick-off, so a walk
#: beamed to (0, 0) would start at about x = -2.5 while the trainer believes it at 0. From x = -5
#: the fastest walks known (0.9 m/s for 15 s) end near x = 8.5, inside the 15 m half.
DEFAULT_START: Start = (-5.0, 0.0, 0.0)

#: The agent's command dither (rad/s) the optimizer walks with by default: the amplitude at which
#: the stand-in's walk-to-walk spread matches the real server's own (docs/optimizer.md, "The
#: dither's calibration"; ``bench/calibrate_dither.py``).
CALIBRATED_COMMAND_NOISE = 1e-6

#: The left team's robot must stay this far behind the centre line to be left alone before
#: kick-off on a real server (its colliders reach ~0.15 m from the torso; the referee moves any
#: robot whose bounding box enters the right half).
_REFEREE_MARGIN = 0.5


def start_problem_on_real_server(start: Start) -> str | None:
    """Why a real server would not leave a robot beamed to ``start`` where it was put (None when
    it would): its referee clears the opponent half before kick-off."""
    if start[0] > -_REFEREE_MARGIN:
        return (
            f"x = {start[0]:g} m: a real server's referee moves a left-team robot within "
            f"{_REFEREE_MARGIN:g} m of the centre line (or past it) 2.5 m back before kick-off, so the walk "
            f"would not start there; start at x <= {-_REFEREE_MARGIN:g} (default {DEFAULT_START[0]:g})"
        )
    return None


def parked_ball(sx: float, sy: float) -> tuple[float, float, float]:
    """Where an episode's trainer puts the ball as the walk starts (start at ``sx, sy``): 5 m to
    its side, on the ground, out of a straight walk's way."""
    return (sx, sy + 5.0, 0.042)


@dataclass(frozen=True)
class EpisodeConfig:
    #: Seconds of walking (game time after PlayOn) before the walk is scored (paper: 15 s).
    walk_time: float = 15.0
    #: Start point (x, y) and heading (deg, 0 = +x) on the field: where the robot is beamed, and
    #: the direction along which its distance is measured (from where its torso is at PlayOn).
    start: tuple[float, float] = DEFAULT_START[:2]
    heading: float = DEFAULT_START[2]
    #: "inprocess": a fresh ``agent.NaoAgent`` per episode in this process, over the same socket
    #: protocol (fast, default); "process": a fresh ``python -m agent`` process per episode.
    agent_mode: str = "inprocess"
    #: How an in-process agent meets the runner's own embedded stub (no server given):
    #: "inprocess": the stub's core and the agent's behaviour driven in this process, no sockets and
    #: no text (``optimizer.episode.inprocess``; the same results, several times faster; default);
    #: "socket": a ``python -m server_stub`` process over TCP, as any other server.
    embedded_stub: str = "inprocess"
    #: Wall seconds an episode may take before the server or agent is declared hung.
    episode_timeout: float = 60.0
    team: str = "GALA"
    unum: int = 1
    #: Settle cycle at which the agent repeats its beam (None: never); part of how a walk starts,
    #: and the real server's walk depends on it (``agent.AgentConfig.rebeam_cycle``).
    rebeam_cycle: int | None = AgentConfig.rebeam_cycle
    #: Fall rule (community run benchmark): torso up-vector z below / torso height below.
    fall_up_z: float = 0.6
    fall_height: float = 0.25
    #: The agent's dither of its velocity commands while walking (rad/s; 0: none) and its seed,
    #: ``agent.AgentConfig.command_noise``: the fidelity benchmark draws from a walk's chaotic
    #: spread with it. ``EpisodeRunner.evaluate(seed=...)`` sets the seed per episode.
    command_noise: float = 0.0
    noise_seed: int = 0
    #: Fitness per metre of sideways drift taken off each metre walked: a walk's fitness is
    #: 10 x (distance - drift_penalty x |drift|), the drift measured from the line the walk started
    #: on (``scoring.sideways_drift``). 0: eq. 9 exactly. A straight walk is what a game needs.
    drift_penalty: float = 0.0
    #: The gait family whose genes the runner is given (``gait.FAMILIES``; a ``Gait`` names its own).
    family: str = DEFAULT_FAMILY
    #: The heterogeneous robot type walked (0: nao.rsg; 1-4: nao_hetero.rsg, 4 with toes).
    robot_type: int = 0
    #: What a walk is scored by (``optimizer.episode.objectives``): "distance", the paper's eq. 9
    #: (the default), or "course", the time to walk ``course`` (``on_course`` sets both).
    objective: str = "distance"
    course: Course | None = None
    #: A course walker's pose: the server's ``mypos``/``myorien`` where it sends them (True), or
    #: always the agent's own estimate from vision and odometry (False).
    true_pose: bool = True
    #: One command a steerable gait walks (forward m/s, left m/s, turn deg/s) instead of its own:
    #: how a walk engine's speeds are measured (``bench.bench_course``). None: its own.
    command: tuple[float, float, float] | None = None

    @property
    def goals(self) -> tuple[tuple[float, float, float], ...]:
        """The poses the episode's agent walks to: its course's (none for a straight walk)."""
        return () if self.course is None else self.course.poses

    def on_course(self, course: Course) -> EpisodeConfig:
        """This config walking ``course``: beamed to its start, for at most its time limit."""
        x, y, heading = course.start
        return replace(
            self, objective="course", course=course, start=(x, y), heading=heading, walk_time=course.time_limit
        )

    def starting_at(self, start: Start) -> EpisodeConfig:
        """This config with another start point and heading."""
        x, y, heading = start
        return replace(self, start=(float(x), float(y)), heading=float(heading))

    def __post_init__(self) -> None:
        if not self.walk_time > 0:
            raise ValueError(f"walk_time must be > 0 s, got {self.walk_time}")
        family_named(self.family)  # an unknown family is refused here, not in a worker
        if not self.drift_penalty >= 0:
            raise ValueError(f"drift_penalty must be >= 0, got {self.drift_penalty}")
        if self.agent_mode not in ("inprocess", "process"):
            raise ValueError(f"agent_mode must be 'inprocess' or 'process', got {self.agent_mode!r}")
        if self.embedded_stub not in ("inprocess", "socket"):
            raise ValueError(f"embedded_stub must be 'inprocess' or 'socket', got {self.embedded_stub!r}")
        if not self.episode_timeout > 0:
            raise ValueError(f"episode_timeout must be > 0 s, got {self.episode_timeout}")
        last = AgentConfig.settle_cycles - 1
        if self.rebeam_cycle is not None and not 0 <= self.rebeam_cycle <= last:
            raise ValueError(f"rebeam_cycle must be a settle cycle 0-{last} or None, got {self.rebeam_cycle}")
        if not self.command_noise >= 0:
            raise ValueError(f"command_noise must be >= 0 rad/s, got {self.command_noise}")
        if self.robot_type not in ROBOT_TYPES:
            raise ValueError(f"robot_type must be one of {ROBOT_TYPES}, got {self.robot_type}")
        if (self.objective == "course") != (self.course is not None):
            raise ValueError(f"objective {self.objective!r} with {'a' if self.course else 'no'} course")


@dataclass(frozen=True)
class EpisodeResult:
    distance: float
    fell: bool
    time: float
    fitness: float
    mean_speed: float
    status: str = "ok"
    reason: str = ""
    wall: float = 0.0
    #: Where a traced walk (``EpisodeRunner.evaluate(trace=True)``) went besides forward: metres
    #: it ended left (+) of its start line, degrees it turned (left +), and the torso's track
    #: (``scoring.TRACK_FIELDS``, every ``scoring.TRACK_EVERY``-th monitor state and the last).
    #: None for an untraced walk: the search does not pay for them.
    drift: float | None = None
    heading_change: float | None = None
    track: tuple[tuple[float, ...], ...] | None = None
    #: A course walk's outcome (``optimizer.episode.course``): whether it reached every pose, how
    #: many it reached, and the game time at which it reached each. None for other walks.
    finished: bool | None = None
    reached: int | None = None
    legs: tuple[float, ...] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The result's fields; a walk that was not a course's leaves out the course's."""
        document = asdict(self)
        if self.finished is None:
            for name in ("finished", "reached", "legs"):
                del document[name]
        return document

    @classmethod
    def failed(cls, reason: str, wall: float) -> EpisodeResult:
        """An episode the infrastructure could not run; fitness 0 so that the search goes on."""
        return cls(0.0, False, 0.0, 0.0, 0.0, "failed", reason, wall)
