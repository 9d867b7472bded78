"""Numbers that steer the search: GA, learning automaton and GALA settings, with the paper's defaults.

Only plain numbers and flags live here, so a run folder can store its configuration as JSON and a
resumed run can check it is replaying the same search. Behaviour (selection, crossover, mutation,
the learning scheme, a constraint repair) is passed as objects to the constructors in ``ga``,
``la`` and ``gala`` instead: a new scheme is then one new function or class, never an edit here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple


@dataclass(frozen=True)
class GAConfig:
    """One GA run (paper section VI: population 100, 10 generations, roulette wheel).

    ``generations`` counts evaluated populations *including* the random initial one: the paper's
    "generation counter greater than 10" is read as 10 evaluated generations, i.e. 1000 episodes
    (991 with elitism, whose carried best is not re-evaluated).
    The default rates are the paper's best pair of Table I (0.8, 0.07).
    ``elitism`` carries the single best individual into the next generation unchanged. It is ON by
    default because the paper's population is *continuing* (GALA keeps one population across 100
    iterations, each with a possibly high mutation rate): without it the best walk found so far can
    be lost to selection noise or mutation. OFF reproduces the plain paper GA.
    """

    population_size: int = 100
    generations: int = 10
    crossover_rate: float = 0.8
    mutation_rate: float = 0.07
    elitism: bool = True

    def __post_init__(self) -> None:
        if self.population_size < 2:
            raise ValueError(f"GAConfig.population_size must be >= 2, got {self.population_size}")
        if self.generations < 1:
            raise ValueError(f"GAConfig.generations must be >= 1, got {self.generations}")
        for name in ("crossover_rate", "mutation_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"GAConfig.{name} must be within [0, 1], got {value}")


@dataclass(frozen=True)
class LAConfig:
    """A variable-structure automaton(r) over mutation rates (paper section VI: automata(10),
    actions 0.00 .. 0.09 by 0.01, reward step a = 0.1, penalty step b = 0.2)."""

    actions: tuple[float, ...] = tuple(round(0.01 * i, 2) for i in range(10))
    reward_step: float = 0.1
    penalty_step: float = 0.2

    def __post_init__(self) -> None:
        if len(self.actions) < 2:
            raise ValueError(f"LAConfig.actions needs at least 2 actions, got {len(self.actions)}")
        if any(not 0.0 <= rate <= 1.0 for rate in self.actions):
            raise ValueError(f"LAConfig.actions are mutation rates and must be within [0, 1], got {self.actions}")
        for name in ("reward_step", "penalty_step"):
            value = getattr(self, name)
            if not 0.0 < value <= 1.0:
                raise ValueError(f"LAConfig.{name} must be within (0, 1], got {value}")


@dataclass(frozen=True)
class GALAConfig:
    """GALA for one crossover rate (paper section V-VI), and the sweep of crossover rates of Table I.

    Each of ``iterations`` iterations runs ``generations_per_iteration`` generations on one
    continuing population; ``restart_each_iteration`` takes the other reading, a fresh GA of
    ``ga.generations`` generations per iteration. ``ga.generations`` is also the length of the
    final GA run with the learnt mutation rate. ``ga.crossover_rate`` and ``ga.mutation_rate`` are
    ignored: GALA is given its crossover rate and learns the mutation rate.
    """

    ga: GAConfig = field(default_factory=GAConfig)
    la: LAConfig = field(default_factory=LAConfig)
    iterations: int = 100
    generations_per_iteration: int = 1
    restart_each_iteration: bool = False
    #: Feedback baseline: None compares an iteration's best with the average of ALL preceding
    #: bests (the paper). With a continuing elitist population that average lags behind, so
    #: nearly every iteration is rewarded and the automaton learns little (measured on synthetic
    #: fitness: 97 rewards in 99 iterations); k compares with the average of the last k bests.
    baseline_window: int | None = None
    crossover_rates: tuple[float, ...] = tuple(round(0.1 * i, 1) for i in range(1, 10))

    def __post_init__(self) -> None:
        if self.iterations < 1:
            raise ValueError(f"GALAConfig.iterations must be >= 1, got {self.iterations}")
        if self.generations_per_iteration < 1:
            raise ValueError(f"GALAConfig.generations_per_iteration must be >= 1, got {self.generations_per_iteration}")
        if self.baseline_window is not None and self.baseline_window < 1:
            raise ValueError(f"GALAConfig.baseline_window must be >= 1 or None, got {self.baseline_window}")
        if any(not 0.0 <= rate <= 1.0 for rate in self.crossover_rates):
            raise ValueError(f"GALAConfig.crossover_rates must be within [0, 1], got {self.crossover_rates}")


class RatePreset(NamedTuple):
    """A published (crossover, mutation) pair the paper compares GALA against."""

    name: str
    crossover_rate: float
    mutation_rate: float


#: De Jong's rates as quoted by the paper (its Fig. 4: 0.54 m in 15 s).
DE_JONG = RatePreset("De Jong", 0.6, 0.001)
#: Grefenstette's rates as quoted by the paper (its Fig. 5: 4.12 m in 15 s).
GREFENSTETTE = RatePreset("Grefenstette", 0.95, 0.01)
#: The pair GALA found best in the paper's Table I (its Fig. 7: 4.95 m in 15 s).
PAPER_GALA_BEST = RatePreset("GALA (paper Table I)", 0.8, 0.07)


@dataclass(frozen=True)
class StabilityConfig:
    """The stability check of a found gait (``optimizer.run.stability``): ``repeats`` walks, each
    with its own draw of the run's command dither, from starts moved by up to +-``jitter`` (x m,
    y m, heading deg): the perturbation its search scored its raced walks by. For the fastest
    stable gait, the ``candidates`` best-scored gaits of the run are checked. ``repeats`` 0 turns
    the check off.

    The default jitter is the real server's default beam noise (``BeamNoiseXY`` 0.05 m,
    ``BeamNoiseAngle`` 10 deg, uniform): the starts a gait meets on a stock rcssserver3d. It adds
    what the dither alone misses: a quick run's fastest gait that held 10 dithered walks from
    the run's start fell in 3 of 10 from moved starts (docs/optimizer.md, "The stability check").

    Ten repeats, from measurement on the real server (rcssserver3d 0.7.3, sync profile, 30 walks
    of each of three gaits from one start): its run-to-run spread of the 15-s distance was 0.05%
    to 5.2% (coefficient of variation), so the mean of ten is within ~1.6% (one standard error);
    and a gait that falls one walk in five passes ten walks without a fall only 11% of the time
    (0.8^10), where it would pass a single walk 80% of the time.

    ``confirm`` more walks are asked of each candidate for the fastest gait that held its
    ``repeats``, before it may be handed over. Picking the best of ten candidates by ten walks
    each favours the one that was luckiest in them (docs/optimizer.md, "The hand-over"). Thirty
    walks without a fall pass
    a gait that falls one walk in ten 4% of the time (0.9^30), ten walks 35%.

    ``hand_over`` walks in all are asked of the gait a run hands over at its end: the confirmed
    candidates walk on towards that many, best first, ``repeats`` at a time and no further once one
    fell, until one holds them all. Thirty walks cannot tell a walk that falls once in 30 from one
    that does not, and the stand-in shows such rare falls as often as the real server does (six
    handed-over walks, 70-500 fresh walks on each server: 0.6% and 0.8%, 3.7% and 3.2%, 0.3% and
    0.4%, 0 and 0, 4% and 4%, 0.7% and 0.6%; docs/optimizer.md, "The hand-over"). A hundred walks
    were not enough either: trying the candidates one after another until one holds favours the
    luckiest again (one held 100 walks and then fell in 11 of 300 more). Two hundred walks without
    a fall pass a gait that falls one walk in 30 once in 900 tries (0.967^200), one that falls once
    in 200 a third of the time.
    """

    repeats: int = 10
    jitter: tuple[float, float, float] = (0.05, 0.05, 10.0)
    candidates: int = 10
    confirm: int = 20
    hand_over: int = 200

    def __post_init__(self) -> None:
        if self.repeats < 0:
            raise ValueError(f"StabilityConfig.repeats must be >= 0, got {self.repeats}")
        if len(self.jitter) != 3 or any(not 0.0 <= j < float("inf") for j in self.jitter):
            raise ValueError(f"StabilityConfig.jitter must be three finite values >= 0, got {self.jitter}")
        if self.candidates < 1:
            raise ValueError(f"StabilityConfig.candidates must be >= 1, got {self.candidates}")
        if self.confirm < 0:
            raise ValueError(f"StabilityConfig.confirm must be >= 0, got {self.confirm}")
        if self.hand_over < 0:
            raise ValueError(f"StabilityConfig.hand_over must be >= 0, got {self.hand_over}")


@dataclass(frozen=True)
class ScoringConfig:
    """How a search scores a gait (``optimizer.run.robust``).

    ``walks`` 1 is the paper's eq. 9: one walk, its fitness 10 x the distance. ``walks`` k > 1 scores
    a gait over k walks, each drawn from the real server's run-to-run spread by the agent's command
    dither (the run's ``command_noise``), so that a search cannot win by one lucky walk. The k walks
    are raced: every gait walks once, and only a gait whose first walk could put it among the
    ``top`` best scores of its search so far walks the other k - 1 times.

    The score of k walks is the ``quantile`` of their eq. 9 fitness (None: their mean). The
    default, the 0.25 quantile of 5, is the second-worst walk: one bad draw in five is forgiven,
    two are not, so a gait that falls in a third of its walks scores what it walks when it falls.
    Each walk keeps eq. 9's count of a fall (the distance reached), which gives a population of
    falling gaits its slope towards walking; a discount of falls by the time stood was tried and
    dropped, since it led the first generations to gaits that stand still (docs/optimizer.md).
    """

    walks: int = 5
    top: int = 3
    quantile: float | None = 0.25
    #: Where a gait's walks after its first start: moved within +-jitter (x m, y m, heading deg)
    #: of the run's start, as its check walks are (``StabilityConfig.jitter``); its first walk,
    #: the one racing judges, starts at the run's start.
    jitter: tuple[float, float, float] = (0.05, 0.05, 10.0)
    #: Walks in all of a gait whose score of k walks would make it its search's best (0: none
    #: more): its score is then taken over all of them. k walks scored by the worst cannot see a
    #: gait that falls once in 30 walks (it passes five 84% of the time), and a search's best is
    #: where it restarts from and what its hand-over checks first (docs/optimizer.md, "Leaders").
    lead_walks: int = 0

    def __post_init__(self) -> None:
        if self.walks < 1:
            raise ValueError(f"ScoringConfig.walks must be >= 1, got {self.walks}")
        if self.lead_walks and self.lead_walks <= self.walks:
            raise ValueError(
                f"ScoringConfig.lead_walks must be 0 or more than walks ({self.walks}), got {self.lead_walks}"
            )
        if self.top < 1:
            raise ValueError(f"ScoringConfig.top must be >= 1, got {self.top}")
        if self.quantile is not None and not 0.0 <= self.quantile <= 1.0:
            raise ValueError(f"ScoringConfig.quantile must be within [0, 1], got {self.quantile}")

    @property
    def robust(self) -> bool:
        return self.walks > 1
