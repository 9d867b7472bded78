"""Configuration of the stand-in server: every setting in one dataclass per concern."""

from __future__ import annotations

import os
from dataclasses import dataclass, field

from protocol.nao import CYCLE, TORQUE_LIMIT


@dataclass(frozen=True)
class PhysicsConfig:
    """pybullet settings of the simulated world. Targets, in order: the real server's numbers
    (docs/robot_and_server.md sections 3-4 and the calibration walk), then speed. Each comment gives
    the measured reason (probe scripts ran the calibration gait; "walk" = dx in 15 s)."""

    # --- timing (docs/robot_and_server.md section 4: one 0.02 s ODE step per cycle, no sub-steps) ---
    cycle: float = CYCLE
    #: "bullet" backend only (the ODE step takes one step per cycle, as the real server): pybullet
    #: steps per cycle (World.step runs them one by one, the slip force renewed before
    #: each). 1, as ODE. Walk probe = the calibration gait from 72 perturbed starts (rebeam cycle
    #: 10-14 or none, beams 0 or 1 step late, heading +-1 deg, anywhere on the own half, first
    #: beam after 2-4 steps); "ok" = no fall and 3.0 m +-15%. Flail probe = 336 robots driven
    #: by random motor speeds for 20 s (falling, lying, kicking); "blow-up" = torso over 5 m/s.
    #: (``python bench/probe_physics.py walk|flail``.) With this model: walk 72/72 ok over three
    #: draws of starts (2.97-3.35 m, sideways <= 0.85 m), flail 0 blow-ups in 336 (torso
    #: <= 2.6 m/s). 2 and 3 steps per cycle walked worse with the same model (19/24 and 13/24 ok,
    #: 5 and 10 falls) and cost 1.7x / 2.4x the time. The model before this one (plane ground,
    #: a damper per point) needed 3 steps per cycle to walk 24/24 and ran at 45x in
    #: bench_physics; this one runs at 77x (its slip solve compiled, ``server_stub.physics.slip``).
    sub_steps: int = 1
    gravity: float = -9.81

    # --- backend ---
    #: "ode" (default): one ODE-like step per cycle solved by the stub itself, contacts, slip
    #: friction and motors in one LCP (``server_stub.physics.ode_step``; with ``ode_maximal``, as
    #: ODE's own dWorldStep). "bullet": Bullet's multibody step with slip solved beside it
    #: (``server_stub.physics.slip``), the default before: it matches the real server standing and
    #: on the slow walk, but not at walking speed (fidelity benchmark: Spearman -0.09, fall
    #: agreement 0.52; it walks from starts where the real server falls). The environment
    #: variable ``NAO_STUB_PHYSICS`` picks the default, so stand-ins started in subprocesses (the
    #: fidelity benchmark's) follow it.
    backend: str = field(default_factory=lambda: os.environ.get("NAO_STUB_PHYSICS", "ode"))
    #: "ode" backend only: joint stops as ODE's limit rows (one-sided; the motor pushing into the
    #: stop with its full torque), not as the "bullet" backend's two-sided stop motor. Training
    #: set (bench/RESULTS.md): no change either way.
    ode_limits: bool = field(default_factory=lambda: os.environ.get("NAO_STUB_ODE_LIMITS", "1") == "1")
    #: "ode" backend only: contacts asked of ODE's colliders per pair, 1-4 (source: SimSpark's
    #: odespace.cpp asks dCollide for 4). A box meets the ground as ODE 0.16's box-plane collider
    #: makes it (``ode_kernels.box_plane``, equal to libode on 1,200 stored and 400 fresh random
    #: poses, ``tests/test_ode_colliders.py``): a flat foot at its 4 sole corners, a foot landing
    #: on an edge at 3 at most. Measured: taking every corner below the ground instead (4 on such a
    #: landing) kept a 6-Hz shuffle gait walking 8 of 8 times where the real server falls 8 of 8.
    ode_box_points: int = field(default_factory=lambda: int(os.environ.get("NAO_STUB_ODE_BOX_POINTS", "4")))
    #: "ode" backend's reduced step only: contacts found where ODE's bodies would be: each hinge's anchor copies
    #: drift apart and its child turns off the hinge by ODE's per-body integration, pulled back by
    #: its world ERP 0.2 (``ode_kernels.joint_drift``); the dynamics stay in exact joints.
    #: Measured on the real server's monitor stream (the 13.26 m gait): knees 3-6 mm apart, as
    #: this model predicts; 0.02 mm standing. Off: see ``ode_true_inertia``.
    ode_joint_drift: bool = field(default_factory=lambda: os.environ.get("NAO_STUB_ODE_DRIFT", "0") == "1")
    #: "ode" backend's reduced step only (the maximal step always has them): the parts' true
    #: principal moments (docs section 2, uniform solids), not
    #: raised to ``inertia_floor`` (which Bullet's own solver needs). With this and the drift the
    #: 13.26 m gait's first 10 walking cycles match the real server's GYR and FRP to 1-2 deg/s,
    #: but over the fidelity sets they walk worse (training: Spearman 0.891 against 0.845 without
    #: both, median |1-ratio| 0.136 against 0.054, heading factor 2.7 against 2.4; held aside:
    #: 0.56 / 0.67 against 0.90 / 0.15), so both stay off until the dynamics, not only the
    #: contacts, have ODE's maximal coordinates.
    ode_true_inertia: bool = field(default_factory=lambda: os.environ.get("NAO_STUB_ODE_TRUE_INERTIA", "0") == "1")
    #: "ode" backend only: maximal coordinates, as ODE's dWorldStep (``server_stub.physics.ode_maximal``):
    #: every body integrated on its own (true inertias, no floor), each hinge held by ODE's 5 joint
    #: rows (world ERP ``ode_joint_erp``, world CFM ``global_cfm``) plus its motor or limit row;
    #: contacts as the reduced step makes them, from the bodies' own poses. Off: the reduced step.
    #: On by default (``NAO_STUB_ODE_MAX=0`` turns it off).
    #: One step equals libode 0.16.2's dWorldStep to 1e-10, contacts included. Measured (bench/RESULTS.md):
    #: standing 0.3839 m, 22.60 N a foot; knee anchors 3.4 / 5.6-5.8 mm apart (mean / max) on the
    #: 13.26 m gait (real 3.0-3.6 / 4.9-5.8); the calibration fixture's GYR within 1 deg/s of the
    #: real run for 100 cycles; training set Spearman 0.97-0.99, falls 0.88-0.91, median |1-ratio|
    #: 0.03-0.06 (reduced: 0.78-0.81 / 0.75-0.81 / 0.07-0.14), 106 of 128 walks inside the real
    #: server's own spread (reduced 61); walk probe: falls where the real server falls in 69 of 72
    #: starts (the real server falls from 31 of them; reduced 63, bullet 41); 0.30 ms a cycle.
    ode_maximal: bool = field(default_factory=lambda: os.environ.get("NAO_STUB_ODE_MAX", "1") == "1")
    #: ``ode_maximal`` only: the world ERP of the hinges' joint rows. SimSpark never sets it
    #: (spark.rb sets gravity, CFM, auto-disable and the surface layer only), so ODE's default 0.2.
    ode_joint_erp: float = 0.2
    #: ``ode_maximal`` only: ODE 0.16's gyroscopic torque, on for every body by default (dBodyCreate
    #: sets dxBodyGyroscopic; SimSpark never clears it) and computed implicitly ("implicit",
    #: step.cpp: (I (I - h [L]x)^-1 - 1) L / h, L = I w); "explicit" (-w x I w) for comparison.
    ode_gyroscopic: str = "implicit"
    #: ``ode_maximal`` only: contacts besides the ground (``server_stub.physics.ode_contacts``):
    #: robot-robot, robot-ball, robot-goal/border, ball-goal/border, and the ball as a body of the
    #: stub's own solve (its ground contact too); touching bodies are solved in one LCP
    #: (``ode_island``). Off: each robot against the ground only and Bullet steps the ball.
    ode_contacts: bool = field(default_factory=lambda: os.environ.get("NAO_STUB_ODE_CONTACTS", "1") == "1")
    #: The surfaces SimSpark gives each kind of collider, (soft ERP, soft CFM, slip, bounce, minimum
    #: bounce velocity), None where its ContactJointHandler leaves that mode off. Two surfaces
    #: combine as SimSpark's ContactJointHandlerImp::CalcSurfaceParamInternal does
    #: (plugin/odeimps/odecontactjointhandler.cpp): a value set on both sides is their mean, on one
    #: side that side's; a mode off on both leaves ODE's world value (ERP ``ode_joint_erp`` 0.2,
    #: CFM ``global_cfm`` 1e-5, no slip: friction CFM 1e-5, no bounce); mu is the mean of two
    #: infinities (every handler keeps Initialize()'s dInfinity), so friction is unbounded.
    #: Only the handler of ODE's first geom acts (ContactJointHandler::IsSymmetricHandler is
    #: false): one contact joint per point, up to 4 points a pair (odespace.cpp, nContacts = 4).
    #: A robot's own parts never collide (nao_hetero.rsg: its Space has disableInnerCollision).
    #: A robot part: rsg/agent/nao/contactjointhandler.rsg (bounce off, ERP 0.6, CFM 1e-4, slip 5e-3).
    ode_surface_robot: tuple = (0.6, 1e-4, 5e-3, None, None)
    #: The ball: rsg/agent/ball.rsg (bounce 0.8 above 0.8 m/s, slip 0.6, ERP 0.5, CFM 0.05).
    ode_surface_ball: tuple = (0.5, 0.05, 0.6, 0.8, 0.8)
    #: The ground: soccer.rsg's PlaneCollider (bounce off, ERP 0.2; its "setContactSoftCFM true"
    #: sets a value without the mode, so no CFM; "setContactSlip 0.1 0.1" fails, taking one
    #: argument (contactjointhandler_c.cpp), leaving the mode on with Initialize()'s 5e-3). The
    #: robot-ground contact keeps ``contact_erp`` / ``contact_cfm`` / ``slip``, the same mix.
    ode_surface_ground: tuple = (0.2, None, 5e-3, None, None)
    #: Goal boxes (goal.rsg: the two side "posts" 0.6 x 0.04 x 0.8 m, the back wall, the top
    #: plate) and the four border walls (soccer.rsg): BoxColliders with no handler, which
    #: Collider::PrePhysicsUpdateInternal gives a default ContactJointHandler (Initialize():
    #: mode bounce only, bounce 0.8, minimum bounce velocity 2.0). The goal's own box collider
    #: has a RecorderHandler and so no contact handler: it makes no contacts.
    ode_surface_static: tuple = (None, None, None, 0.8, 2.0)
    #: The ball's DragController (ball.rsg): linear 0.01, angular 5e-5; its mass and radius are
    #: naosoccersim.rb's BallMass 0.026 kg and BallRadius 0.042 m (``server_stub.field``), its
    #: inertia a solid sphere's (ball.rsg setSphereTotal: 2/5 m r^2).
    ode_ball_drag_linear: float = 0.01
    ode_ball_drag_angular: float = 5e-5

    # --- solver ---
    #: "bullet" backend only: "dantzig": pybullet's exact MLCP solver, like ODE's dWorldStep (section 4). Measured: a
    #: beamed NAO with zero motor speeds keeps every joint within 0.01 deg for 15 s; with the
    #: iterative "pgs" solver it sags and falls within 1.5 s even at 100 iterations (20 would need
    #: an inertia floor and still drifts), because the motor rows along the leg chains converge
    #: slowly.
    solver: str = "dantzig"
    #: "bullet" backend only: iterations for "pgs" (and the Dantzig solver's fallback when it fails).
    solver_iterations: int = 20
    #: "bullet" backend (and the reduced ODE step without ``ode_true_inertia``) only:
    #: rotational-inertia floor on every link, kg m^2 (a measured choice, standing in for geared
    #: rotor inertia, which the model lacks). Flail probe: 0 blow-ups; without it (the model's own tiny
    #: inertias, e.g. the hip and ankle links) 2-3 of 96 robots kicked at 5 m/s or exploded at
    #: one step per cycle (with friction off as well, so not the slip model's doing), and 1e-4
    #: still let 1 of 96 explode. Walk probe: 72/72 either way.
    inertia_floor: float = 1e-3
    #: world CFM of the real server (section 4; spark.rb's $physicsGlobalCFM). ``ode_maximal`` gives
    #: it to the hinges' 5 joint rows (ODE sets every joint row's CFM to the world's before the
    #: joint's own; SimSpark's hinge ``setCFM 0 1e-8`` is dParamCFM, the motor row's only).
    global_cfm: float = 1e-5

    # --- contacts (docs/robot_and_server.md section 4: robot soft ERP 0.6 / CFM 1e-4, ground ERP 0.2, averaged) ---
    #: ODE contact ERP/CFM of a robot part on the ground (robot ERP 0.6 and ground ERP 0.2
    #: averaged; CFM 1e-4 from the robot side only), turned into a spring-damper set on every
    #: robot link: k = ERP / (CFM h) = 2e5 N/m, d = (1 - ERP) / CFM = 6000 N s/m, which Bullet
    #: turns back into ERP 0.4 per step (its exact solver adds only the global CFM, so the
    #: contact's own CFM has no further effect). Measured: standing, each foot carries 22.60 N
    #: and the torso rests at 0.385 m (real 22.59 N, 0.383 m). Walk probe (24 starts): ERP 0.3
    #: 24/24, 0.5 23/24.
    contact_erp: float = 0.4
    contact_cfm: float = 1e-4
    #: "bullet" backend only: distance (m) within which Bullet keeps a contact point. 0.002 (default 0.02): ODE only
    #: makes contacts for touching geometry (surface layer 0.001 m). Walk probe (24 starts):
    #: 0.001 and 0.004 24/24 as well; Bullet's default 0.02 19/24, turning up to 2.5 m aside.
    contact_breaking_threshold: float = 0.002
    #: ODE's contact surface layer, 0.001 m (docs/robot_and_server.md section 4): a contact may sink this deep before
    #: it is pushed back, so a resting foot stays just inside the ground and is found again by the
    #: next step's collision check (Bullet's contactSlop, which its multibody solver honours).
    #: Without it a stance foot ended about one step in eleven just above the ground, found no
    #: contact in the next, and the robot dropped for a cycle: 8.9% of the calibration walk's
    #: cycles had no FRP on either foot, against 0% on the real server. With it, over 72 perturbed
    #: starts (walk probe, seeds 7, 11, 12): 0% without FRP, both feet 12.1% (real 11.6-12.0%),
    #: 72/72 ok (2.94-3.35 m), sideways drift median 0.65 m (the real runs: 0.40, 0.66, 0.99 m),
    #: up to 1.62 m; flail 0 blow-ups in 336 (torso <= 2.72 m/s). 0.0005: 4 falls in 24;
    #: 0.0015 / 0.002: both feet 15.2% / 18.6%.
    contact_slop: float = 0.001
    #: "bullet" backend only: Coulomb mu of robot parts (the ground has 1; Bullet multiplies
    #: them). 0: the real server has
    #: no Coulomb limit (mu infinite); its tangential contact force comes from force-dependent
    #: slip alone (``slip``). Measured before the slip model: with mu 0.5 alone, 2 of 12 starts
    #: walked 3.0 m +-15% and 6 fell (rebeam at cycle 12: 3.37 m, at 13: 0.56 m); mu >= 1
    #: always fell backwards.
    lateral_friction: float = 0.0
    #: force-dependent slip of every contact point in both tangential directions, (m/s) per N
    #: (docs/robot_and_server.md section 4, ODE's dContactSlip1/2): a point slides at slip x its tangential force.
    #: The real value, applied by ``server_stub.physics.slip`` (see there why outside Bullet's solver).
    #: Walk probe: 0.005 72/72; 0.006 24/24; 0.004 21/24 (3 falls, 1 flail blow-up); in the
    #: earlier per-point damper only an effective 0.027 was stable, and walked 2.6-3.2 m.
    slip: float = 0.005
    #: "bullet" backend only: ODE has neither rolling nor spinning friction (spinning friction
    #: 0.002-0.01 changed nothing
    #: in the walk with Coulomb friction; the MLCP solver ignores it).
    rolling_friction: float = 0.0
    spinning_friction: float = 0.0
    #: "bullet" backend only (the ODE step takes each surface's bounce, ``ode_surface_*``): bounce off
    #: for robots (docs/robot_and_server.md section 4).
    restitution: float = 0.0

    # --- bodies and motors (docs/robot_and_server.md sections 2-3) ---
    #: drag 0.01 on every body (section 2; Bullet's damping form differs slightly: m d (1+|v|) v).
    linear_damping: float = 0.01
    angular_damping: float = 0.01
    motor_torque: float = TORQUE_LIMIT
    #: joint stop: ERP 0.8, bounce 1 (fully elastic), applied when a joint starts a step outside
    #: its range, as ODE's limit rows are.
    stop_erp: float = 0.8
    stop_bounce: float = 1.0

    def __post_init__(self) -> None:
        if not 1 <= self.ode_box_points <= 4:
            raise ValueError(
                f"ode_box_points (NAO_STUB_ODE_BOX_POINTS) must be 1-4, the contacts ODE's box-plane "
                f"collider can make; got {self.ode_box_points}"
            )

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
    #: Move every agent's beam by a uniform random amount within +-``beam_noise_xy`` (m) on x and
    #: y and +-``beam_noise_angle`` (deg) on the heading: the real server's defaults
    #: (``BeamNoiseXY``, ``BeamNoiseAngle``; docs/robot_and_server.md sections 6 and 10). The fixtures' server had
    #: them at 0; an optimizer that needs exact starts turns the noise off.
    beam_noise: bool = True
    beam_noise_xy: float = 0.05
    beam_noise_angle: float = 10.0
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
    #: Cycles between monitor updates (0.04 s) and between vision messages (0.06 s), docs/robot_and_server.md section 4.
    monitor_interval: int = 2
    vision_interval: int = 3
    #: Log lines about one client's bad input: the first ``warning_burst`` distinct problems are
    #: logged at once, later ones at most one per ``warning_interval`` wall seconds (that line says
    #: how many were held back), so a client sending garbage cannot fill the disk (one fuzzing run
    #: wrote 93 MB of warnings before this).
    warning_burst: int = 10
    warning_interval: float = 10.0
    #: Most characters of a client's input quoted in one warning (escaped, then cut).
    warning_quote: int = 200
    #: A client whose messages keep being refused whole (they do not parse, or no command in them
    #: applies) is disconnected once it has ``bad_input_burst`` more of them than
    #: ``bad_input_rate`` per wall second would allow (a token bucket): an agent with one odd
    #: message now and then is served, a garbage stream is cut within seconds.
    bad_input_burst: int = 100
    bad_input_rate: float = 5.0
    #: Exit when this process is no longer our parent (0: never). A worker that starts a stub and
    #: is killed (SIGKILL leaves no chance to clean up) must not leave the stub behind.
    parent_pid: int = 0
