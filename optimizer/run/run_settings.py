"""What a run's stored settings mean: their defaults, how a stored run is resumed, and the configs
(scoring, check, gene box, episode) the settings stand for.

Settings are what decides a run's episodes (search numbers, walk time, agent mode) and are stored
in the manifest; ``--resume`` takes them from there and refuses a flag that contradicts them.
How the run is executed (workers, servers, progress) is not a setting and may change on resume.
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from gait import DEFAULT_FAMILY, GaitFamily, family_named
from optimizer.episode import (
    CALIBRATED_COMMAND_NOISE,
    DEFAULT_START,
    EpisodeConfig,
)
from optimizer.search.config import ScoringConfig, StabilityConfig

#: How the settings store "score by the mean" (None would read as "not given").
MEAN = "mean"


def stored_quantile(value: float | str | None) -> float | None:
    """A quantile setting as ``ScoringConfig`` takes it: the stored ``MEAN`` (the one text a quantile
    setting holds, ``quantile_or_mean``) is None, the mean."""
    return None if isinstance(value, str) else value


#: Defaults of the check settings the commands store.
CHECK_DEFAULTS: dict[str, Any] = {
    "check_repeats": StabilityConfig().repeats,
    "check_jitter": list(StabilityConfig().jitter),
}


#: Defaults of the settings of a command that hands over a fastest walk (``fastest_walk``).
HAND_OVER_DEFAULTS: dict[str, Any] = {
    "check_confirm": StabilityConfig().confirm,
    "hand_over_walks": StabilityConfig().hand_over,
}


#: Defaults of the scoring settings the commands store.
SCORING_DEFAULTS: dict[str, Any] = {
    "robust_walks": ScoringConfig().walks,
    "robust_top": ScoringConfig().top,
    "robust_quantile": ScoringConfig().quantile,
    "command_noise": CALIBRATED_COMMAND_NOISE,
    "drift_penalty": 0.0,
}


#: What a run made before robust scoring stored nothing about: one undithered walk a gait, and
#: checks from starts moved within the real server's beam noise.
LEGACY_SCORING: dict[str, Any] = {"robust_walks": 1, "robust_quantile": MEAN, "command_noise": 0.0}


_LEGACY_JITTER = (0.05, 0.05, 10.0)


def stability_config(settings: Mapping[str, Any]) -> StabilityConfig:
    """The run's check; a run made before checks existed has none, one made before confirming walks
    hands over on its candidates' checks alone, one made before hand-over walks on its confirmed ones."""
    return StabilityConfig(
        repeats=settings.get("check_repeats", 0),
        jitter=tuple(settings.get("check_jitter", _LEGACY_JITTER)),
        confirm=settings.get("check_confirm", 0),
        hand_over=settings.get("hand_over_walks", 0),
    )


def scoring_config(settings: Mapping[str, Any]) -> ScoringConfig:
    """The run's scoring; a run made before robust scoring scored by one walk."""
    quantile = settings.get("robust_quantile", LEGACY_SCORING["robust_quantile"])
    return ScoringConfig(
        walks=settings.get("robust_walks", LEGACY_SCORING["robust_walks"]),
        top=settings.get("robust_top", ScoringConfig().top),
        quantile=stored_quantile(quantile),
        jitter=stability_config(settings).jitter,
    )


#: The family and gene box a new run searches; a run folder without the settings searched the TFS
#: family, in the legacy box.
BOUNDS_DEFAULTS: dict[str, Any] = {"family": DEFAULT_FAMILY, "bounds": "robot"}


def run_family(settings: Mapping[str, Any]) -> str:
    """The run's gait family (a run from before families: the paper's TFS)."""
    return str(settings.get("family", DEFAULT_FAMILY))


def search_box(
    settings: Mapping[str, Any], family: GaitFamily | None = None
) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
    """The run's gene bounds and the repair that keeps a chromosome inside them: of the run's own
    family, or of ``family`` (the refinement's), in the run's named box."""
    family = family_named(run_family(settings)) if family is None else family
    bounds = family.boxes[settings.get("bounds", "legacy")]
    return bounds, functools.partial(family.repair, bounds=bounds)


def in_box(genes: Sequence[float], bounds: np.ndarray) -> bool:
    """Whether ``genes`` lie inside ``bounds`` (edges included): a search starts only from inside
    its box, since the box's repair would move the start before its first walk."""
    values = np.asarray(genes, dtype=float)
    return bool(np.all(values >= bounds[:, 0]) and np.all(values <= bounds[:, 1]))


#: Defaults of the episode settings every command stores.
EPISODE_DEFAULTS: dict[str, Any] = {"walk_time": 15.0, "start": list(DEFAULT_START), "agent_mode": "inprocess"}


#: Where runs made before ``--start`` existed started.
LEGACY_START: tuple[float, float, float] = (0.0, 0.0, 0.0)


def episode_config(
    walk_time: float,
    start: Sequence[float],
    agent_mode: str,
    command_noise: float = 0.0,
    family: str = DEFAULT_FAMILY,
    drift_penalty: float = 0.0,
) -> EpisodeConfig:
    x, y, heading = start
    return EpisodeConfig(
        walk_time=walk_time,
        start=(x, y),
        heading=heading,
        agent_mode=agent_mode,
        command_noise=command_noise,
        family=family,
        drift_penalty=drift_penalty,
    )


def _flag(name: str, value: Any) -> str:
    if isinstance(value, bool):
        return f"--{name.replace('_', '-')}" if value else f"--no-{name.replace('_', '-')}"
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
