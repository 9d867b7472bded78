"""Configuration of the stand-in server: every setting in one dataclass per concern."""
from __future__ import annotations

from dataclasses import dataclass

from protocol.nao import CYCLE, TORQUE_LIMIT


@dataclass(frozen=True)
class PhysicsConfig:
    """pybullet settings of the simulated world. Targets, in order: the real server's numbers
    (NAO_MODEL_FACTS.md sections 3-4 and the calibration walk), then speed. Each comment gives
    the measured reason (probe scripts ran the calibration gait; "walk" = dx in 15 s)."""

    # --- timing (facts section 4: one 0.02 s ODE step per cycle, no sub-steps) ---
    cycle: float = CYCLE
    #: pybullet sub-steps per cycle, run one by one by World.step so the slip force below is
    #: renewed each sub-step. (Before, pybullet ran 2 internal sub-steps of one 0.02 s call,
    #: which also capped each motor's impulse per sub-step at 10 N m x 0.02 s, i.e. 20 N m.)
    #: 3, unlike ODE's 1. Walk probe = the calibration gait from 24 perturbed starts (rebeam
    #: cycle 10-14 or none, beams 0 or 1 step late, heading +-1 deg, anywhere on the own half,
    #: first beam after 2-4 steps); "ok" = no fall and 3.0 m +-15%. 1 sub-step: best 24/24
    #: (slip_mass 1.1) but its neighbours 0.9 / 1.2 / 1.4 gave 15 / 22 / 22 (falls, one run shot
    #: off 20 m: the explicit damper is near its stability limit). 2 sub-steps: 24/24 for
    #: slip_mass 0.4-0.5, but a beamed robot landed with its ankles yielding 1.4 deg and never
    #: came to rest, reading ACC y -0.24 and GYR x -10 deg/s for ever (real: 0): the slip force
    #: on each foot flips between +2.1 and -2.1 N every sub-step (the damper's period-2
    #: oscillation), and a contact ERP matched to 3 sub-steps (0.308) did not cure it.
    #: 3 sub-steps: 24/24 for slip_mass 0.25 / 0.3 / 0.35, resting upright (ACC (0, 0, 9.81),
    #: GYR 0). Robustness over speed: 3 costs about 1.45x the time of 2 and 2.5x that of 1
    #: (0.41 / 0.28 / 0.16 ms a walking cycle). A robust single step needs the slip inside the
    #: constraint solver, as ODE has it (friction rows with CFM = slip); pybullet exposes only a
    #: global CFM, which would soften the motors and contacts as well (tried: the robot sagged
    #: to 0.366 m and fell backwards in every start).
    sub_steps: int = 3
    gravity: float = -9.81

    # --- solver ---
    #: "dantzig": pybullet's exact MLCP solver, like ODE's dWorldStep (section 4). Measured: a
    #: beamed NAO with zero motor speeds keeps every joint within 0.01 deg for 15 s; with the
    #: iterative "pgs" solver it sags and falls within 1.5 s even at 100 iterations (20 would need
    #: an inertia floor and still drifts), because the motor rows along the leg chains converge
    #: slowly.
    solver: str = "dantzig"
    #: iterations for "pgs" (and the Dantzig solver's fallback when it fails).
    solver_iterations: int = 20
    #: rotational-inertia floor on every link, kg m^2 (a crutch for "pgs"; 0 = the model's own).
    #: With Dantzig, floors of 1e-4 and 1e-3 made the walk fall more often than 0 (grid above).
    inertia_floor: float = 0.0
    #: world CFM of the real server (section 4).
    global_cfm: float = 1e-5

    # --- contacts (facts section 4: robot soft ERP 0.6 / CFM 1e-4, ground ERP 0.2, averaged) ---
    #: ODE contact ERP/CFM of a robot part on the ground (robot ERP 0.6 and ground ERP 0.2
    #: averaged; CFM 1e-4 from the robot side only), turned into a spring-damper set on every
    #: robot link: k = ERP / (CFM h) = 2e5 N/m, d = (1 - ERP) / CFM = 6000 N s/m (Bullet turns
    #: k, d back into the same ERP/CFM per (sub-)step). Measured: standing, each foot carries
    #: 22.60 N and the torso rests at 0.385 m (real 22.59 N, 0.383 m). In the walk grid a stiffer
    #: CFM 1e-5 fell in 1 of 4 runs, a softer ERP 0.2 / CFM 1e-3 turned or fell.
    contact_erp: float = 0.4
    contact_cfm: float = 1e-4
    #: distance (m) within which Bullet keeps a contact point. 0.002 (default 0.02): ODE only
    #: makes contacts for touching geometry (surface layer 0.001 m); in the walk grid 0.002 beat
    #: 0.001, 0.003, 0.004 and the default (falls or turning walks).
    contact_breaking_threshold: float = 0.002
    #: Coulomb mu of robot parts (the ground has 1; Bullet multiplies them). 0: the real server has
    #: no Coulomb limit (mu infinite) and its tangential contact force comes from force-dependent
    #: slip alone, emulated by ``slip`` / ``slip_mass``. Measured (walk probe above): Coulomb
    #: friction was what made the walk fragile. With mu 0.5 alone, 2 of 12 starts walked
    #: 3.0 m +-15% and 6 fell (rebeam at cycle 12: 3.37 m, at 13: 0.56 m, beam 1 step late:
    #: fell); mu >= 1 always fell backwards; adding mu 0.1 / 0.2 on top of the slip damper
    #: brought back falls (1-3 of 12).
    lateral_friction: float = 0.0
    #: force-dependent slip of every contact point in both tangential directions, (m/s) per N
    #: (facts section 4, ODE's dContactSlip1/2): a point slides at slip x its tangential force,
    #: i.e. friction is a viscous damper of 1 / slip = 200 N s/m per contact point.
    slip: float = 0.005
    #: effective mass (kg) per contact point in the semi-implicit damper F = -v / (slip + h / m)
    #: (h = sub-step; ``Robot._before_substep``). It caps the damper at what stops a point of
    #: mass m in one sub-step: 36.7 N s/m per point (0.3 kg, h = 1/150 s) instead of the real 200,
    #: which an explicit force cannot reach stably. Walk probe, damper strength per point:
    #: 22 N s/m: 0/12 ok (2.17-2.53 m, slides too much); 33-41: 24/24 (2.59-3.16 m);
    #: 55-66: falls in 2-3 of 12-24; 100+: unstable. Applying the damper also to Bullet's
    #: points that carry no load (kept up to 2 mm apart) dragged the swing foot: 0 of 12 ok.
    slip_mass: float = 0.3
    #: ODE has neither rolling nor spinning friction (spinning friction 0.002-0.01 changed nothing
    #: in the walk with Coulomb friction; the MLCP solver ignores it).
    rolling_friction: float = 0.0
    spinning_friction: float = 0.0
    #: bounce off (facts section 4).
    restitution: float = 0.0

    # --- bodies and motors (facts sections 2-3) ---
    #: drag 0.01 on every body (section 2; Bullet's damping form differs slightly: m d (1+|v|) v).
    linear_damping: float = 0.01
    angular_damping: float = 0.01
    motor_torque: float = TORQUE_LIMIT
    #: joint stop: ERP 0.8, bounce 1 (fully elastic), applied when a joint starts a step outside
    #: its range, as ODE's limit rows are.
    stop_erp: float = 0.8
    stop_bounce: float = 1.0

    @property
    def contact_stiffness(self) -> float:
        return self.contact_erp / (self.contact_cfm * self.cycle)

    @property
    def contact_damping(self) -> float:
        return (1.0 - self.contact_erp) / self.contact_cfm


