"""One typed table of the optimizer's settings, the argument parsers built from it, and the upgrade
of an older run's stored settings.

Every setting is one ``Setting`` of ``TABLE``: its stored name (the argparse dest and the key of the
manifest's settings), its section, its default, its help and how it is given on a command line, which
commands take it and whether it is one of the few shown first in ``--help``. A command that names or
defaults a setting differently (``optimizer.refine``'s ``--budget`` stores ``refine``; the comparison's
population is 40) says so in the setting's ``variants``, not in a copy. ``build_parser`` makes a
command's parser from the table, ``defaults`` the settings a new run stores, and the budgets and presets
are overrides of the table (``BUDGETS``, ``COMPARE_PRESETS``, ``GA_PRESETS``, ``REFINE_NEW_RUN``).

A run stores its settings in its manifest; a manifest made before a setting existed lacks it, and the
run was made as if it held one legacy value (one walk a gait, no check, the legacy box...). ``upgrade``
fills those values in one versioned step, so that code reading a run's settings reads every setting
(``Settings.from_stored``) instead of branching on "a run from before ...".

Execution settings (workers, servers, the run folder, the seed...) say how a run is executed, not what
it is: they are not stored with the settings (the seed is stored beside them) and may change on resume.
"""

from __future__ import annotations

import argparse
import builtins
import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gait import DEFAULT_FAMILY, FAMILIES, TFS, TFS_START
from optimizer.episode import CALIBRATED_COMMAND_NOISE, DEFAULT_START, ServerAddress
from optimizer.episode.course import Course, CourseError
from optimizer.episode.objectives import DEFAULT_OBJECTIVE, OBJECTIVES
from optimizer.run.folder import RunFolder, RunFolderError
from optimizer.search.config import (
    DE_JONG,
    GREFENSTETTE,
    PAPER_GALA_BEST,
    GAConfig,
    GALAConfig,
    RatePreset,
    ScoringConfig,
    StabilityConfig,
)
from protocol.cli_values import count, non_negative, number, positive_float, positive_int, probability

#: The commands whose parsers the table builds.
COMMANDS = ("gala", "ga", "refine", "compare")
#: The searches of a population (``--population``, ``--elitism``).
_POPULATION = frozenset({"gala", "ga", "compare"})
#: Every search command.
_ALL = frozenset(COMMANDS)
#: The commands that hand over a fastest walk (``--check-confirm``, ``--hand-over-walks``).
_HAND_OVER = frozenset({"gala", "refine"})

#: The sections, in the order ``--help`` shows them, with their titles.
SECTIONS: dict[str, str] = {
    "search": "search settings",
    "scoring": "scoring settings",
    "check": "check settings",
    "refinement": "refinement settings",
    "hand_over": "hand-over settings",
    "episode": "episode settings",
    "execution": "where and how episodes run (not stored with the settings)",
}
#: The title of the group ``--help`` shows first.
COMMON_TITLE = "common settings"

#: The version of the settings this code stores; a manifest without one is version 0 (``upgrade``).
#: 2: the objective (``objective``, ``course``) and the course walker's pose (``true_pose``).
SETTINGS_VERSION = 2


# --- argument types: each names what is wrong; argparse adds the flag -----------------------------

#: How the settings store "score by the mean" (None would read as "not given").
MEAN = "mean"


def quantile_or_mean(text: str) -> float | str:
    """A quantile within [0, 1], or ``mean``."""
    return MEAN if text == MEAN else probability(text)


def stored_quantile(value: float | str | None) -> float | None:
    """A quantile setting as ``ScoringConfig`` takes it: the stored ``MEAN`` (the one text a quantile
    setting holds, ``quantile_or_mean``) is None, the mean."""
    return None if isinstance(value, str) else value


def server_address(text: str) -> ServerAddress:
    """``HOST:AGENT_PORT:MONITOR_PORT`` of a running rcssserver3d."""
    try:
        return ServerAddress.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def course_document(text: str) -> dict[str, Any]:
    """``--course``'s value: the course in a course/1 file, as the document a run stores (the course
    itself, so that a resumed run or a worker never reads the file again)."""
    try:
        return Course.load(text).to_document()
    except CourseError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def existing_run(text: str) -> RunFolder:
    """A run folder to resume, opened (its manifest read)."""
    try:
        return RunFolder.open(Path(text))
    except RunFolderError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def lead_walks(text: str) -> int:
    """``--lead-walks``'s value: 0 or a whole number of walks above 1."""
    value = count(text)
    if value == 1:
        raise argparse.ArgumentTypeError("1 is not more walks than a gait's first: give 0 (none) or at least 2")
    return value


def method_list(text: str) -> list[str]:
    """``--methods``: comma-separated names of the comparison's methods, each known and named once."""
    from optimizer.compare.methods import discover  # the methods' modules load only for the comparison

    names = [n.strip() for n in text.split(",") if n.strip()]
    known = discover()
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown method(s) {', '.join(unknown) or '(none given)'}; known: {', '.join(known)}"
        )
    if len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"a method is named twice in {text!r}")
    return names


