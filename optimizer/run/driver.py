"""Driving a keyed search: ask, answer from the episode log or evaluate, log, tell.

Resuming is replaying: the search is rebuilt from its seed and driven from the start; every
candidate whose key is already in the log is answered from it, the rest are evaluated and logged.
Because the search is a deterministic function of its seed and its answers, the replay reaches
exactly the state of an uninterrupted run, and no episode is ever run twice.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from tqdm import tqdm

from optimizer.episode import DEFAULT_START, Start
from optimizer.evaluation.pool import EpisodeTask, Evaluator
from optimizer.evaluation.record import EpisodeRecord, WalkKind
from optimizer.run.folder import EpisodeLog
from optimizer.run.robust import Race, ScoredGait, extra_key, moved_starts
from optimizer.search.config import ScoringConfig
from optimizer.search.protocol import AskTellSearch
from optimizer.seeds import stable_seed


class ResumeMismatch(RuntimeError):
    """The log answers a key whose logged genes differ from what the replayed search asks: the
    log belongs to other settings, seed or code, and replaying it would mix two searches."""


class Progress(Protocol):
    """Hears about the drive: a batch about to be evaluated, each episode as it is logged, each
    candidate's score as its search is told it."""

    def batch(self, prefix: str) -> None: ...

    def episode(self, record: EpisodeRecord) -> None: ...

    def scored(self, fitness: float) -> None: ...

    def plan(self, remaining: int) -> None: ...


class Driver:
    """Runs searches against one evaluator and one episode log (a run may drive several searches,
    e.g. one GALA per crossover rate, through the same driver: keys never collide).

    Candidates are scored as ``scoring`` says (``optimizer.run.robust``: one walk, or k dithered
    walks raced). ``scored`` keeps every candidate scored so far, by key: where a run finds its
    best gaits."""

    def __init__(
        self,
        evaluator: Evaluator,
        log: EpisodeLog,
        run_seed: int,
        progress: Progress | None = None,
        scoring: ScoringConfig = ScoringConfig(walks=1),
        start: Start = DEFAULT_START,
    ) -> None:
        self.evaluator = evaluator
        self.log = log
        self.run_seed = run_seed
        self.progress = progress
        self.scoring = scoring
        #: the run's start, around which a gait's raced walks are moved (``ScoringConfig.jitter``)
        self.start = start
        #: every candidate scored, by key, in the order scored
        self.scored: dict[str, ScoredGait] = {}
        #: episodes this driver evaluated (not replayed from the log)
        self.evaluated = 0

    def run(self, search: AskTellSearch, race: Race | None = None, family: str | None = None) -> Any:
        """Drive ``search`` to the end and return its ``result()``; ``race``: the race it goes on
        with (a search run in stages keeps its bar), else a fresh one; ``family``: its genes' gait
        family, where it is not the run's."""
        race = self.race() if race is None else race
        while not search.done:
            scored = self.score([(c.key, c.genes) for c in search.ask()], race, family)
            search.tell({s.key: s.fitness for s in scored})
        return search.result()

    def replan(self, remaining: int) -> None:
        """Tell the progress how many episodes are now expected after those walked so far (a run's
        next stages are estimated better once its earlier stages have walked)."""
        if self.progress is not None:
            self.progress.plan(remaining)

    def walks_per_gait(self) -> float:
        """Episodes a scored gait walked on average so far (racing walks some gaits several
        times): what an estimate of a later search's episodes multiplies its gaits by."""
        if not self.scored:
            return 1.0
        return sum(len(s.walks) for s in self.scored.values()) / len(self.scored)

    def race(self) -> Race:
        """A fresh race for one search."""
        return Race(self.scoring)

    def score(
        self,
        candidates: Sequence[tuple[str, Sequence[float] | np.ndarray]],
        race: Race,
        family: str | None = None,
    ) -> list[ScoredGait]:
        """Score a batch: every candidate walks once, then, round by round, those ``race``
        chooses walk the rest of their k walks (each round one more batch) and their scores join
        the race, until it chooses none; then, round by round, its leaders walk on."""
        firsts = self.walk([self.task(key, genes, family=family) for key, genes in candidates])
        walks = {key: [firsts[key]] for key, _ in candidates}
        genes_of = {key: genes for key, genes in candidates}
        k, lead = race.config.walks, race.config.lead_walks
        while chosen := race.choose([(key, firsts[key]) for key, _ in candidates if len(walks[key]) == 1]):
            walks.update(self._walk_on(chosen, walks, genes_of, k, race.config.jitter, family))
            for key in chosen:
                race.enter(race.score(walks[key]))
        while chosen := race.leaders([(key, race.score(w)) for key, w in walks.items() if len(w) == k]):
            walks.update(self._walk_on(chosen, walks, genes_of, lead, race.config.jitter, family))
            for key in chosen:
                race.lead(race.score(walks[key]))
        out = []
        for key, _ in candidates:
            scored = ScoredGait(key, firsts[key].genes, race.score(walks[key]), tuple(walks[key]), family)
            self.scored[key] = scored
            out.append(scored)
            if self.progress is not None:
                self.progress.scored(scored.fitness)
        return out

    def _walk_on(
        self,
        keys: Sequence[str],
        walks: dict[str, list[EpisodeRecord]],
        genes_of: dict[str, Sequence[float] | np.ndarray],
        total: int,
        jitter: Sequence[float],
        family: str | None,
    ) -> dict[str, list[EpisodeRecord]]:
        """The walks of these candidates gone on to ``total`` each, walked as one batch: their walks
        after the first from starts moved as their check's are, the same starts however far a
        candidate goes."""
        tasks = []
        for key in keys:
            seed = stable_seed(self.run_seed, "robust/" + key)
            starts = moved_starts(self.start, jitter, total - 1, seed)
            for j in range(len(walks[key]), total):
                tasks.append(self.task(extra_key(key, j), genes_of[key], starts[j - 1], family=family))
        done = self.walk(tasks)
        return {key: walks[key] + [done[extra_key(key, j)] for j in range(len(walks[key]), total)] for key in keys}

    def task(
        self,
        key: str,
        genes: Sequence[float] | np.ndarray,
        start: Start | None = None,
        kind: WalkKind = WalkKind.SEARCH,
        trace: bool = False,
        family: str | None = None,
    ) -> EpisodeTask:
        """The episode ``key`` of this run, with its own seed (which also seeds its dither)."""
        genes = tuple(float(g) for g in genes)
        return EpisodeTask(key, genes, stable_seed(self.run_seed, key), start, kind, trace, family)

    def walk(self, tasks: Sequence[EpisodeTask]) -> dict[str, EpisodeRecord]:
        """Each task's log record: from the log when it holds the key, else evaluated (as one
        batch) and logged as it finishes. A logged key must have the task's genes, start and family."""
        records: dict[str, EpisodeRecord] = {}
        todo: list[EpisodeTask] = []
        for task in tasks:
            record = self.log.records.get(task.key)
            if record is None:
                todo.append(task)
                continue
            asked = (task.genes, None if task.start is None else tuple(float(x) for x in task.start), task.family)
            if (record.genes, record.start, record.family) != asked:
                raise ResumeMismatch(
                    f"episode {task.key!r}: the log holds other genes, another start or another family than "
                    f"the search asks (genes {list(record.genes)}, start {record.start}, family {record.family} vs "
                    f"genes {list(task.genes)}, start {asked[1]}, family {task.family}); was the run made with "
                    "other settings or code?"
                )
            records[task.key] = record
        if todo:
            if self.progress is not None:
                self.progress.batch(todo[0].key.rsplit("/", 1)[0])
            for outcome in self.evaluator.evaluate(todo):
                record = outcome.to_record()
                self.log.append(record)
                self.evaluated += 1
                records[outcome.task.key] = record
                if self.progress is not None:
                    self.progress.episode(record)
        return records


