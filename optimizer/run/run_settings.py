"""What a run's settings stand for (its scoring, check, gene box and episodes), and how the flags
given meet the settings a resumed run stored.

The table of settings, their defaults and the upgrade of an older run's: ``optimizer.settings``.
Settings are what decides a run's episodes and are stored in the manifest; ``--resume`` takes them
from there and refuses a flag that contradicts them. How the run is executed (workers, servers,
progress) is not a setting and may change on resume.
"""

from __future__ import annotations

import argparse
import functools
import json
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from gait import DEFAULT_FAMILY, GaitFamily, Steerable, family_named
from optimizer.episode import (
    EpisodeConfig,
)
from optimizer.episode.course import Course
from optimizer.search.config import ScoringConfig, StabilityConfig
from optimizer.settings import Settings, stored_quantile, upgrade


def manifest_settings(manifest: Mapping[str, Any]) -> Settings:
    """The settings of a run folder's manifest, brought up to date (``optimizer.settings.upgrade``):
    a ValueError when the run's command or settings are not one this version can read."""
    command = str(manifest.get("command"))
    stored = upgrade(manifest["settings"], command, manifest.get("settings_version", 0))
    return Settings.from_stored(stored, command)


def stability_config(settings: Settings) -> StabilityConfig:
    """The run's check, and how the walk it hands over is confirmed (``optimizer.run.stability``)."""
    check, hand_over = settings.check, settings.hand_over
    return StabilityConfig(
        repeats=check.repeats, jitter=jitter(settings), confirm=hand_over.confirm, hand_over=hand_over.walks
    )


def scoring_config(settings: Settings) -> ScoringConfig:
    """How the run scores a gait (``optimizer.run.robust``)."""
    scoring = settings.scoring
    return ScoringConfig(
        walks=scoring.walks,
        top=scoring.top,
        quantile=stored_quantile(scoring.quantile),
        jitter=jitter(settings),
    )


def jitter(settings: Settings) -> tuple[float, float, float]:
    """How far the run moves a check walk's start, and a raced walk's but a gait's first."""
    dx, dy, degrees = settings.check.jitter
    return dx, dy, degrees


def search_box(
    settings: Settings, family: GaitFamily | None = None
) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
    """The run's gene bounds and the repair that keeps a chromosome inside them: of the run's own
    family, or of ``family`` (the refinement's), in the run's named box."""
    family = family_named(settings.episode.family) if family is None else family
    bounds = family.boxes[settings.episode.bounds]
    return bounds, functools.partial(family.repair, bounds=bounds)


def in_box(genes: Sequence[float], bounds: np.ndarray) -> bool:
    """Whether ``genes`` lie inside ``bounds`` (edges included): a search starts only from inside
    its box, since the box's repair would move the start before its first walk."""
    values = np.asarray(genes, dtype=float)
    return bool(np.all(values >= bounds[:, 0]) and np.all(values <= bounds[:, 1]))


def course_of(settings: Settings) -> Course | None:
    """The course a run's walks walk (its stored document), None for a run scored by eq. 9."""
    document = settings.scoring.course
    return None if document is None else Course.from_document(document)


def steers(family: GaitFamily) -> bool:
    """Whether ``family``'s gaits take a command (``gait.Steerable``), as a course needs: asked of
    the walker of the middle of its default box, repaired."""
    box = family.bounds
    genes = family.repair(np.asarray(box, dtype=float).mean(axis=1), box)
    try:
        return isinstance(family.walker(tuple(float(g) for g in genes)), Steerable)
    except ValueError:
        return False


def episode_config(
    walk_time: float,
    start: Sequence[float],
    agent_mode: str,
    command_noise: float = 0.0,
    family: str = DEFAULT_FAMILY,
    drift_penalty: float = 0.0,
    course: Course | None = None,
    true_pose: bool = True,
) -> EpisodeConfig:
    """The episodes of a run: a ``course`` puts them on it (``EpisodeConfig.on_course``: its start
    and time limit, scored by the course objective)."""
    x, y, heading = start
    config = EpisodeConfig(
        walk_time=walk_time,
        start=(x, y),
        heading=heading,
        agent_mode=agent_mode,
        command_noise=command_noise,
        family=family,
        drift_penalty=drift_penalty,
        true_pose=true_pose,
    )
    return config if course is None else config.on_course(course)


def _flag(name: str, value: Any) -> str:
    if isinstance(value, bool):
        return f"--{name.replace('_', '-')}" if value else f"--no-{name.replace('_', '-')}"
    if isinstance(value, Mapping):  # a course's document
        text = json.dumps(value)
        return f"--{name.replace('_', '-')} {text if len(text) <= 60 else text[:57] + '...'}"
    shown = " ".join(map(str, value)) if isinstance(value, (list, tuple)) else value
    return f"--{name.replace('_', '-')} {shown}"


def resolve_settings(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    defaults: Mapping[str, Any],
    stored: Mapping[str, Any] | None,
) -> dict[str, Any]:
    """The run's settings: the stored ones on ``--resume`` (a given flag that contradicts one is
    refused), else each given flag or its default. Lists are compared and stored as lists."""
    given = {name: getattr(args, name) for name in defaults if getattr(args, name) is not None}
    given = {k: list(v) if isinstance(v, tuple) else v for k, v in given.items()}
    if stored is None:
        return {**defaults, **given}
    for name, value in given.items():
        if name not in stored:
            parser.error(f"--resume: the run has no setting {name!r}; it was made by another version")
        if value != stored[name]:
            parser.error(f"--resume: {_flag(name, value)} conflicts with the run's {_flag(name, stored[name])}")
    return dict(stored)


def apply_preset(args: argparse.Namespace, values: Mapping[str, Any]) -> None:
    """A preset (a budget) stands for the flags it sets; a flag given on the command line wins."""
    for name, value in values.items():
        if getattr(args, name) is None:
            setattr(args, name, value)
