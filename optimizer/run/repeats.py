"""One gait walked again and again (``python -m optimizer.episode --repeat N``): from moved
starts, one runner for all the walks, and what they add up to.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from gait import Gait
from optimizer.episode.config import EpisodeConfig, Start
from optimizer.episode.course import leg_durations
from optimizer.episode.runner import EpisodeResult, EpisodeRunner, quiet_agent_logs
from optimizer.episode.servers import ManagedServer, ServerAddress
from optimizer.run.stability import distance_spread


def walk_from(
    gait: Gait,
    base: EpisodeConfig,
    server: ServerAddress | ManagedServer | None,
    points: Sequence[Start],
    seed: int,
    report: Callable[[Start, EpisodeResult], None],
) -> list[EpisodeResult]:
    """Walk ``gait`` from each of ``points`` on one runner, telling ``report`` each walk as it ends."""
    results = []
    quiet_agent_logs()  # each walk's outcome is reported instead
    with EpisodeRunner(base, server, seed=seed) as runner:
        for point in points:
            result = runner.evaluate(gait, start=point)
            results.append(result)
            report(point, result)
    return results


def describe(result: EpisodeResult) -> str:
    """One walk in a line: how far, how long, whether it fell, its fitness and speed (a course
    walk: whether it finished, in what time, the poses reached and each leg's time)."""
    if result.finished is not None:
        legs = " ".join(f"{t:.2f}" for t in leg_durations(result.legs or ()))
        return (
            f"{'finished' if result.finished else 'did not finish'} in {result.time:.2f} s "
            f"({'fell' if result.fell else 'did not fall'}); {result.reached} poses reached, legs {legs or '-'} s; "
            f"fitness {result.fitness:.4f}"
        )
    return (
        f"distance {result.distance:.3f} m in {result.time:.2f} s walked "
        f"({'fell' if result.fell else 'did not fall'}); fitness {result.fitness:.4f}; "
        f"mean speed {result.mean_speed:.3f} m/s"
    )


def summary(results: Sequence[EpisodeResult]) -> str:
    """One line over repeated walks: how many fell, the spread of the distances."""
    ran = [r for r in results if r.status == "ok"]
    spread = distance_spread([r.distance for r in ran])
    if spread is None:
        return f"{len(results)} walks, none could be run"
    shortest, longest, mean = spread
    if any(r.finished is not None for r in ran):  # a course: the time of the walks that finished counts
        times = [r.time for r in ran if r.finished]
        timed = f" in {min(times):.2f}-{max(times):.2f} s, mean {sum(times) / len(times):.2f} s" if times else ""
        return (
            f"{len(ran)} walks: {sum(r.fell for r in ran)} fell; {len(times)} finished{timed}; "
            f"metres of course done {shortest:.3f}-{longest:.3f}"
            + (f"; {len(results) - len(ran)} could not be run" if len(ran) < len(results) else "")
        )
    return (
        f"{len(ran)} walks: {sum(r.fell for r in ran)} fell; distance {shortest:.3f}-"
        f"{longest:.3f} m, mean {mean:.3f} m; mean speed "
        f"{sum(r.mean_speed for r in ran) / len(ran):.3f} m/s"
        + (f"; {len(results) - len(ran)} could not be run" if len(ran) < len(results) else "")
    )
