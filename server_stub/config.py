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
    #: pybullet sub-steps per cycle (0 and 1 both mean one step of ``cycle``).
    sub_steps: int = 1
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
    inertia_floor: float = 0.0
    global_cfm: float = 1e-5

    # --- contacts (facts section 4: robot soft ERP 0.6 / CFM 1e-4, ground ERP 0.2, averaged) ---
    #: ODE contact ERP/CFM of a robot part on the ground, turned into a spring-damper:
    #: k = ERP / (CFM h), d = (1 - ERP) / CFM (same stiffness for any step size h).
    contact_erp: float = 0.4
    contact_cfm: float = 1e-4
    contact_breaking_threshold: float = 0.002
    lateral_friction: float = 1.0
    rolling_friction: float = 0.0
    spinning_friction: float = 0.0
    restitution: float = 0.0

    # --- bodies and motors (facts sections 2-3) ---
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