# --- the table ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Setting:
    """One setting: where it is stored, its default and help, and how a command line gives it.

    ``default`` is what a new run stores (``defaults``); the parser's own default is None (False for a
    ``store_true`` flag), so that a resumed run can tell a given flag from a default. ``flags`` empty: no
    flag (the command sets it itself, as ``optimizer.refine`` its ``start_gait``). ``stored`` False: an
    execution setting, not in the manifest's settings. ``exclusive`` names a mutually exclusive group
    of flags. ``variants`` holds, per command, the fields that differ there (``on``)."""

    name: str
    section: str
    default: Any
    help: str = ""
    flags: tuple[str, ...] = ()
    type: Callable[[str], Any] | None = None
    nargs: int | str | None = None
    choices: Sequence[str] | None = None
    metavar: str | tuple[str, ...] | None = None
    action: str | builtins.type[argparse.Action] | None = None
    common: bool = False
    commands: frozenset[str] = _ALL
    stored: bool = True
    exclusive: str | None = None
    #: the attribute of its section's record (``Settings``): ``refine`` is ``refinement.budget``
    attribute: str = ""
    variants: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def on(self, command: str) -> Setting:
        """The setting as ``command`` takes it."""
        return dataclasses.replace(self, **self.variants.get(command, {}), variants={})

    def add_to(self, container: argparse._ActionsContainer) -> None:
        """Add this setting's flag to a parser, group or mutually exclusive group."""
        options: dict[str, Any] = {"dest": self.name, "help": self.help}
        for name in ("type", "nargs", "choices", "metavar", "action"):
            value = getattr(self, name)
            if value is not None:
                options[name] = value
        if self.action != "store_true":
            options["default"] = None
        container.add_argument(*self.flags, **options)


def _help_default(value: float | None) -> str:
    return MEAN if value is None else format(value, "g")


_SCORING = ScoringConfig()
_STABILITY = StabilityConfig()
_GA = GAConfig()
_GALA = GALAConfig()

#: The refinement's defaults, in the main job (``gala``) and in ``optimizer.refine``: 8000 gaits of CMA-ES
#: (4000 in the main job), 20 a generation, from each start with a first step of 0.05 of the box and one
#: of 0.1, raced; restarts after a patience without a gain are off until measured
#: (docs/optimizer.md, "Why a refinement phase", "Restarts").
_REFINE, _REFINE_IN_GALA, _REFINE_SIGMA, _REFINE_POPULATION, _LEAD_WALKS = 8000, 4000, [0.05, 0.1], 20, 20
#: The quantile of its walks a refined gait is scored by: the worst, since its walk is handed over.
REFINE_QUANTILE = 0.0
#: The published GA rates ``python -m optimizer.ga --preset`` takes, by name.
GA_RATES: dict[str, RatePreset] = {"dejong": DE_JONG, "grefenstette": GREFENSTETTE, "gala": PAPER_GALA_BEST}
#: The quick budget's refinement families, in turn.
QUICK_FAMILIES = (TFS.name, TFS_START.name)
_QUICK_REFINE = 3200

#: The help of the refinement's leaders' walks, in the main job and in ``optimizer.refine``.
LEAD_WALKS_HELP = (
    "a refined gait that would be its run's best walks on to N walks in all first, and is scored by all "
    f"of them, so that a walk that falls once in 30 is seldom the best (default {_LEAD_WALKS}; "
    "0: none; more than --robust-walks)"
)

