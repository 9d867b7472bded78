"""What a gait family is: its genes, the box they are searched in, and how genes become joint targets.

A family is data plus three functions, so a new one is a module that builds a ``GaitFamily`` and
registers it (``gait.families``); the agent, the optimizer and the gait files never name a family's
internals. A ``Gait`` is one family's genes, checked once on construction, so an invalid gait never
reaches a robot.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

#: Joint limits by effector name, (min_deg, max_deg), as the agent passes them (``protocol.nao``,
#: which this package does not import so that it stays free of wire concerns).
Limits = Mapping[str, tuple[float, float]]


class Repair(Protocol):
    """Moves a chromosome onto a family's feasible set without leaving ``bounds``."""

    def __call__(self, genes: np.ndarray, bounds: np.ndarray) -> np.ndarray: ...


class Walker(Protocol):
    """One gait, evaluated: joint targets (degrees, by effector name) at any gait time. Stateless,
    so that looking ahead (the action latency) is free."""

    def joint_targets(self, t: float, limits: Limits) -> dict[str, float]: ...


class Command(NamedTuple):
    """What a steerable walker is asked to do: speeds in the torso's own frame, forward (m/s),
    to the left (m/s) and turning left (deg/s). A walker clips it to what its genes allow."""

    forward: float = 0.0
    left: float = 0.0
    turn: float = 0.0


@runtime_checkable
class ArrayWalker(Walker, Protocol):
    """A walker that also gives its targets as an array, in ``target_effectors`` order: the
    agent's path each cycle, which would otherwise read ``joint_targets``' dict into an array."""

    #: the joints of ``joint_target_array``, in its order
    target_effectors: tuple[str, ...]

    def joint_target_array(self, t: float, limits: Limits) -> np.ndarray:
        """``joint_targets``' values, in ``target_effectors`` order (a new array)."""
        ...


#: A vector of three numbers as a perceptor gives it (gyro deg/s, accelerometer m/s^2).
Vec3 = tuple[float, float, float]


@runtime_checkable
class Steerable(Walker, Protocol):
    """A walker that takes a command and feels the robot (an omnidirectional walk engine). It has
    state, so ``joint_targets`` must be asked at non-decreasing times, once a cycle, and
    ``sense`` before it each cycle with that cycle's perception: the engine's own clock runs at
    the time it is asked for (the agent asks two cycles ahead, for the server's action latency).
    At time 0 and whenever it has stopped it stands."""

    #: what it walks now; the agent (or a behaviour) sets it each cycle
    command: Command

    @property
    def max_command(self) -> Command:
        """The largest speeds its genes allow each way (backwards: ``max_backward``)."""
        ...

    @property
    def max_backward(self) -> float:
        """The largest backward speed (m/s, positive)."""
        ...

    def sense(self, gyro: Vec3 | None, acc: Vec3 | None, joints: Mapping[str, float]) -> None:
        """This cycle's gyro (deg/s), accelerometer (m/s^2) and joint angles (deg by perceptor
        name): the feedback that keeps the robot up."""
        ...

    def moved(self) -> Command:
        """Odometry: how far its steps have carried the torso since the last call, as the engine
        planned them (forward m, left m, turn deg; the fields of a ``Command`` as distances)."""
        ...


@dataclass(frozen=True, eq=False, repr=False)
class GaitFamily:
    """A gait family. ``boxes`` names the search boxes the family offers (the first is the default);
    ``check`` raises ValueError for genes no robot should walk; ``repair`` moves a chromosome onto
    the feasible set inside a box (the search operators work gene by gene); ``walker`` evaluates
    checked genes."""

    name: str
    about: str
    gene_names: tuple[str, ...]
    gene_units: Mapping[str, str]
    boxes: Mapping[str, np.ndarray]
    check: Callable[[tuple[float, ...]], None] = field(repr=False)
    repair: Repair = field(repr=False)
    walker: Callable[[tuple[float, ...]], Walker] = field(repr=False)
    #: the family this one extends by further genes, and how a gait of that family becomes the
    #: gait of this one that walks exactly as it does (``from_gait``)
    extends: GaitFamily | None = None
    extend: Callable[[tuple[float, ...]], tuple[float, ...]] | None = field(default=None, repr=False)
    #: genes a refinement keeps at its start gait's values, searching only the others: the part
    #: of a walk the start gait already got right (``gait.tfs_start``)
    held: tuple[int, ...] = ()

    def __repr__(self) -> str:
        return f"GaitFamily({self.name!r})"

    @property
    def default_box(self) -> str:
        return next(iter(self.boxes))

    @property
    def bounds(self) -> np.ndarray:
        """The default search box, (low, high) per gene."""
        return self.boxes[self.default_box]

    def describe(self, genes: Sequence[float]) -> str:
        """Genes as a reader wants them, ``c_h 14.95, c_k 16.83, ...``, whether or not they are a
        gait a robot may walk (a card or a log may hold any)."""
        return ", ".join(f"{n} {g:.4g}" for n, g in zip(self.gene_names, genes))

    def gait(self, genes: Sequence[float] | np.ndarray) -> Gait:
        return Gait(self, tuple(float(g) for g in genes))

    def from_gait(self, gait: Gait) -> Gait:
        """``gait`` as a gait of this family: itself, or, from the family this one extends, the
        same walk as a gait of this family (``extend``). A ValueError otherwise."""
        if gait.family is self:
            return gait
        if gait.family is self.extends and self.extend is not None:
            return self.gait(self.extend(gait.genes))
        raise ValueError(f"a {gait.family.name} gait cannot start a {self.name} search (it extends no such family)")


@dataclass(frozen=True)
class Gait:
    """One gait of one family. Construction checks the genes (their number, that they are finite
    numbers, and the family's own rules)."""

    family: GaitFamily
    genes: tuple[float, ...]

    def __post_init__(self) -> None:
        names = self.family.gene_names
        if len(self.genes) != len(names):
            raise ValueError(
                f"a {self.family.name} gait has {len(names)} genes ({', '.join(names)}), got {len(self.genes)}"
            )
        for name, value in zip(names, self.genes):
            if not isinstance(value, (int, float)) or not np.isfinite(value):
                raise ValueError(f"{self.family.name} gene {name} must be a finite number, got {value!r}")
        object.__setattr__(self, "genes", tuple(float(v) for v in self.genes))  # JSON may give ints
        self.family.check(self.genes)

    @property
    def params(self) -> dict[str, float]:
        """The genes by name, in the family's order."""
        return dict(zip(self.family.gene_names, self.genes))

    def as_array(self) -> np.ndarray:
        return np.array(self.genes, dtype=float)

    def walker(self) -> Walker:
        return self.family.walker(self.genes)

    def describe(self) -> str:
        """The genes as a reader wants them: ``c_h 14.95, c_k 16.83, ...``."""
        return self.family.describe(self.genes)
