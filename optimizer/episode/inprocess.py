"""Episodes on the embedded stand-in without sockets or text: the optimizer's fast path.

``EpisodeRunner`` walks a gait on a server over TCP: the stub prints a perception, the agent parses
it and prints its reply, the stub parses that, and the monitor stream is printed and parsed again
for the judge. With the embedded stub all of it runs on one machine for one agent, so this module
drives the stand-in's core (``server_stub.simulation.Simulation``) and the agent's behaviour
(``agent.behaviour.WalkBehaviour``) directly, in one process, in the same order of events as the
socket path, and scores with the same ``Judge``:

- each cycle the agent is given the perception computed after the previous step, the replies
  to the perception before it are applied, the world steps: the server's two-cycle latency;
- ``PlayOn`` is set between the perception after which the agent is settled and its reply, as
  the runner's trainer sends it;
- every number crosses as the text would carry it: perceptions rounded to 2 decimals
  (``%.2f``), velocity commands to 4 (``%.4f``), the judge's torso to 6 significant digits
  (``%g``) and only when the monitor's delta rule would resend it (a move over 0.005);
- what this agent does not read is not made: foot pressure, hearing, and all body parts but the
  torso for the judge; vision only for an agent that looks (one walking to poses), as the full
  perception text of that cycle, parsed (its noise drawn as the socket server draws it).

``tests/test_episode_inprocess.py`` checks that fast and slow gaits walk the same distances and fall
the same way, to the last digit, here and over the sockets.
"""

from __future__ import annotations

import logging
import math
from operator import sub

import numpy as np

from agent.behaviour import WalkBehaviour
from agent.config import AgentConfig
from gait import Gait
from optimizer.episode import rounding
from optimizer.episode.config import EpisodeConfig, parked_ball
from optimizer.episode.monitor_link import EpisodeFailure
from optimizer.episode.objectives import Judging
from optimizer.episode.rounding import perception_numbers, rounded, rounded_array
from protocol import commands
from protocol.monitor import MonitorState, RobotPose, Vec3
from protocol.nao import JOINTS
from protocol.perception import GameState, Perception, parse_perception
from server_stub import kernels
from server_stub.agent_state import AgentState
from server_stub.config import PhysicsConfig, ServerConfig
from server_stub.sensors.monitor_scene import MonitorConfig
from server_stub.simulation import Simulation

_stub_log = logging.getLogger("server_stub")
#: The 22 joints' effector names, in ``JOINTS`` order: a reply naming them all is one array.
_EFFECTORS = tuple(joint.effector for joint in JOINTS)
#: The monitor resends a transform only when one of its 16 numbers moved by more than this.
_SLT_THRESHOLD = MonitorConfig().slt_threshold


def _printed(values: list[float]) -> list[float]:
    """``values`` as the monitor stream carries them: ``%g``, 6 significant digits (one format
    for them all: half the cost of one each, every other cycle)."""
    return list(map(float, ("%g " * len(values) % tuple(values)).split()))


class _TorsoView:
    """What a monitor reader knows of each robot's torso, without the stream: a full scene when
    robots came or went (or one's team or number changed), else the torso's pose only when it
    moved past the delta threshold since it was last sent (``server_stub.sensors.monitor_scene``).
    The pose last sent is kept as it was read, so a torso that did not move past the threshold
    costs no printing."""

    def __init__(self) -> None:
        self._keys: list[tuple] = []
        #: each robot's torso as last sent: the 12 numbers of its SLT that move, and the position,
        #: up and forward axes a reader parsed from them (None: nothing sent since the full scene)
        self._sent: list[tuple[tuple[float, ...], tuple[Vec3, Vec3, Vec3]] | None] = []

    def state(self, sim: Simulation) -> MonitorState:
        playing = [s for s in sim.agents if s.robot is not None]
        keys = [(s.side, s.unum, s.robot_type) for s in playing]
        full = sim.scene_changed or keys != self._keys
        sim.scene_changed = False
        if full:
            self._keys = keys
            self._sent = [None] * len(playing)
        game = sim.game
        numbers = [game.time]  # what is printed now: the time and each torso sent now
        fresh = []
        for index, state in enumerate(playing):
            robot = state.robot
            assert robot is not None
            (px, py, pz), r = robot.torso_position(), robot.torso_rotation().ravel().tolist()
            # the torso's SLT (its 4x4 world pose, column-major) but its 4 constant numbers, in order
            pose = (r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8], px, py, pz)
            sent = self._sent[index]
            if sent is None or max(map(abs, map(sub, pose, sent[0]))) > _SLT_THRESHOLD:
                fresh.append((index, pose))
                numbers += (px, py, pz, r[2], r[5], r[8], r[1], r[4], r[7])  # position, up and forward axes
        printed = _printed(numbers)
        for i, (index, pose) in enumerate(fresh):
            x, y, z, ux, uy, uz, fx, fy, fz = printed[1 + 9 * i : 10 + 9 * i]
            self._sent[index] = (pose, ((x, y, z), (ux, uy, uz), (fx, fy, fz)))
        robots = []
        for state, sent in zip(playing, self._sent):
            assert sent is not None
            robots.append(RobotPose(state.side, state.unum, state.robot_type, *sent[1]))
        return MonitorState(
            printed[0],
            game.play_mode,
            game.half,
            game.score_left,
            game.score_right,
            game.team_left,
            game.team_right,
            robots,
        )