#: Every setting, in the order a new run stores them (a command stores those it takes, in this order).
TABLE: tuple[Setting, ...] = (
    # --- search ---
    Setting(
        "preset",
        "search",
        None,
        "published rates: dejong (0.6, 0.001), grefenstette (0.95, 0.01), gala (0.8, 0.07, "
        "the paper's Table I best; the default); --crossover/--mutation override it",
        ("--preset",),
        choices=sorted(GA_RATES),
        common=True,
        commands=frozenset({"ga"}),
        attribute="preset",
    ),
    Setting(
        "methods",
        "search",
        None,  # None: every method found
        "methods to compare (default all: {known})",
        ("--methods",),
        type=method_list,
        metavar="A,B,...",
        common=True,
        commands=frozenset({"compare"}),
        attribute="methods",
    ),
    Setting(
        "seeds",
        "search",
        10,
        "runs per method (default 10)",
        ("--seeds",),
        type=positive_int,
        common=True,
        commands=frozenset({"compare"}),
        attribute="seeds",
    ),
    Setting(
        "budget",
        "search",
        800,
        "search episodes per run, the same for every method (default 800); a raced gait spends --robust-walks of them",
        ("--budget",),
        type=positive_int,
        metavar="EPISODES",
        common=True,
        commands=frozenset({"compare"}),
        attribute="budget",
    ),
    Setting(
        "crossover",
        "search",
        list(_GALA.crossover_rates),
        "a crossover rate (one Table I row); repeat for more rows (default 0.1 ... 0.9)",
        ("--crossover",),
        type=probability,
        action="append",
        common=True,
        commands=frozenset({"gala", "ga"}),
        attribute="crossover",
        variants={"ga": {"default": PAPER_GALA_BEST.crossover_rate, "help": "crossover rate pc", "action": None}},
    ),
    Setting(
        "mutation",
        "search",
        PAPER_GALA_BEST.mutation_rate,
        "mutation rate pm (per gene)",
        ("--mutation",),
        type=probability,
        common=True,
        commands=frozenset({"ga"}),
        attribute="mutation",
    ),
    Setting(
        "iterations",
        "search",
        _GALA.iterations,
        "GALA iterations per row (default 100)",
        ("--iterations",),
        type=positive_int,
        commands=frozenset({"gala"}),
        attribute="iterations",
    ),
    Setting(
        "population",
        "search",
        _GA.population_size,
        f"population size (default {_GA.population_size})",
        ("--population",),
        type=positive_int,
        commands=_POPULATION,
        attribute="population",
        variants={"compare": {"default": 40, "help": "population size (default 40)"}},
    ),
    Setting(
        "generations",
        "search",
        _GA.generations,
        "generations of the final GA of each row (and of each iteration's GA with "
        "--restart-each-iteration), the first included (default 10)",
        ("--generations",),
        type=positive_int,
        common=True,
        commands=frozenset({"gala", "ga"}),
        attribute="generations",
        variants={"ga": {"help": "generations, the random first one included (default 10)"}},
    ),
    Setting(
        "generations_per_iteration",
        "search",
        _GALA.generations_per_iteration,
        "generations the continuing population runs per iteration (default 1)",
        ("--generations-per-iteration",),
        type=positive_int,
        commands=frozenset({"gala"}),
        attribute="generations_per_iteration",
    ),
    Setting(
        "restart_each_iteration",
        "search",
        _GALA.restart_each_iteration,
        "a fresh GA of --generations generations per iteration instead of one continuing population",
        ("--restart-each-iteration",),
        action=argparse.BooleanOptionalAction,
        commands=frozenset({"gala"}),
        attribute="restart_each_iteration",
    ),
    Setting(
        "scheme",
        "search",
        "lrp",
        "learning scheme: lrp (L_R-P, eq. 7-8; default) or lri (L_R-I, eq. 6)",
        ("--scheme",),
        choices=("lrp", "lri"),
        commands=frozenset({"gala"}),
        attribute="scheme",
    ),
    Setting(
        "elitism",
        "search",
        _GA.elitism,
        "carry the best individual into the next generation (default on)",
        ("--elitism",),
        action=argparse.BooleanOptionalAction,
        commands=_POPULATION,
        attribute="elitism",
    ),
    Setting(
        "baseline_window",
        "search",
        _GALA.baseline_window,
        "reward an iteration whose best beats the average of the last K bests "
        "(default: of all preceding bests, as the paper)",
        ("--baseline-window",),
        type=positive_int,
        metavar="K",
        commands=frozenset({"gala"}),
        attribute="baseline_window",
    ),
    Setting(
        "success_distance",
        "search",
        4.95,  # the paper's headline walk
        "a run succeeds when its best walks at least M metres without a fall in its check (default 4.95, the paper's)",
        ("--success-distance",),
        type=non_negative,
        metavar="M",
        commands=frozenset({"compare"}),
        attribute="success_distance",
    ),
    # --- refinement ---
    Setting(
        "refine",
        "refinement",
        _REFINE_IN_GALA,
        "after the rows, CMA-ES tries N more gaits from the fastest gait that held its check, scored "
        f"the same way (default {_REFINE_IN_GALA}; quick {_QUICK_REFINE}; 0: the paper's protocol alone)",
        ("--refine",),
        type=count,
        metavar="N",
        common=True,
        commands=frozenset({"gala", "refine"}),
        attribute="budget",
        variants={
            "refine": {
                "default": _REFINE,
                "flags": ("--budget",),
                "type": positive_int,
                "help": f"gaits CMA-ES tries, all its runs together (default {_REFINE})",
            }
        },
    ),
    Setting(
        "refine_sigma",
        "refinement",
        _REFINE_SIGMA,
        "the first step of each of the refinement's CMA-ES runs, a fraction of the gene box: one run "
        f"per step, the N gaits shared (default {' '.join(map(str, _REFINE_SIGMA))})",
        ("--refine-sigma",),
        type=positive_float,
        nargs="+",
        metavar="S",
        commands=frozenset({"gala", "refine"}),
        attribute="sigma",
        variants={
            "refine": {
                "flags": ("--sigma",),
                "help": "the first step of each CMA-ES run, a fraction of the gene box; one run per step, the "
                f"budget shared (default {' '.join(map(str, _REFINE_SIGMA))})",
            }
        },
    ),
    Setting(
        "refine_population",
        "refinement",
        _REFINE_POPULATION,
        f"gaits per CMA-ES generation of the refinement (default {_REFINE_POPULATION}; "
        "the library's own for 7 genes is 9)",
        ("--refine-population",),
        type=positive_int,
        metavar="N",
        commands=frozenset({"gala", "refine"}),
        attribute="population",
        variants={
            "refine": {
                "flags": ("--population",),
                "help": f"gaits per CMA-ES generation (default {_REFINE_POPULATION})",
            }
        },
    ),
    Setting(
        "refine_race",
        "refinement",
        True,
        "race the refinement's CMA-ES runs (from the fastest gait that held and the best-scored "
        "one, each step) and give the winner half the gaits (default); --no-refine-race: "
        "CMA-ES from the fastest gait alone (and from the reference walk with --refine-reference), "
        "the gaits shared evenly among its runs, as before the race",
        ("--refine-race",),
        action=argparse.BooleanOptionalAction,
        commands=frozenset({"gala", "refine"}),
        attribute="race",
        variants={
            "refine": {
                "flags": ("--race",),
                "help": "race the CMA-ES runs (one per step) and give the winner half the gaits (default); "
                "--no-race: the gaits shared evenly among the steps",
            }
        },
    ),
    Setting(
        "refine_patience",
        "refinement",
        None,
        "start a refinement run again from its best, with twice the gaits a generation, when its best "
        "has not gained 1%% in G generations (default: only when CMA-ES itself stops)",
        ("--refine-patience",),
        type=positive_int,
        metavar="G",
        commands=frozenset({"gala", "refine"}),
        attribute="patience",
        variants={
            "refine": {
                "flags": ("--patience",),
                "help": "start a CMA-ES run again from its best, with twice the gaits a generation, when its "
                "best has not gained 1%% in G generations (default: only when CMA-ES itself stops)",
            }
        },
    ),
    Setting(
        "refine_lead_walks",
        "refinement",
        _LEAD_WALKS,
        LEAD_WALKS_HELP,
        ("--refine-lead-walks",),
        type=lead_walks,
        metavar="N",
        commands=frozenset({"gala", "refine"}),
        attribute="lead_walks",
        variants={"refine": {"flags": ("--lead-walks",)}},
    ),
    Setting(
        "refine_family",
        "refinement",
        TFS_START.name,
        "the gait family the refinement searches, the run's own or one extending it (default "
        f"{TFS_START.name}: the rows' walk begun by itself, its start held and its cruise gait "
        'searched; docs/optimizer.md, "The start-up decides"); several: each searches its share of '
        f"--refine in turn and the checks walk the best of each (quick: {' '.join(QUICK_FAMILIES)}). "
        f"Known: {', '.join(FAMILIES)}",
        ("--refine-family",),
        choices=list(FAMILIES),
        nargs="+",
        metavar="FAMILY",
        commands=frozenset({"gala"}),
        attribute="family",
    ),
    Setting(
        "refine_quantile",
        "refinement",
        REFINE_QUANTILE,
        "score a raced gait of the refinement by this quantile of its walks' fitness, or 'mean' "
        f"(default {REFINE_QUANTILE:g}: the worst walk, since the refinement's walk is the one "
        "handed over; --robust-quantile scores the rows' gaits)",
        ("--refine-quantile",),
        type=quantile_or_mean,
        metavar="Q",
        commands=frozenset({"gala"}),
        attribute="quantile",
    ),
    Setting(
        "refine_reference",
        "refinement",
        False,
        "the refinement also starts from the reference walk (gait/default_gait.json: the slow "
        "calibration walk, which holds on the real server), besides the rows' walks: a short search's "
        "walks can all sit where gaits fall, and CMA-ES climbs only from where gaits walk (quick: on; "
        'default: off, the rows of 11,000 gaits start higher; docs/optimizer.md, "The reference start")',
        ("--refine-reference",),
        action=argparse.BooleanOptionalAction,
        commands=frozenset({"gala"}),
        attribute="reference",
    ),
    # --- hand-over ---
    Setting(
        "check_confirm",
        "hand_over",
        _STABILITY.confirm,
        "walk each candidate for the fastest walk that held its check N more times before it may be "
        "handed over, so that the best of several is not the luckiest "
        f"(default {_STABILITY.confirm}; 0: hand over on the checks alone)",
        ("--check-confirm",),
        type=count,
        metavar="N",
        commands=_HAND_OVER,
        attribute="confirm",
    ),
    Setting(
        "hand_over_walks",
        "hand_over",
        _STABILITY.hand_over,
        "before the run's fastest walk is handed over at its end, its confirmed candidates walk on, "
        "best first, towards N walks each (stopped once one falls), and the first that holds them all "
        "is it; when none does, the walk the refinement started from, if it holds them "
        f"(default {_STABILITY.hand_over}; at most the check and confirming walks: no more walks)",
        ("--hand-over-walks",),
        type=count,
        metavar="N",
        commands=_HAND_OVER,
        attribute="walks",
    ),
    # the refinement's start (``optimizer.refine``'s GAIT as genes of the run's family): no flag
    Setting("start_gait", "refinement", None, commands=frozenset({"refine"}), attribute="start_gait"),
    # --- episode ---
    Setting(
        "walk_time",
        "episode",
        15.0,
        "seconds of walking per episode (eq. 9; default 15)",
        ("--walk-time",),
        type=positive_float,
        common=True,
        attribute="walk_time",
    ),
    Setting(
        "start",
        "episode",
        list(DEFAULT_START),
        "where each walk starts: field position (m) and heading (deg, 0 = +x); the "
        "distance is measured along the heading from where the torso stands when the "
        "walk begins (default {:g} {:g} {:g})".format(*DEFAULT_START),
        ("--start",),
        type=number,
        nargs=3,
        metavar=("X", "Y", "DEG"),
        attribute="start",
    ),
    Setting(
        "agent_mode",
        "episode",
        "inprocess",
        "run the agent inside the worker or as its own process (default inprocess)",
        ("--agent-mode",),
        choices=("inprocess", "process"),
        attribute="agent_mode",
    ),
    # --- scoring ---
    Setting(
        "robust_walks",
        "scoring",
        _SCORING.walks,
        "score a gait over K walks, each with its own draw of the command dither, raced: only a "
        f"gait whose first walk could enter its search's top walks the rest (default {_SCORING.walks}; "
        "1: one walk, the paper's eq. 9)",
        ("--robust-walks",),
        type=positive_int,
        metavar="K",
        common=True,
        attribute="walks",
    ),
    Setting(
        "robust_top",
        "scoring",
        _SCORING.top,
        "racing: a first walk earns the other K - 1 when it beats the N-th best score of its "
        f"search so far (default {_SCORING.top})",
        ("--robust-top",),
        type=positive_int,
        metavar="N",
        attribute="top",
    ),
    Setting(
        "robust_quantile",
        "scoring",
        _SCORING.quantile,
        "score K walks by this quantile of their eq. 9 fitness (default "
        f"{_help_default(_SCORING.quantile)}; with K 5, 0 is "
        "the worst walk and 0.25 the second-worst), or by their mean with 'mean'",
        ("--robust-quantile",),
        type=quantile_or_mean,
        metavar="Q",
        attribute="quantile",
        variants={
            # a new refinement stores REFINE_QUANTILE (``REFINE_NEW_RUN``): its help says so
            "refine": {
                "help": "score K walks by this quantile of their eq. 9 fitness (default "
                f"{_help_default(REFINE_QUANTILE)}; with K 5, 0 is "
                "the worst walk and 0.25 the second-worst), or by their mean with 'mean'"
            }
        },
    ),
    Setting(
        "command_noise",
        "scoring",
        CALIBRATED_COMMAND_NOISE,
        "the agent's dither of every walking velocity command, uniform within +-RAD_S, seeded "
        f"per walk (default {CALIBRATED_COMMAND_NOISE:g}, calibrated to the real server's run-to-run "
        "spread; 0 with --robust-walks 1 walks and scores exactly as the paper)",
        ("--command-noise",),
        type=non_negative,
        metavar="RAD_S",
        attribute="command_noise",
    ),
    Setting(
        "drift_penalty",
        "scoring",
        0.0,
        "take W metres off a walk's distance for each metre it drifted sideways from the line it "
        "started on, so that the search prefers straight walks (default 0: eq. 9)",
        ("--drift-penalty",),
        type=non_negative,
        metavar="W",
        attribute="drift_penalty",
    ),
    Setting(
        "objective",
        "scoring",
        DEFAULT_OBJECTIVE,
        "what a walk is scored by: "
        + "; ".join(f"{o.name}, {o.about}" for o in OBJECTIVES.values())
        + f" (default {DEFAULT_OBJECTIVE}; --course implies course)",
        ("--objective",),
        choices=list(OBJECTIVES),
        attribute="objective",
    ),
    Setting(
        "course",
        "scoring",
        None,
        "the course/1 file every walk walks (implies --objective course; a steerable family): its start "
        "and time limit stand for --start and --walk-time, its poses are reached in order, and a walk is "
        "scored by its time (optimizer.episode.course). The run stores the course itself, not the path",
        ("--course",),
        type=course_document,
        metavar="FILE",
        attribute="course",
    ),
    # --- check ---
    Setting(
        "check_repeats",
        "check",
        _STABILITY.repeats,
        "walk each gait the run reports N more times, each with its own draw of the command "
        "dither, and count the falls (default 10; 0: no check)",
        ("--check-repeats",),
        type=count,
        metavar="N",
        common=True,
        attribute="repeats",
    ),
    Setting(
        "check_jitter",
        "check",
        list(_STABILITY.jitter),
        "move the start of each check walk, and of each raced walk but a gait's first, within "
        "+-DX, +-DY (m) and +-DEG (heading) (default 0.05 0.05 10, the real server's beam noise)",
        ("--check-jitter",),
        type=non_negative,
        nargs=3,
        metavar=("DX", "DY", "DEG"),
        attribute="jitter",
    ),
    # --- episode: the family and its box ---
    Setting(
        "family",
        "episode",
        DEFAULT_FAMILY,
        "the gait family searched (default tfs, the paper's 7 genes): "
        + "; ".join(f"{f.name}: {f.about}" for f in FAMILIES.values()),
        ("--family",),
        choices=list(FAMILIES),
        common=True,
        attribute="family",
    ),
    Setting(
        "bounds",
        "episode",
        "robot",
        "the gene box searched: robot (from the NAO's joint limits, speed cap and control "
        "cycle; the default) or legacy (tfs only: the narrower box of earlier versions)",
        ("--bounds",),
        choices=sorted({box for f in FAMILIES.values() for box in f.boxes}),
        attribute="bounds",
    ),
    Setting(
        "true_pose",
        "episode",
        True,
        "a course walker steers by the server's mypos/myorien where it sends them (default); "
        "--no-true-pose: always by its own estimate from vision and odometry (--objective course only)",
        ("--true-pose",),
        action=argparse.BooleanOptionalAction,
        attribute="true_pose",
    ),
    # --- execution: not stored with the settings ---
    Setting(
        "seed",
        "execution",
        None,
        "fixes every random choice of the run (default: a random seed, recorded)",
        ("--seed",),
        type=int,
        common=True,
        stored=False,
    ),
    Setting(
        "real",
        "execution",
        None,
        "start N real rcssserver3d servers (from $RCSSSERVER3D, else rcssserver3d on PATH) "
        "in a sync profile on free ports, one worker each, and stop them at the end",
        ("--real",),
        type=positive_int,
        metavar="N",
        common=True,
        stored=False,
        exclusive="server",
    ),
    Setting(
        "server",
        "execution",
        None,
        "evaluate on this running rcssserver3d instead of the embedded stub; repeat for more servers "
        "(one worker per server)",
        ("--server",),
        type=server_address,
        action="append",
        metavar="HOST:AGENT_PORT:MONITOR_PORT",
        common=True,
        stored=False,
        exclusive="server",
    ),
    Setting(
        "workers",
        "execution",
        None,
        "worker processes (default: one per core; one per --server)",
        ("--workers",),
        type=positive_int,
        common=True,
        stored=False,
    ),
    Setting(
        "scheduler",
        "execution",
        None,
        "send episodes to this Dask scheduler (needs pip install '.[dask]')",
        ("--scheduler",),
        metavar="tcp://HOST:8786",
        stored=False,
        exclusive="dask",
    ),
    Setting(
        "dask_local",
        "execution",
        None,
        "start a local Dask cluster of N workers (needs pip install '.[dask]')",
        ("--dask-local",),
        type=positive_int,
        metavar="N",
        stored=False,
        exclusive="dask",
    ),
    Setting(
        "out",
        "execution",
        None,
        "new run folder (default runs/<command>-<time>)",
        ("--out",),
        type=Path,
        common=True,
        stored=False,
        exclusive="folder",
    ),
    Setting(
        "resume",
        "execution",
        None,
        "continue the run in DIR: finished episodes are not run again",
        ("--resume",),
        type=existing_run,
        metavar="DIR",
        common=True,
        stored=False,
        exclusive="folder",
    ),
    Setting("quiet", "execution", False, "no progress bar", ("--quiet",), action="store_true", stored=False),
    Setting(
        "skip_bad_lines",
        "execution",
        False,
        "with --resume: move lines of the episode log that cannot be used to "
        "episodes.jsonl.rejected (and say how many) instead of stopping",
        ("--skip-bad-lines",),
        action="store_true",
        stored=False,
    ),
)

