"""Make the fidelity benchmark's gait sets (``bench/fidelity_gaits/training.json``, ``held_aside.json``).

The sets must hold what a search meets and what the stand-in gets wrong, so they are
drawn from five families and screened on a real rcssserver3d (one walk each, recorded with the gait):

- ``line``: the straight line in gene space from the shipped gait to the fast real walk
  (``FAST_REAL``, 13.3 m in 15 s), in ``--line-steps`` equal steps, ends included;
- ``neighbour``: gaits around fast real walks (``FAST_REAL`` and the fastest distinct walks that
  did not fall in a GALA run on real servers, ``--real-run``) at several radii, the radius a
  fraction of each gene's range, in a random direction; kept whatever they do;
- ``random``: uniform in the search box (``gait.GENE_BOUNDS``, through ``gait.repair_genes``),
  kept only when the real server does not see them fall within ``--random-min-time`` s;
- ``found``: the fastest distinct walks that did not fall in a GALA run on the stand-in
  (``--stub-run``): what the optimizer finds today;
- ``turning``: neighbours of walking gaits with A and B pulled apart, kept when they walk
  without a fall on the real server and turn the most there (at least ``--min-turn`` deg).

The union is split into training and held-aside parts (about 2/3 and 1/3) by a seeded shuffle
within each family, so each family is in both. Everything is seeded (``--seed``); a remake with
the same seed and run folders draws the same candidates (the real server's screen walks vary a
few per cent, so a gait near a threshold can go either way).

    python -m bench.make_fidelity_gaits --real-run runs/real-pc0.8 --stub-run runs/stub-pc0.8
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from bench.fidelity import (
    FAST_REAL,
    GAIT_SET_DIR,
    FidelityConfig,
    FidelityGait,
    Walk,
    print_progress,
    real_server_or_none,
    save_gait_set,
    walk_gaits,
)
from gait import GENE_BOUNDS, GENE_NAMES, load_gait, repair_genes
from optimizer.episode import EpisodeRunner
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.runner import quiet_agent_logs
from optimizer.run.folder import EPISODES, read_episode_log

#: Each gene's range: distances in gene space are in these units, so no gene dominates.
_SPAN = GENE_BOUNDS[:, 1] - GENE_BOUNDS[:, 0]


def _genes(values: Sequence[float]) -> tuple[float, ...]:
    return tuple(round(float(v), 4) for v in repair_genes(np.asarray(values, dtype=float)))


def _fastest_distinct(run: Path, count: int, min_separation: float) -> list[tuple[tuple[float, ...], float, str]]:
    """The ``count`` fastest walks of a run's ``episodes.jsonl`` that did not fall, each at least
    ``min_separation`` (in gene ranges) from the ones kept before: (genes, distance, key)."""
    records = [r for r in read_episode_log(run / EPISODES)[0].values() if r.stood]
    records.sort(key=lambda r: (-r.distance, r.key))
    kept: list[tuple[tuple[float, ...], float, str]] = []
    for record in records:
        genes = np.asarray(record.genes, dtype=float)
        if all(np.linalg.norm((genes - np.asarray(g)) / _SPAN) >= min_separation for g, _, _ in kept):
            kept.append((_genes(genes), record.distance, record.key))
        if len(kept) == count:
            break
    return kept


def _around(centre: Sequence[float], radius: float, rng: np.random.Generator) -> tuple[float, ...]:
    """A point at ``radius`` (a fraction of each gene's range) from ``centre`` in a random direction."""
    direction = rng.normal(size=len(_SPAN))
    direction /= np.linalg.norm(direction)
    return _genes(np.asarray(centre) + radius * direction * _SPAN)


def _screen(runner: EpisodeRunner, gaits: list[FidelityGait]) -> list[tuple[FidelityGait, Walk]]:
    """One real walk of each gait, recorded on the gait (``screen``)."""
    walks = walk_gaits(runner, gaits, 1, print_progress, "screen")
    out = []
    for gait, (walk,) in zip(gaits, walks):
        screen = {
            "real_distance": round(walk.distance, 3),
            "real_fell": walk.fell,
            "real_time": round(walk.time, 2),
            "real_heading_change": round(walk.heading_change, 1),
            "real_drift": round(walk.drift, 3),
        }
        out.append((FidelityGait(gait.name, gait.family, gait.genes, gait.how, screen), walk))
    return out


def _split(
    gaits: list[FidelityGait], seed: int, training_share: float
) -> tuple[list[FidelityGait], list[FidelityGait]]:
    """Training and held-aside parts: a seeded shuffle within each family, ``training_share`` of
    each (rounded) to training."""
    rng = np.random.default_rng(seed)
    training: list[FidelityGait] = []
    held: list[FidelityGait] = []
    for family in dict.fromkeys(g.family for g in gaits):
        members = [g for g in gaits if g.family == family]
        order = rng.permutation(len(members))
        cut = round(training_share * len(members))
        training += [members[i] for i in sorted(order[:cut])]
        held += [members[i] for i in sorted(order[cut:])]
    return training, held


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m bench.make_fidelity_gaits",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--seed", type=int, default=15)
    p.add_argument("--real-run", type=Path, required=True, help="a GALA run folder walked on real servers")
    p.add_argument("--stub-run", type=Path, required=True, help="a GALA run folder walked on the stand-in")
    p.add_argument("--out", type=Path, default=GAIT_SET_DIR)
    p.add_argument("--line-steps", type=int, default=10)
    p.add_argument("--radii", type=float, nargs="+", default=[0.02, 0.05, 0.10])
    p.add_argument("--per-radius", type=int, default=2, help="neighbours per centre and radius")
    p.add_argument("--fast-centres", type=int, default=2, help="fast walks taken from --real-run besides FAST_REAL")
    p.add_argument("--random", type=int, default=8, help="random gaits to keep")
    p.add_argument("--random-tries", type=int, default=160)
    p.add_argument("--random-min-time", type=float, default=2.0)
    p.add_argument("--found", type=int, default=5)
    p.add_argument("--turning", type=int, default=6, help="turning gaits to keep")
    p.add_argument("--turning-tries", type=int, default=30)
    p.add_argument("--min-turn", type=float, default=10.0)
    p.add_argument("--training-share", type=float, default=2 / 3)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    command = real_server_or_none()
    quiet_agent_logs()
    if command is None:
        return 1
    rng = np.random.default_rng(args.seed)
    shipped = np.asarray(load_gait().as_array())
    fast = np.asarray(FAST_REAL)
    gaits: list[FidelityGait] = []

    for i in range(args.line_steps + 1):
        s = i / args.line_steps
        gaits.append(
            FidelityGait(
                f"line-{i:02d}",
                "line",
                _genes(shipped + s * (fast - shipped)),
                f"shipped gait + {s:.2f} x (FAST_REAL - shipped gait)",
            )
        )

    centres = [("fast", FAST_REAL, "FAST_REAL (13.26 m on the real server)")]
    for j, (genes, distance, key) in enumerate(_fastest_distinct(args.real_run, args.fast_centres, 0.15)):
        centres.append((f"realrun{j}", genes, f"{args.real_run.name} {key}: {distance:.2f} m on the real server"))
    for name, genes, what in centres:
        if name != "fast":
            gaits.append(FidelityGait(f"centre-{name}", "neighbour", genes, what + " (the centre itself)"))
        for radius in args.radii:
            for k in range(args.per_radius):
                gaits.append(
                    FidelityGait(
                        f"near-{name}-r{radius:g}-{k}",
                        "neighbour",
                        _around(genes, radius, rng),
                        f"{radius:g} x each gene's range from {what}, random direction",
                    )
                )

    for j, (genes, distance, key) in enumerate(_fastest_distinct(args.stub_run, args.found, 0.05)):
        gaits.append(
            FidelityGait(
                f"found-stub{j}",
                "found",
                genes,
                f"{args.stub_run.name} {key}: {distance:.2f} m on the stand-in, no fall",
            )
        )

    config = FidelityConfig()
    with EpisodeRunner(config.episode_config(), RealServerProcess(command), trace=True) as runner:
        kept = [g for g, _ in _screen(runner, gaits)]

        random_kept: list[FidelityGait] = []
        for t in range(args.random_tries):
            if len(random_kept) == args.random:
                break
            genes = _genes(rng.uniform(GENE_BOUNDS[:, 0], GENE_BOUNDS[:, 1]))
            [(gait, walk)] = _screen(
                runner,
                [
                    FidelityGait(
                        f"random-{t:03d}",
                        "random",
                        genes,
                        f"uniform in GENE_BOUNDS, draw {t} of seed {args.seed}; "
                        f"kept: no fall within {args.random_min_time:g} s",
                    )
                ],
            )
            if walk.status == "ok" and (not walk.fell or walk.time >= args.random_min_time):
                random_kept.append(gait)
        kept += random_kept

        # turning: walking gaits (real, no fall) as bases, A and B pulled apart, a small random step
        bases = [g for g in kept if g.screen.get("real_fell") is False and g.screen["real_distance"] >= 2.0]
        candidates = []
        for t in range(args.turning_tries):
            base = bases[int(rng.integers(len(bases)))]
            genes = np.asarray(_around(base.genes, 0.03, rng))
            pull = rng.uniform(0.2, 0.5) * (genes[2] + genes[3]) / 2
            sign = 1 if rng.random() < 0.5 else -1
            genes[2] += sign * pull
            genes[3] -= sign * pull
            candidates.append(
                FidelityGait(
                    f"turn-{t:02d}",
                    "turning",
                    _genes(genes),
                    f"{base.name} moved 0.03 of the ranges, A {'+' if sign > 0 else '-'}"
                    f"{pull:.1f} deg and B the other way",
                )
            )
        screened = _screen(runner, candidates)
    turners = sorted(
        ((g, w) for g, w in screened if w.status == "ok" and not w.fell and abs(w.heading_change) >= args.min_turn),
        key=lambda gw: -abs(gw[1].heading_change),
    )
    kept += [g for g, _ in turners[: args.turning]]

    training, held = _split(kept, args.seed, args.training_share)
    about = {
        "made_by": "python -m bench.make_fidelity_gaits " + " ".join(sys.argv[1:] if argv is None else argv),
        "seed": args.seed,
        "gene_names": list(GENE_NAMES),
        "real_server": command,
        "screen": "one 15-s walk on the real server from (-5, 0, 0), sync profile",
    }
    save_gait_set(args.out / "training.json", "training", training, about)
    save_gait_set(args.out / "held_aside.json", "held_aside", held, about)
    families = {f: sum(g.family == f for g in kept) for f in dict.fromkeys(g.family for g in kept)}
    print(
        f"{len(kept)} gaits ({families}): {len(training)} training, {len(held)} held aside; "
        f"random kept {len(random_kept)}, turning kept {len(turners[: args.turning])} of {len(turners)} that turned "
        f">= {args.min_turn:g} deg; written to {args.out}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