def _perception(sim: Simulation, state: AgentState) -> Perception:
    """What the agent's parser would read from this cycle's perception, numbers rounded as
    printed; no See (this agent never looks), no FRP or hear (it reads neither)."""
    robot = state.robot
    assert robot is not None
    game = sim.game
    identity = state.announce_identity and state.side is not None
    state.announce_identity = state.announce_identity and not identity
    # the two clocks, the gyro, the accelerometer and the joints' degrees, rounded in one pass
    sensed = np.array((game.time, sim.world.time, *robot.gyro(), *robot.accelerometer()))
    numbers = perception_numbers(sensed[None], robot.joint_state()[0][None])
    game_time, now, gx, gy, gz, ax, ay, az, *degrees = numbers[0].tolist()
    gs = GameState(
        state.unum if identity else None,
        state.side if identity else None,
        game.score_left,
        game.score_right,
        game_time,
        game.play_mode,
    )
    return Perception(
        now,
        gs,
        (gx, gy, gz),
        (ax, ay, az),
        dict(zip(robot.perceptors, degrees)),
        {},
        None,
        [],
        [],
    )


def _warn(problem: str, key: str) -> None:
    """A command of the agent the stand-in ignores: said as the stand-in process says it (the
    episode goes on, as over sockets)."""
    _stub_log.warning("agent in process: %s", problem)


class InProcessStub:
    """The embedded stand-in as a library in this process, for one episode after another: the
    same settings as ``StubProcess`` (sync, exact beams, its seed)."""

    def __init__(self, seed: int = 0) -> None:
        self.seed = seed
        # the walk's kernels compiled now, in two processes if numba's cache is cold (a fresh
        # clone), rather than one by one in the first episode
        kernels.warm_up(kernels.WALK, eager=False)
        rounding.warm_up()
        # mypos and myorien in vision, as the real server's sync profile sends them
        config = ServerConfig(sync=True, realtime=False, beam_noise=False, sense_mypos=True, seed=seed)
        self.sim = Simulation(config, PhysicsConfig())
        #: the monitor reader's knowledge, kept across episodes as a trainer's connection keeps it
        self._view = _TorsoView()
        # the runner's trainer connects at its first episode and gets a full scene then
        self.sim.scene_changed = True

    def run(self, gait: Gait, config: EpisodeConfig, judge: Judging) -> WalkBehaviour:
        """Walk ``gait`` once from ``config``'s start; ``judge.result`` holds the outcome. Returns
        the agent's behaviour, for a caller that wants to see what the agent believed."""
        sim = self.sim
        sx, sy = config.start
        # what the runner's trainer sends before each episode
        sim.set_play_mode("BeforeKickOff")
        sim.set_game_time(0.0)
        agent_config = AgentConfig(
            team=config.team,
            unum=config.unum,
            beam=(sx, sy, config.heading),
            sync=True,
            start_now=True,
            rebeam_cycle=config.rebeam_cycle,
            command_noise=config.command_noise,
            noise_seed=config.noise_seed,
            robot_type=config.robot_type,
            goals=config.goals,
            true_pose=config.true_pose,
            walk_command=config.command,
        )
        behaviour = WalkBehaviour(agent_config, gait.walker())
        # an agent that looks gets, in the cycles the camera sees, the perception the sockets
        # would carry, read as it reads it (the vision's noise drawn as the server draws it)
        looks = behaviour.reads_vision
        state = sim.join()
        inbox: list[bytes | np.ndarray | dict[str, float]] = [commands.scene(config.robot_type or None).encode()]
        to_agent: Perception | None = None
        play_on_sent = False
        cycles = 0
        limit = math.ceil(config.walk_time / 0.02) + 1000  # settling and a margin: far more than a walk needs
        try:
            while judge.result is None:
                # the cycle: the perception goes out, the replies that came in are applied, a step
                delivered, to_agent = to_agent, None
                for message in inbox:
                    if isinstance(message, bytes):
                        sim.apply_frame(state, message, _warn)
                        continue
                    robot = state.robot
                    assert robot is not None
                    if isinstance(message, np.ndarray):
                        robot.command_joints(message)
                    else:
                        for name, velocity in message.items():
                            robot.command(name, velocity)
                inbox = []
                sim.step()
                cycles += 1
                if state.robot is not None:
                    if looks and sim.vision_due:
                        to_agent = parse_perception(sim.perception(state, True))
                    else:
                        to_agent = _perception(sim, state)
                if sim.monitor_due:
                    judge.feed(self._view.state(sim))
                # the agent answers the perception it was given
                if delivered is not None:
                    if not play_on_sent and behaviour.settle_cycle >= agent_config.settle_cycles:
                        sim.set_play_mode("PlayOn")  # between the perception and its reply
                        sim.set_ball(parked_ball(sx, sy), (0.0, 0.0, 0.0))
                        play_on_sent = True
                    inbox = self._reply(behaviour, delivered)
                if cycles > limit:
                    raise EpisodeFailure(f"no result after {cycles} cycles")
        finally:
            sim.leave(state)
        return behaviour

    @staticmethod
    def _reply(behaviour: WalkBehaviour, perception: Perception) -> list[bytes | np.ndarray | dict[str, float]]:
        """The agent's reply as the stand-in would read it: velocities at 4 decimals (all 22 in
        ``JOINTS`` order, as every cycle sends them, as one array); the handshake and beams (a few
        per episode) as their text."""
        action = behaviour.action(perception)
        out: list[bytes | np.ndarray | dict[str, float]] = []
        # a non-finite one raises ValueError when applied, as printing it does on the socket path
        if action.effectors == _EFFECTORS:
            out.append(rounded_array(action.speeds, 4))
        elif action.effectors:
            out.append(dict(zip(action.effectors, rounded(action.speeds.tolist(), 4))))
        if action.text:
            out.append(action.text.encode())
        return out

    def close(self) -> None:
        self.sim.close()