_BY_NAME: dict[str, Setting] = {s.name: s for s in TABLE}


def setting(name: str, command: str = "gala") -> Setting:
    """The setting stored as ``name``, as ``command`` takes it (for commands whose flags are a few
    of the table's, as ``optimizer.episode``'s)."""
    return _BY_NAME[name].on(command)


def settings_of(command: str) -> list[Setting]:
    """The settings ``command`` takes, as it takes them, in the order a new run stores them."""
    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; known: {', '.join(COMMANDS)}")
    return [s.on(command) for s in TABLE if command in s.commands]


def defaults(command: str) -> dict[str, Any]:
    """The settings a new run of ``command`` stores before the flags given (and a budget or preset)
    override them: every stored setting the command takes, in the table's order (a manifest's key
    order), lists as fresh lists. ``ga``'s preset changes its defaults: ``{**defaults("ga"),
    **GA_PRESETS[name]}``."""
    return {
        s.name: list(s.default) if isinstance(s.default, list) else s.default for s in settings_of(command) if s.stored
    }


# --- budgets and presets: overrides of the table --------------------------------------------------

#: ``python -m optimizer.gala --budget``: stands for the flags it sets (a flag given wins).
#: paper: the defaults. quick: a first look on a 2-core machine: one row (the paper's best crossover
#: rate), population 20, 20 iterations, a 6-generation final GA, then 3200 gaits of refinement (1600
#: TFS, then 1600 tfs-start walks), also from the reference walk, with no leaders (docs/optimizer.md,
#: "The quick budget", says why each).
BUDGETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "quick": {
        "crossover": [0.8],
        "population": 20,
        "iterations": 20,
        "generations": 6,
        "refine": _QUICK_REFINE,
        "refine_family": list(QUICK_FAMILIES),
        "refine_lead_walks": 0,
        "refine_reference": True,
    },
}

