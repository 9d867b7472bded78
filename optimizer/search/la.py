"""Variable-structure learning automata (paper section IV-B).

An automaton keeps a probability vector over r actions, picks an action by roulette wheel and moves
the probabilities on a reward (beta = 0) or a penalty (beta = 1). How it moves them is the learning
scheme: a class with one ``update(p, i, rewarded) -> new p`` method, so a new scheme is one new
class. L_R-P (eq. 7-8) is what GALA uses; L_R-I (eq. 6) is the option.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np


class LearningScheme(Protocol):
    """Updates the action probabilities after action ``i`` was rewarded or penalised."""

    def update(self, p: np.ndarray, i: int, rewarded: bool) -> np.ndarray: ...


def _check_step(name: str, value: float) -> None:
    if not 0.0 < value <= 1.0:
        raise ValueError(f"{name} must be within (0, 1], got {value}")


def _reward(p: np.ndarray, i: int, a: float) -> np.ndarray:
    """Eq. 6/7: p_i + a (1 - p_i) for the chosen action, p_j (1 - a) for the others."""
    new = p * (1.0 - a)
    new[i] = p[i] + a * (1.0 - p[i])
    return new


@dataclass(frozen=True)
class LinearRewardPenalty:
    """L_R-P: reward by eq. 7 with step ``a``; penalty by eq. 8 with step ``b``, which takes
    b * p_i from the chosen action and spreads b / (r - 1) over the others."""

    a: float
    b: float

    def __post_init__(self) -> None:
        _check_step("L_R-P reward step a", self.a)
        _check_step("L_R-P penalty step b", self.b)

    def update(self, p: np.ndarray, i: int, rewarded: bool) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        if rewarded:
            return _reward(p, i, self.a)
        new = self.b / (p.size - 1) + (1.0 - self.b) * p
        new[i] = p[i] * (1.0 - self.b)
        return new


@dataclass(frozen=True)
class LinearRewardInaction:
    """L_R-I: reward by eq. 6 with step ``a``; a penalty leaves p unchanged."""

    a: float

    def __post_init__(self) -> None:
        _check_step("L_R-I reward step a", self.a)

    def update(self, p: np.ndarray, i: int, rewarded: bool) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        return _reward(p, i, self.a) if rewarded else p.copy()


class LearningAutomaton:
    """automata(r): r actions, all equally likely at the start (paper section V), roulette choice.

    The vector is not renormalised after an update: both linear schemes map a sum S to
    (1 - a) S + a or (1 - b) S + b, so a rounding error in the sum shrinks at every step instead of
    drifting, and L_R-I's "unchanged on penalty" stays exact.
    """

    def __init__(self, actions: Sequence[float], scheme: LearningScheme, rng: np.random.Generator) -> None:
        if len(actions) < 2:
            raise ValueError(f"a learning automaton needs at least 2 actions, got {len(actions)}")
        self.actions = tuple(actions)
        self.scheme = scheme
        self._rng = rng
        self.probabilities = np.full(len(actions), 1.0 / len(actions))

    def choose(self) -> int:
        """Index of an action drawn by roulette wheel on the current probabilities."""
        return int(self._rng.choice(len(self.actions), p=self.probabilities))

    def update(self, i: int, rewarded: bool) -> None:
        if not 0 <= i < len(self.actions):
            raise ValueError(f"action index {i} out of range for {len(self.actions)} actions")
        self.probabilities = self.scheme.update(self.probabilities, i, rewarded)

    def best_action(self) -> int:
        """The action of highest probability (the lowest index on a tie)."""
        return int(np.argmax(self.probabilities))