@dataclass(frozen=True)
class ServerConfig:
    """Network, timing and sensing options of the stand-in server (``python -m server_stub``)."""

    #: Listen address: loopback unless told otherwise (the real server binds all interfaces).
    host: str = "127.0.0.1"
    #: 0 picks a free port (tests, optimizer workers); the chosen ports are printed on start.
    agent_port: int = 3100
    monitor_port: int = 3200
    #: Sync mode: a cycle runs once every agent has answered its last perception with ``(syn)``.
    sync: bool = False
    #: Pace cycles at 50 Hz wall clock; the real server's default. Off: as fast as agents answer.
    realtime: bool = True
    #: Add ``mypos`` / ``myorien`` / ``ballpos`` to vision (off on the real server by default).
    sense_mypos: bool = False
    vision_noise: bool = True
    seed: int = 0
    #: Sync mode waits this long (wall s) for a ``(syn)`` before stepping anyway, as the real
    #: server's 1-s waits do; keeps an agent that sends ``init`` without ``(syn)`` working.
    sync_grace: float = 1.0
    #: An agent silent this long (wall s) is disconnected, so a hung client never freezes others.
    agent_timeout: float = 10.0
    #: Largest frame accepted from a client; a longer length prefix disconnects it.
    max_frame: int = 1 << 20
    #: Bytes a client may leave unread before it is disconnected (agent) or skipped (monitor).
    agent_out_cap: int = 8 << 20
    monitor_out_cap: int = 1 << 20
    #: Cycles between monitor updates (0.04 s) and between vision messages (0.06 s), facts section 4.
    monitor_interval: int = 2
    vision_interval: int = 3
    #: Exit when this process is no longer our parent (0: never). A worker that starts a stub and
    #: is killed (SIGKILL leaves no chance to clean up) must not leave the stub behind.
    parent_pid: int = 0