#: ``python -m optimizer.compare --preset``: stands for the flags it sets (a flag given wins);
#: quick: ~1,900 episodes, 4-7 minutes on the stub with 2 workers.
COMPARE_PRESETS: dict[str, dict[str, Any]] = {
    "default": {},
    "quick": {"seeds": 3, "budget": 100, "population": 10, "check_repeats": 5},
}

#: ``python -m optimizer.ga --preset``: published rates, overriding ``defaults("ga")`` (not the flags
#: given: ``--crossover``/``--mutation`` override a preset).
GA_PRESETS: dict[str, dict[str, Any]] = {
    name: {"preset": name, "crossover": rates.crossover_rate, "mutation": rates.mutation_rate}
    for name, rates in GA_RATES.items()
}

#: A new ``python -m optimizer.refine`` run stands for these flags (a flag given wins; a resumed run
#: keeps what it was made with): its whole run is a refinement, whose walk is handed over.
REFINE_NEW_RUN: dict[str, Any] = {"robust_quantile": REFINE_QUANTILE}


@dataclass(frozen=True)
class _Selector:
    """A command's choice of a budget or preset: a flag, not a setting (not stored)."""

    flag: str
    choices: Sequence[str]
    help: str


#: The flag that picks a set of overrides, for the commands that have one that is not a setting.
_SELECTORS: dict[str, _Selector] = {
    "gala": _Selector(
        "--budget",
        sorted(BUDGETS),
        "paper: the full Table I protocol (default); quick: crossover 0.8, population 20, "
        "20 iterations, 6 final generations, 3200 gaits of refinement (1600 TFS, 1600 tfs-start). "
        "Flags given override it",
    ),
    "compare": _Selector(
        "--preset",
        sorted(COMPARE_PRESETS),
        "quick: 3 seeds x 100 episodes, population 10, 5 check walks (minutes); flags given override it",
    ),
}


