"""What a steerable walk walks when commanded: its speeds measured from the judge's track, and
the calibration (``gait.omni``'s gains and ``side_turn``) that makes them the commanded ones.

Why measured on walks: a robot walks less than its steps plan (its feet slip, its joints trail
their targets) and stepping sideways turns it, by amounts only the physics knows. Each command
is walked from standing for a few seconds, dithered as every search walks (each walk its own
draw), and its speeds are taken over the second half, once the walk has sped up: forward and
sideways in the torso's frame as it turned, and the turn rate (``achieved``).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from gait import Gait, Steerable
from gait.omni import CALIBRATION_GENES
from optimizer.episode.config import CALIBRATED_COMMAND_NOISE, EpisodeConfig
from optimizer.episode.runner import EpisodeRunner
from optimizer.episode.scoring import TracePoint

#: Where each command's walk starts (field m, m, deg): mid own half, room every way.
MAP_START = (-5.0, 0.0, 0.0)
#: The shares of the top speed each calibration command asks for, each way of each axis.
CALIBRATION_SHARES = (0.5, 0.9)


def achieved(trace: Sequence[TracePoint], since: float = 0.0) -> tuple[float, float, float]:
    """Forward and leftward speed (m/s) in the torso's own frame as it turned, and the turn rate
    (deg/s), over the part of the trace from game time ``since`` on: each step between two of the
    judge's states is taken in the heading the torso had midway (the mean of the two)."""
    kept = [p for p in trace if p.game_time >= since - 1e-9]
    if len(kept) < 2:
        return 0.0, 0.0, 0.0
    headings = np.unwrap(np.radians([p.heading for p in kept]))
    midway = (headings[:-1] + headings[1:]) / 2
    forward = left = 0.0
    for a, b, h in zip(kept, kept[1:], midway):
        dx, dy = b.x - a.x, b.y - a.y
        forward += dx * math.cos(h) + dy * math.sin(h)
        left += -dx * math.sin(h) + dy * math.cos(h)
    seconds = kept[-1].game_time - kept[0].game_time
    return forward / seconds, left / seconds, math.degrees(float(headings[-1] - headings[0])) / seconds


@dataclass(frozen=True)
class CommandWalks:
    """One command's walks: how many, how many fell, and the mean speeds (forward m/s, left m/s,
    turn deg/s) of those that stood, over the whole walk and over its second half (None when
    every walk fell)."""

    command: tuple[float, float, float]
    runs: int
    falls: int
    whole: tuple[float, float, float] | None
    second_half: tuple[float, float, float] | None

    def to_dict(self) -> dict:
        return {
            "command": list(self.command),
            "achieved": None if self.whole is None else [round(v, 3) for v in self.whole],
            "second_half": None if self.second_half is None else [round(v, 3) for v in self.second_half],
            "runs": self.runs,
            "falls": self.falls,
        }


def walk_commands(
    runner: EpisodeRunner,
    gait: Gait,
    commands: Sequence[tuple[float, float, float]],
    runs: int,
    seconds: float,
) -> list[CommandWalks]:
    """Each command walked ``runs`` times for ``seconds`` from ``MAP_START`` (seeds 0..runs-1:
    the dither's draws) on ``runner``'s server; the runner's config is set per command and left
    at the last (the runner must trace)."""
    base = EpisodeConfig(command_noise=CALIBRATED_COMMAND_NOISE, walk_time=seconds).starting_at(MAP_START)
    rows = []
    for forward, left, turn in commands:
        command = (forward, left, turn)
        runner.config = replace(base, command=command)
        whole, settled, falls = [], [], 0
        for seed in range(runs):
            result = runner.evaluate(gait, seed=seed)
            falls += result.fell
            if runner.last_trace and not result.fell and result.status == "ok":
                whole.append(achieved(runner.last_trace))
                settled.append(achieved(runner.last_trace, seconds / 2))
        rows.append(CommandWalks(command, runs, falls, _mean(whole), _mean(settled)))
    return rows


def _mean(speeds: list[tuple[float, float, float]]) -> tuple[float, float, float] | None:
    if not speeds:
        return None
    forward, left, turn = (statistics.fmean(s[k] for s in speeds) for k in range(3))
    return forward, left, turn


def calibration_commands(gait: Gait) -> list[tuple[float, float, float]]:
    """The commands a calibration walks: ``CALIBRATION_SHARES`` of the walk's top speed (as it
    now reports it), forward, backward, each side and each way round."""
    walker = gait.walker()
    if not isinstance(walker, Steerable):
        raise ValueError(f"a {gait.family.name} gait takes no command: only a steerable gait is calibrated")
    top = walker.max_command
    commands = []
    for share in CALIBRATION_SHARES:
        commands += [
            (share * top.forward, 0.0, 0.0),
            (-share * walker.max_backward, 0.0, 0.0),
            (0.0, share * top.left, 0.0),
            (0.0, -share * top.left, 0.0),
            (0.0, 0.0, share * top.turn),
            (0.0, 0.0, -share * top.turn),
        ]
    return commands


def calibrated(gait: Gait, walks: Sequence[CommandWalks]) -> Gait:
    """``gait`` with its calibration moved so that the walked commands would walk as commanded:
    each gain times the mean of commanded over walked speed on its axis (its commands only), and
    ``side_turn`` less the turn walked per metre of sideways walk (deg/m) times the new turn gain.
    An axis none of whose walks stood keeps its gain."""
    params = dict(gait.params)
    ratios: dict[str, list[float]] = {name: [] for name in CALIBRATION_GENES}
    for walk in walks:
        if walk.second_half is None:
            continue
        forward, left, turn = walk.command
        got = walk.second_half
        if forward and not left and not turn and got[0] * forward > 0:
            ratios["gain_forward" if forward > 0 else "gain_backward"].append(forward / got[0])
        elif left and not forward and not turn and got[1] * left > 0:
            ratios["gain_left"].append(left / got[1])
            ratios["side_turn"].append(got[2] / got[1])
        elif turn and not forward and not left and got[2] * turn > 0:
            ratios["gain_turn"].append(turn / got[2])
    for name in CALIBRATION_GENES[:4]:
        if ratios[name]:
            params[name] *= statistics.fmean(ratios[name])
    if ratios["side_turn"]:
        params["side_turn"] -= params["gain_turn"] * statistics.fmean(ratios["side_turn"])
    family = gait.family
    low, high = family.bounds[:, 0], family.bounds[:, 1]
    genes = np.clip([params[name] for name in family.gene_names], low, high)
    return family.gait(genes)


def command_error(walks: Sequence[CommandWalks]) -> float:
    """The largest share by which a walked speed missed its command, over the walks that stood
    (on each command's own axis): how far a calibration is from done."""
    worst = 0.0
    for walk in walks:
        if walk.second_half is None:
            continue
        for wanted, got in zip(walk.command, walk.second_half):
            if wanted:
                worst = max(worst, abs(got - wanted) / abs(wanted))
    return worst
