"""An omnidirectional walk measured: the course on both servers, its speeds by command, its pose estimate.

Three parts, each on the stand-in (in process) and on a real rcssserver3d (``RCSSSERVER3D``, then
PATH; the sync profile, which sends ``mypos``):

- **Course.** ``--runs`` walks of the course (default ``optimizer/courses/omni_course.json``)
  steering by the server's pose, then as many by the robot's own estimate (``--no-true-pose``),
  each walk with its own draw of the calibrated command dither (seeds 0, 1, ...): how many
  finished and fell, the mean time, each leg's mean time.
- **Straight to a pose.** ``--runs`` walks of ``optimizer/courses/straight_15m.json`` (15 m ahead
  to a pose) by the server's pose: finished means the walk came within 0.25 m and 15 deg of it.
- **Pose estimate.** Along the own-estimate walks: the estimate the agent steered by at each vision
  cycle against the torso's true pose (the judge's, at the same game time): median and worst error
  in metres and degrees.
- **Speeds by command.** A grid of commands (forward, backwards, sideways, turning, mixes), each
  walked ``--map-seconds`` (default 5) from a standing start at (-5, 0, 0): the velocity achieved
  in the torso's own frame (forward, left, turning) over the whole walk and over its second half
  (the command held after the start), and falls (``optimizer.episode.command_map``).
  ``--target-runs N`` walks the four target commands N times each, and each way at the walk's top
  speed as many times.

    python -m bench.bench_course --gait gait/walks/omni.json [--runs 10] [--target-runs 10]
        [--skip-real] [--skip-map] [--skip-course] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from gait import Gait, GaitFileError, Steerable, load_gait
from optimizer.episode import CALIBRATED_COMMAND_NOISE, EpisodeConfig, EpisodeRunner
from optimizer.episode.command_map import walk_commands
from optimizer.episode.course import Course, leg_durations
from optimizer.episode.real_server import RealServerError, RealServerProcess, find_rcssserver3d
from optimizer.episode.runner import quiet_agent_logs
from optimizer.episode.scoring import TracePoint
from protocol.cli_values import positive_float, positive_int

COURSES = Path(__file__).resolve().parent.parent / "optimizer" / "courses"
DEFAULT_COURSE = COURSES / "omni_course.json"
#: 15 m straight ahead to a pose: finishing it means the walk ended within the reach of the pose.
STRAIGHT_COURSE = COURSES / "straight_15m.json"
#: The commands the targets name (forward, backwards, sideways m/s; turning deg/s).
TARGET_COMMANDS: tuple[tuple[float, float, float], ...] = (
    (1.0, 0.0, 0.0),
    (-0.8, 0.0, 0.0),
    (0.0, 0.7, 0.0),
    (0, 0, 90),
)
#: The map's grid: each way alone at a few speeds, then mixes.
MAP_COMMANDS: tuple[tuple[float, float, float], ...] = (
    (0.3, 0.0, 0.0),
    (0.6, 0.0, 0.0),
    (1.0, 0.0, 0.0),
    (1.3, 0.0, 0.0),
    (-0.4, 0.0, 0.0),
    (-0.8, 0.0, 0.0),
    (0.0, 0.35, 0.0),
    (0.0, 0.7, 0.0),
    (0.0, -0.7, 0.0),
    (0.0, 0.0, 45.0),
    (0.0, 0.0, 90.0),
    (0.0, 0.0, -90.0),
    (0.5, 0.3, 0.0),
    (0.5, 0.0, 45.0),
    (-0.4, 0.3, 0.0),
    (0.3, -0.3, -30.0),
)


@contextmanager
def runner_on(server: str, config: EpisodeConfig) -> Iterator[EpisodeRunner]:
    """A traced runner on the stand-in (in process) or on a real server started here."""
    owned = RealServerProcess(find_rcssserver3d()) if server == "real" else None
    with EpisodeRunner(config, owned, trace=True) as runner:
        yield runner


def pose_errors(
    log: Sequence[tuple[float, float, float, float]], trace: Sequence[TracePoint]
) -> list[tuple[float, float]]:
    """(metres, degrees) between each logged estimate and the true torso at its game time
    (interpolated between the judge's states, 0.04 s apart)."""
    if len(trace) < 2 or not log:
        return []
    times = np.array([p.game_time for p in trace])
    headings = np.unwrap(np.radians([p.heading for p in trace]))
    out = []
    for t, x, y, heading in log:
        if not times[0] <= t <= times[-1]:
            continue
        tx = float(np.interp(t, times, [p.x for p in trace]))
        ty = float(np.interp(t, times, [p.y for p in trace]))
        th = math.degrees(float(np.interp(t, times, headings)))
        out.append((math.hypot(x - tx, y - ty), abs((heading - th + 180.0) % 360.0 - 180.0)))
    return out


def course_runs(gait: Gait, course: Course, server: str, true_pose: bool, runs: int) -> dict[str, Any]:
    config = replace(EpisodeConfig(command_noise=CALIBRATED_COMMAND_NOISE), true_pose=true_pose).on_course(course)
    walks, errors = [], []
    with runner_on(server, config) as runner:
        for seed in range(runs):
            result = runner.evaluate(gait, seed=seed)
            walks.append(result)
            if runner.last_agent is not None and runner.last_trace is not None:
                errors.extend(pose_errors(runner.last_agent.pose_log, runner.last_trace))
            legs = " ".join(f"{d:.2f}" for d in leg_durations(result.legs or ()))
            print(
                f"  {server} {'true pose' if true_pose else 'own estimate'} #{seed}: "
                f"{'finished' if result.finished else 'unfinished'} {result.time:.2f} s, "
                f"{result.reached}/{len(course.poses)} poses, {'FELL' if result.fell else 'no fall'}; legs {legs}",
                flush=True,
            )
    ran = [w for w in walks if w.status == "ok"]
    finished = [w for w in ran if w.finished]
    leg_means = [
        statistics.fmean(leg_durations(w.legs or ())[k] for w in finished) if finished else None
        for k in range(len(course.poses))
    ]
    summary: dict[str, Any] = {
        "server": server,
        "true_pose": true_pose,
        "runs": runs,
        "ran": len(ran),
        "finished": len(finished),
        "falls": sum(w.fell for w in ran),
        "mean_time": statistics.fmean(w.time for w in finished) if finished else None,
        "times": [round(w.time, 2) for w in ran],
        "leg_means": [None if m is None else round(m, 2) for m in leg_means],
    }
    if errors:
        metres, degrees = zip(*errors)
        summary["pose_error"] = {
            "samples": len(errors),
            "median_m": round(statistics.median(metres), 4),
            "worst_m": round(max(metres), 4),
            "median_deg": round(statistics.median(degrees), 3),
            "worst_deg": round(max(degrees), 3),
        }
    return summary


def command_walks(
    gait: Gait, server: str, commands: Sequence[tuple[float, float, float]], runs: int, seconds: float
) -> list[dict[str, Any]]:
    with runner_on(server, EpisodeConfig()) as runner:
        walks = walk_commands(runner, gait, commands, runs, seconds)
    rows = []
    for walk in walks:
        rows.append({"server": server} | walk.to_dict())
        print(
            f"  {server} command {tuple(round(c, 3) for c in walk.command)}: achieved {rows[-1]['achieved']} over "
            f"the walk, {rows[-1]['second_half']} over its second half (fwd m/s, left m/s, deg/s; walks that "
            f"stood), {walk.falls}/{walk.runs} fell"
        )
    return rows


def top_commands(gait: Gait) -> list[tuple[float, float, float]]:
    """Each way at the walk's top speed (``Steerable.max_command``, ``max_backward``)."""
    walker = gait.walker()
    assert isinstance(walker, Steerable)
    top = walker.max_command
    return [(top.forward, 0.0, 0.0), (-walker.max_backward, 0.0, 0.0), (0.0, top.left, 0.0), (0.0, 0.0, top.turn)]


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m bench.bench_course", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--gait", required=True, type=Path, help="an omni gait file")
    p.add_argument("--course", type=Path, default=DEFAULT_COURSE, help="course file (default: the issue's course)")
    p.add_argument("--runs", type=positive_int, default=10, help="course walks per server and pose source")
    p.add_argument("--target-runs", type=positive_int, default=10, help="walks of each target command")
    p.add_argument("--map-seconds", type=positive_float, default=5.0, help="seconds each command is walked")
    p.add_argument("--skip-real", action="store_true", help="the stand-in only")
    p.add_argument("--skip-map", action="store_true", help="no speeds by command")
    p.add_argument("--skip-course", action="store_true", help="no course walks")
    p.add_argument("--out", type=Path, help="write every figure as JSON here")
    args = p.parse_args(argv)
    try:
        gait = load_gait(args.gait)
        course = Course.load(args.course)
    except (GaitFileError, ValueError) as exc:
        p.error(str(exc))
    servers = ["stand-in"] if args.skip_real else ["stand-in", "real"]
    if not args.skip_real:
        try:
            find_rcssserver3d()
        except RealServerError as exc:
            p.error(f"no real server ({exc}); use --skip-real")
    quiet_agent_logs()
    report: dict[str, Any] = {
        "gait": str(args.gait),
        "course": course.to_document(),
        "course_runs": [],
        "straight_runs": [],
        "map": [],
    }
    for server in servers:
        if not args.skip_course:
            print(f"course on {server}:")
            for true_pose in (True, False):
                report["course_runs"].append(course_runs(gait, course, server, true_pose, args.runs))
            print(f"straight to a pose on {server}:")
            report["straight_runs"].append(course_runs(gait, Course.load(STRAIGHT_COURSE), server, True, args.runs))
        if not args.skip_map:
            print(f"targets on {server} ({args.target_runs} walks each, {args.map_seconds:g} s):")
            report["map"] += command_walks(gait, server, TARGET_COMMANDS, args.target_runs, args.map_seconds)
            print(f"top speeds on {server} ({args.target_runs} walks each, {args.map_seconds:g} s):")
            report["map"] += command_walks(gait, server, top_commands(gait), args.target_runs, args.map_seconds)
            print(f"map on {server} (1 walk each):")
            report["map"] += command_walks(gait, server, MAP_COMMANDS, 1, args.map_seconds)
    print(json.dumps({k: report[k] for k in ("course_runs", "straight_runs")}, indent=1))
    if args.out is not None:
        args.out.write_text(json.dumps(report, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