# --- the parser -----------------------------------------------------------------------------------


def _with_help_values(setting: Setting) -> Setting:
    """The help of a setting whose text names what is only known when the parser is built."""
    if setting.name == "methods":
        from optimizer.compare.methods import discover

        return dataclasses.replace(setting, help=setting.help.format(known=", ".join(discover())))
    return setting


def build_parser(command: str, prog: str, description: str | None = None) -> argparse.ArgumentParser:
    """``command``'s parser, every flag from the table: the common settings first, then one group per
    section. Every default is None (False for ``--quiet``, ``--skip-bad-lines``), so that a resumed run
    can tell a given flag from a default; ``defaults`` has the values. A command's arguments that are
    not settings (``optimizer.refine``'s GAIT) are the command's to add."""
    parser = argparse.ArgumentParser(
        prog=prog, description=description, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    common = parser.add_argument_group(COMMON_TITLE)
    groups = {section: parser.add_argument_group(title) for section, title in SECTIONS.items()}
    selector = _SELECTORS.get(command)
    if selector is not None:
        common.add_argument(selector.flag, choices=selector.choices, default=None, help=selector.help)
    exclusive: dict[str, argparse._MutuallyExclusiveGroup] = {}
    for setting in settings_of(command):
        if not setting.flags:
            continue
        group = common if setting.common else groups[setting.section]
        container: argparse._ActionsContainer = group
        if setting.exclusive is not None:
            if setting.exclusive not in exclusive:
                exclusive[setting.exclusive] = group.add_mutually_exclusive_group()
            container = exclusive[setting.exclusive]
        _with_help_values(setting).add_to(container)
    return parser


# --- the upgrade of an older run's settings -------------------------------------------------------

#: What a run made before a setting existed was made with, by setting: a value, or how it follows
#: from the run's other settings (those come first): how that run's episodes were made, as the
#: code before this table read it in the setting's place.
LEGACY: dict[str, Any] = {
    # before robust scoring: one undithered walk a gait, scored by it
    "robust_walks": 1,
    "robust_top": _SCORING.top,
    "robust_quantile": MEAN,
    "command_noise": 0.0,
    # before the drift penalty: eq. 9's distance
    "drift_penalty": 0.0,
    # before checks: none; their starts were then moved within the real server's beam noise
    "check_repeats": 0,
    "check_jitter": [0.05, 0.05, 10.0],
    # before confirming and hand-over walks: hand over on the candidates' checks alone
    "check_confirm": 0,
    "hand_over_walks": 0,
    # before --start: the field's centre, heading +x
    "start": [0.0, 0.0, 0.0],
    # before families and boxes: the paper's TFS in the narrower box of earlier versions
    "family": DEFAULT_FAMILY,
    "bounds": "legacy",
    # before the refinement (the main job): none
    "refine": 0,
    # before leaders, restarts, the race, the refinement's own population and the reference start
    "refine_lead_walks": 0,
    "refine_patience": None,
    "refine_race": False,
    "refine_population": None,  # the library's default population
    "refine_reference": False,
    # before the refinement's own family and quantile: the run's own
    "refine_family": lambda settings: settings["family"],
    "refine_quantile": lambda settings: settings["robust_quantile"],
    # before objectives (version 2): eq. 9's distance, no course, the walker's pose as the server sends it
    "objective": DEFAULT_OBJECTIVE,
    "course": None,
    "true_pose": True,
}

#: The settings version 2 added (``_to_version_2``).
_NEW_IN_2 = ("objective", "course", "true_pose")


def _to_version_1(stored: Mapping[str, Any], command: str) -> dict[str, Any]:
    """Version 0 (no version stored) to 1: every setting the run did not store gets the value it was
    made with (``LEGACY``). A main job from before the refinement (no ``refine``) never read the
    refinement's steps, which get the default. Any other setting missing is refused: today's code
    reads it without a fallback, so no run that could resume lacks it."""
    settings = dict(stored)
    taken = [setting for setting in settings_of(command) if setting.stored]
    names = {setting.name for setting in taken}
    for name, legacy in LEGACY.items():  # in its order: a value that follows another comes after it
        if name in names and name not in settings:
            value = legacy(settings) if callable(legacy) else legacy
            settings[name] = list(value) if isinstance(value, list) else value  # a fresh list a run
    for setting in taken:
        if setting.name in settings:
            continue
        if setting.name == "refine_sigma" and "refine" not in stored:
            settings[setting.name] = list(setting.default)
        else:
            raise ValueError(f"the run's settings lack {setting.name!r}, which every {command} run has stored")
    return settings


def _to_version_2(stored: Mapping[str, Any], command: str) -> dict[str, Any]:
    """Version 1 to 2: a run from before objectives walked eq. 9's distance, on no course, and
    (having no course) never steered by a pose (``LEGACY``); nothing else changed."""
    settings = dict(stored)
    names = {setting.name for setting in settings_of(command) if setting.stored}
    for name in _NEW_IN_2:
        if name in names and name not in settings:
            settings[name] = LEGACY[name]
    return settings


#: The upgrade from each version to the next: ``_UPGRADES[v]`` takes version v to v + 1.
_UPGRADES: tuple[Callable[[Mapping[str, Any], str], dict[str, Any]], ...] = (_to_version_1, _to_version_2)


def upgrade(stored: Mapping[str, Any], command: str, version: int = 0) -> dict[str, Any]:
    """The settings of a ``command`` run's manifest, stored by settings ``version`` (the manifest's
    ``settings_version``; none: 0), brought up to ``SETTINGS_VERSION``: a setting older versions did not
    store holds the value the run was made with, so that it resumes and reports as it was made.
    Current settings come back unchanged (a copy)."""
    if not 0 <= version <= SETTINGS_VERSION:
        raise ValueError(f"settings version {version}: this version reads 0 to {SETTINGS_VERSION}")
    settings = dict(stored)
    for step in _UPGRADES[version:]:
        settings = step(settings, command)
    return settings


# --- the typed record -----------------------------------------------------------------------------

#: A setting's value as the record holds it: lists as tuples.
Values = tuple[float, ...]


@dataclass(frozen=True)
class SearchSettings:
    """The search's numbers (GA, GALA, the comparison)."""

    preset: str | None
    methods: tuple[str, ...] | None
    seeds: int
    budget: int
    crossover: float | Values
    mutation: float
    iterations: int
    population: int
    generations: int
    generations_per_iteration: int
    restart_each_iteration: bool
    scheme: str
    elitism: bool
    baseline_window: int | None
    success_distance: float


@dataclass(frozen=True)
class ScoringSettings:
    """How a gait is scored (``ScoringConfig``) and the dither every walk gets."""

    walks: int
    top: int
    #: a quantile, or ``MEAN``
    quantile: float | str
    command_noise: float
    drift_penalty: float
    #: the objective's name (``optimizer.episode.objectives.OBJECTIVES``)
    objective: str
    #: the course's document (``Course.to_document``; ``run_settings.course_of``), None without one
    course: Mapping[str, Any] | None


@dataclass(frozen=True)
class CheckSettings:
    """The stability check of the gaits a run reports (``StabilityConfig``)."""

    repeats: int
    jitter: Values


@dataclass(frozen=True)
class RefinementSettings:
    """The refinement's CMA-ES (the main job's phase, ``optimizer.refine``'s whole run)."""

    budget: int
    #: one step per CMA-ES run; a run from before several steps stored one number, kept as it is
    sigma: float | Values
    population: int | None
    race: bool
    patience: int | None
    lead_walks: int
    #: one family's name, or several names
    family: str | tuple[str, ...] | None
    quantile: float | str
    reference: bool
    start_gait: Values | None


@dataclass(frozen=True)
class HandOverSettings:
    """What the walk a run hands over walks first (``StabilityConfig.confirm``, ``.hand_over``)."""

    confirm: int
    walks: int


@dataclass(frozen=True)
class EpisodeSettings:
    """How one episode is run, and the family and box of the genes it walks."""

    walk_time: float
    start: Values
    agent_mode: str
    family: str
    bounds: str
    #: a course walker steers by the server's pose where it sends one (``EpisodeConfig.true_pose``)
    true_pose: bool


_SECTION_RECORDS: dict[str, type] = {
    "search": SearchSettings,
    "scoring": ScoringSettings,
    "check": CheckSettings,
    "refinement": RefinementSettings,
    "hand_over": HandOverSettings,
    "episode": EpisodeSettings,
}


def _frozen(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value


def _thawed(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


@dataclass(frozen=True)
class Settings:
    """A run's settings, typed and in sections: ``settings.refinement.budget`` for ``settings["refine"]``.

    ``keys`` are the stored names the run stored, in their order, so that ``stored`` gives back exactly
    the dict it was made from (lists as lists)."""

    command: str
    keys: tuple[str, ...]
    search: SearchSettings
    scoring: ScoringSettings
    check: CheckSettings
    refinement: RefinementSettings
    hand_over: HandOverSettings
    episode: EpisodeSettings

    @classmethod
    def new(cls, command: str) -> Settings:
        """The settings a new ``command`` run stores when no flag is given (``defaults``)."""
        return cls.from_stored(defaults(command), command)

    @classmethod
    def from_stored(cls, stored: Mapping[str, Any], command: str) -> Settings:
        """The record of a ``command`` run's stored settings, once ``upgrade`` has filled in what an older
        run lacks: a ValueError names a key that is not a setting of the command, or one missing."""
        taken = {s.name: s for s in settings_of(command) if s.stored}
        unknown = [name for name in stored if name not in taken]
        if unknown:
            raise ValueError(f"not settings of a {command} run: {', '.join(unknown)}")
        missing = [name for name in taken if name not in stored]
        if missing:
            raise ValueError(f"the {command} run's settings lack {', '.join(missing)}; upgrade them first")
        # a setting the command does not take holds the table's default and is never stored
        sections: dict[str, dict[str, Any]] = {section: {} for section in _SECTION_RECORDS}
        for setting in TABLE:
            if setting.section in sections:
                sections[setting.section][setting.attribute] = _frozen(setting.default)
        for name, value in stored.items():
            setting = taken[name]
            sections[setting.section][setting.attribute] = _frozen(value)
        records = {section: _SECTION_RECORDS[section](**values) for section, values in sections.items()}
        return cls(command, tuple(stored), **records)

    def stored(self) -> dict[str, Any]:
        """The settings as a manifest stores them: the keys the record was made from, in their order."""
        return {name: self[name] for name in self.keys}

    def __getitem__(self, name: str) -> Any:
        """A setting by its stored name, as stored (lists as lists); a KeyError for one the run did not
        store (an execution setting, or another command's)."""
        if name not in self.keys:
            raise KeyError(name)
        setting = _BY_NAME[name]
        return _thawed(getattr(getattr(self, setting.section), setting.attribute))