class BarProgress:
    """One tqdm bar for a whole run, on stderr: episodes done of planned, episodes per second and
    the ETA (tqdm's), the batch being evaluated (crossover row, iteration, generation), the best
    score a search was told so far and the number of failed episodes. Episodes replayed from the log are counted
    from the start, so the rate and the ETA measure only the episodes run now."""

    def __init__(self, total: int, done: int = 0, best: float = -math.inf, *, quiet: bool = False) -> None:
        self.best = best
        self.failed = 0
        self._bar = tqdm(total=total, initial=done, unit="ep", dynamic_ncols=True, disable=quiet, smoothing=0.05)
        self._batch = ""

    def batch(self, prefix: str) -> None:
        self._batch = prefix
        self._show()

    def episode(self, record: EpisodeRecord) -> None:
        self.failed += not record.ran
        if self._bar.total is not None and self._bar.n >= self._bar.total:
            self._bar.total = self._bar.n + 1  # walked past the estimate: never shown past its total
        self._bar.update(1)
        self._show()

    def plan(self, remaining: int) -> None:
        """The total becomes the episodes walked so far and ``remaining`` more."""
        self._bar.total = self._bar.n + remaining
        self._bar.refresh()

    def scored(self, fitness: float) -> None:
        if fitness > self.best:
            self.best = fitness
            self._show()

    def _show(self) -> None:
        postfix = {"batch": self._batch, "best": f"{self.best:.3f}"}
        if self.failed:
            postfix["failed"] = str(self.failed)
        self._bar.set_postfix(postfix, refresh=False)

    def close(self, finished: bool = False) -> None:
        """``finished``: the run is done, so the bar shows 100% even where the planned total was
        an estimate (how many walks the stability checks take depends on which walks fall)."""
        if finished and self._bar.total != self._bar.n:
            self._bar.total = self._bar.n
            self._bar.refresh()
        self._bar.close()
