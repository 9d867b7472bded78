"""The probes behind the choices in ``server_stub/config.py``: how a physics setting walks and
whether it keeps a flailing robot on the ground.

    python -m bench.probe_physics walk [--seed 7] [name=value ...]
    python -m bench.probe_physics flail [--seed 0] [--sigma 3] [name=value ...]

``walk``: the real calibration gait (``server_stub.physics.calibration_walk``) from 24 perturbed starts
(repeated beam at cycle 10-14 or none, beams 0 or 1 step late, heading +-1 deg, anywhere on the
own half, first beam after 2-4 steps), judged against what the real server did from the same
starts (seeds 7, 11 and 12: ``tests/data/rcssserver3d/walk_calibration/probe_starts_real.json``;
it falls from 11, 10 and 10 of them, by the start's timing): in how many the stand-in falls where
the real server falls, and its distance against the real one where both walk. ``flail``: 24
robots driven by random motor speeds (normal, ``--sigma`` rad/s, new every 0.2 s) for 20 s; a
torso faster than 5 m/s counts as a blow-up. ``name=value`` overrides a ``PhysicsConfig`` field
(JSON value), e.g. ``slip=0.006 contact_erp=0.3``. Uses both cores.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import random
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from protocol.cli_values import positive_float, whole
from protocol.nao import JOINTS
from server_stub.config import PhysicsConfig
from server_stub.physics import calibration_walk
from server_stub.physics.world import World

RUNS = 24
#: The real server's walks from the probe's starts (seeds 7, 11, 12), recorded by a probe client.
REAL_STARTS = Path(__file__).resolve().parents[1] / "tests/data/rcssserver3d/walk_calibration/probe_starts_real.json"


def _real_outcomes(seed: int) -> list[dict] | None:
    """The real server's walk from each start of ``seed`` in the probe's order, or None if not recorded."""
    recorded = [w for w in json.loads(REAL_STARTS.read_text())["starts"] if w["probe_seed"] == seed]
    return recorded if len(recorded) == RUNS else None


def _walk_report(results: list[tuple[float, float, bool]], real: list[dict] | None) -> str:
    walked = [dx for dx, _, fell in results if not fell]
    line = (
        f"{sum(f for *_, f in results)}/{RUNS} falls, {min(walked, default=0):.2f}-{max(walked, default=0):.2f} m, "
        f"sideways up to {max(abs(dy) for _, dy, _ in results):.2f} m"
    )
    if real is None:
        return line + " (no real-server record for this seed)"
    agree = sum(fell == r["fell"] for (_, _, fell), r in zip(results, real))
    ratios = [dx / r["dx"] for (dx, _, fell), r in zip(results, real) if not fell and not r["fell"]]
    return (
        f"{line}; falls where the real server falls in {agree}/{RUNS} (real: {sum(r['fell'] for r in real)} falls)"
        + (f", distance {min(ratios):.2f}-{max(ratios):.2f} of the real one where both walk" if ratios else "")
    )


def _starts(seed: int) -> list[dict]:
    rng = random.Random(seed)
    starts = [
        dict(
            rebeam_cycle=rng.choice([10, 11, 12, 13, 14, None]),
            beam_delay=rng.choice([0, 1]),
            beam=(round(rng.uniform(-13, -1), 2), round(rng.uniform(-8, 8), 2), round(rng.uniform(-1, 1), 2)),
            cycles_before_beam=rng.choice([2, 3, 4]),
        )
        for _ in range(RUNS)
    ]
    starts[0] = {}  # the README's own start
    return starts


def _walk(job: tuple[dict, dict]) -> tuple[float, float, bool]:
    overrides, start = job
    with World(dataclasses.replace(PhysicsConfig(), **overrides)) as world:
        world.set_ball((0.0, 9.0, 0.042))  # out of the way of starts near the centre
        result = calibration_walk.run(world, **start)
    return result.dx, result.dy, result.fell


def _flail(job: tuple[dict, int, float]) -> float:
    overrides, seed, sigma = job
    rng = np.random.default_rng(seed)
    fastest = 0.0
    with World(dataclasses.replace(PhysicsConfig(), **overrides)) as world:
        robot = world.add_robot()
        robot.beam(0.0, 0.0, 0.0)
        for cycle in range(1000):
            if cycle % 10 == 0:
                for joint in JOINTS:
                    robot.command(joint.effector, float(rng.normal(0.0, sigma)))
            world.step()
            fastest = max(fastest, float(np.linalg.norm(robot._velocity)))
    return fastest


def main() -> None:
    p = argparse.ArgumentParser(
        prog="python -m bench.probe_physics", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("probe", choices=("walk", "flail"))
    p.add_argument("--seed", type=whole, default=None, help="walk: start draw (7); flail: first robot's seed (0)")
    p.add_argument("--sigma", type=positive_float, default=3.0, help="flail: spread of the random motor speeds, rad/s")
    p.add_argument("overrides", nargs="*", metavar="name=value")
    args = p.parse_args()
    overrides = {}
    for item in args.overrides:
        name, _, value = item.partition("=")
        if name not in {f.name for f in dataclasses.fields(PhysicsConfig)}:
            p.error(f"{name!r} is not a PhysicsConfig field")
        overrides[name] = json.loads(value)
    with ProcessPoolExecutor(2) as pool:
        if args.probe == "walk":
            seed = 7 if args.seed is None else args.seed
            results = list(pool.map(_walk, [(overrides, s) for s in _starts(seed)]))
            print(f"{overrides or 'defaults'}: {_walk_report(results, _real_outcomes(seed))}")
        else:
            first = 0 if args.seed is None else args.seed
            speeds = list(pool.map(_flail, [(overrides, first + k, args.sigma) for k in range(RUNS)]))
            print(
                f"{overrides or 'defaults'}: {sum(s > 5.0 for s in speeds)}/{RUNS} blow-ups, "
                f"fastest torso {max(speeds):.2f} m/s, median {sorted(speeds)[RUNS // 2]:.2f} m/s"
            )


if __name__ == "__main__":
    main()
