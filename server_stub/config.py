"""Configuration of the stand-in server: every setting in one dataclass per concern."""

from __future__ import annotations

from dataclasses import dataclass

from protocol.nao import CYCLE, TORQUE_LIMIT
from server_stub import field as soccer_field


@dataclass(frozen=True)
class PhysicsConfig:
    """The real server's physics numbers, as the stand-in's step uses them (ODE 0.16 as SimSpark
    sets it up; docs/robot_and_server.md sections 2-4). Each comment gives the source; the
    measurements that confirmed them are in docs/fidelity.md."""

    # --- timing (section 4: one 0.02 s ODE step per cycle, no sub-steps) ---
    cycle: float = CYCLE
    gravity: float = -9.81

    # --- joints ---
    #: World ERP of the hinges' joint rows. SimSpark never sets it (spark.rb sets gravity, CFM,
    #: auto-disable and the surface layer only), so ODE's default 0.2.
    ode_joint_erp: float = 0.2
    #: World CFM (section 4; spark.rb's $physicsGlobalCFM), given to the hinges' 5 joint rows (ODE
    #: sets every joint row's CFM to the world's; SimSpark's hinge ``setCFM 0 1e-8`` is the motor
    #: row's only).
    global_cfm: float = 1e-5
    #: ODE 0.16's gyroscopic torque, on for every body (dBodyCreate sets dxBodyGyroscopic; SimSpark
    #: never clears it), computed implicitly ("implicit", step.cpp: (I (I - h [L]x)^-1 - 1) L / h,
    #: L = I w); "explicit" (-w x I w) for comparison.
    ode_gyroscopic: str = "implicit"

    # --- contacts ---
    #: Contacts asked of ODE's colliders per pair, 1-4 (SimSpark's odespace.cpp asks dCollide for
    #: 4). A box meets the ground as ODE 0.16's box-plane collider makes it
    #: (``server_stub.physics.collision``, equal to libode on 1,200 stored and 400 fresh random
    #: poses, ``tests/test_ode_colliders.py``): a flat foot at its 4 sole corners, a foot landing on
    #: an edge at 3 at most.
    ode_box_points: int = 4
    #: Robot-ground contact joint: robot ERP 0.6 and ground ERP 0.2 averaged, CFM 1e-4 from the
    #: robot side only (rsg/agent/nao/contactjointhandler.rsg, soccer.rsg). Standing, each foot
    #: carries 22.60 N and the torso rests at 0.384 m (real 22.59 N, 0.383 m).
    contact_erp: float = 0.4
    contact_cfm: float = 1e-4
    #: ODE's contact surface layer (section 4): a contact may sink this deep before it is pushed
    #: back, so a resting foot stays just inside the ground and is found again next step.
    contact_slop: float = 0.001
    #: Force-dependent slip of every contact in both tangential directions, (m/s) per N (section 4,
    #: ODE's dContactSlip1/2; friction is otherwise unbounded: SimSpark's mu is infinite).
    slip: float = 0.005
    #: Distance (m) within which Bullet's collision pass (robot-robot, robot-ball, robot-goal
    #: contacts) keeps a point in its manifold between steps; only touching points become contacts.
    contact_breaking_threshold: float = 0.002
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

    # --- bodies and motors (sections 2-3) ---
    #: SimSpark's DragController on every robot body: a force -0.01 v and a torque -0.01 w.
    linear_damping: float = 0.01
    angular_damping: float = 0.01
    #: The ball's DragController (ball.rsg): linear 0.01, angular 5e-5; its mass and radius are
    #: naosoccersim.rb's BallMass 0.026 kg and BallRadius 0.042 m (``server_stub.field``), its
    #: inertia a solid sphere's (ball.rsg setSphereTotal: 2/5 m r^2).
    ode_ball_drag_linear: float = 0.01
    ode_ball_drag_angular: float = 5e-5
    motor_torque: float = TORQUE_LIMIT
    #: Joint stop: ERP 0.8, bounce 1 (fully elastic), applied when a joint starts a step outside
    #: its range, as ODE's limit rows are.
    stop_erp: float = 0.8
    stop_bounce: float = 1.0

    # --- islands of touching robots (no counterpart: ODE's dWorldStep solves every island exactly) ---
    #: An island with more bounded rows than this (motors, contact normals, three rows per point
    #: between two bodies) is solved by block Gauss-Seidel (``physics.gauss_seidel``), not exactly:
    #: the exact solve's cost grows with the cube of the rows (200 rows: about 8 ms a step; 1,248,
    #: a pile of six: 2.9 s). Two robots bumping into each other make 60-150.
    island_exact_rows: int = 200
    #: The most sweeps of block Gauss-Seidel in one step (20: ODE's QuickStep's default count of
    #: iterations, ``dWorldSetQuickStepNumIterations``), and when to stop before: no multiplier
    #: moved by more than this fraction of the largest in the last sweep. Converging takes
    #: thousands (the motors' CFM of 1e-8 makes the LCP stiff), so a large island's step is the
    #: softer answer of an iterative solver, as QuickStep's is (``docs/physics.md``).
    island_sweeps: int = 20
    island_tolerance: float = 1e-6

    def __post_init__(self) -> None:
        if not 1 <= self.ode_box_points <= 4:
            raise ValueError(
                f"ode_box_points must be 1-4, the contacts ODE's box-plane collider can make; got {self.ode_box_points}"
            )
        if self.ode_gyroscopic not in ("implicit", "explicit"):
            raise ValueError(f"ode_gyroscopic must be 'implicit' or 'explicit', got {self.ode_gyroscopic!r}")
        if self.island_exact_rows < 0 or self.island_sweeps < 1 or not self.island_tolerance >= 0.0:
            raise ValueError(
                "island_exact_rows must be >= 0, island_sweeps >= 1 and island_tolerance >= 0; got "
                f"{self.island_exact_rows}, {self.island_sweeps}, {self.island_tolerance}"
            )


@dataclass(frozen=True)
class HearingConfig:
    """How far a ``say`` carries and how much of it a robot hears: rcssserver3d 0.7.3's defaults,
    which naosoccersim.rb leaves alone (SoccerRuleAspect's ``mAudioCutDist``; AgentState's
    ``mHearMax``, ``mHearInc``, ``mHearDecay``; docs/robot_and_server.md section 8). The longest
    message is ``protocol.commands.SAY_MAX_LENGTH`` (``mSayMsgSize``), a rule agents share."""

    #: A robot hears another's message only if their torso centres are less than this apart (m,
    #: in 3-D); a robot's own message always reaches it.
    range: float = 50.0
    #: Each robot has one hearing capacity for its teammates' messages and one for its opponents':
    #: a message costs ``cost`` and is lost when less is left; each perception gives back
    #: ``recovery`` while the capacity is below ``capacity`` (its start). With 2, 2, 1: one message
    #: of each kind per perception, then none of that kind in the next cycle.
    capacity: int = 2
    cost: int = 2
    recovery: int = 1


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
    #: Range and capacity of hearing (``say``).
    hearing: HearingConfig = HearingConfig()
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
    #: Messages (and their bytes) an agent may send before the next cycle applies them; an agent
    #: that sends more, not waiting for its perceptions, is disconnected, so that its flood cannot
    #: grow the server's memory (a well-behaved agent sends one message a cycle, 300 B).
    agent_inbox_frames: int = 1000
    agent_inbox_bytes: int = 4 << 20
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
    #: A file the server writes when it stops: every cycle's wall time (ms) of the physics step
    #: and of the whole cycle, as JSON ``{"physics": [...], "cycle": [...]}``; for benchmarks
    #: (``bench/bench_match.py``), "" none. Kept in memory until then: 16 bytes a cycle.
    cycle_times: str = ""


@dataclass(frozen=True)
class RefereeConfig:
    """The referee's timeouts and distances: rcssserver3d 0.7.3's naosoccersim.rb values, read by
    its SoccerRuleAspect (docs/robot_and_server.md section 8). The field's sizes, the ball's radius
    and the penalty area are ``server_stub.field``'s."""

    #: RuleGoalPauseTime: after a goal, the scorers' celebration before the other side kicks off.
    goal_pause_time: float = 3.0
    #: RuleKickInPauseTime: a kick-in, corner or goal kick waits this long before the ball is
    #: placed and may be played.
    kick_in_pause_time: float = 1.0
    #: A touch ends a kick-in, corner or goal kick only if it comes this long after the pause
    #: (hard-coded in SoccerRuleAspect: the cycle that places the ball does not count).
    kick_touch_margin: float = 0.03
    #: RuleHalfTime: the first half ends at this game time, the second at twice it.
    half_time: float = 300.0
    #: RuleDropBallTime: a kick-off, kick-in, corner or goal kick nobody takes within this long
    #: ends in a drop ball (play on).
    drop_ball_time: float = 15.0
    #: FreeKickDistance: opponents are kept this far from a kick-in or corner spot, and a drop
    #: ball clears everybody from this far around it; also the centre circle's radius.
    free_kick_distance: float = soccer_field.CENTRE_CIRCLE_RADIUS
    #: FreeKickMoveDist: how far the referee moves a robot it clears.
    free_kick_move_dist: float = soccer_field.FREE_KICK_MOVE_DIST
    #: KickRepelDist: players of the kicking side this close to the spot are moved out to it.
    kick_repel_dist: float = 0.5
    #: GoalKickDist: a goal kick's spot is this far in front of the goal's centre.
    goal_kick_dist: float = 1.0
    #: The "incapable" foul (naosoccersim.rb's auto-referee values): a field player whose torso
    #: centre has been below 0.25 m (not standing) this long while the game runs, or below
    #: 0.15 m (on the ground) ``ground_max_time``, is lifted and then put outside the field.
    not_standing_max_time: float = 30.0
    ground_max_time: float = 15.0
    #: The same for the goalie (number 1).
    goalie_not_standing_max_time: float = 60.0
    goalie_ground_max_time: float = 30.0
    #: FoulHoldTime: how long a fouled player is held in the air before it is put outside.
    foul_hold_time: float = 0.5
