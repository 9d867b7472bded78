"""The settings table (``optimizer.settings``): its parsers, defaults and presets, the upgrade of an
older run's settings, and the typed record."""

from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizer import settings as table
from optimizer.settings import (
    COMMANDS,
    SETTINGS_VERSION,
    Settings,
    build_parser,
    defaults,
    settings_of,
    upgrade,
)

EXPECTED_LEGACY = {
    "robust_walks": 1,
    "robust_top": 3,
    "robust_quantile": "mean",
    "command_noise": 0.0,
    "drift_penalty": 0.0,
    "check_repeats": 0,
    "check_jitter": [0.05, 0.05, 10.0],
    "check_confirm": 0,
    "hand_over_walks": 0,
    "start": [0.0, 0.0, 0.0],
    "family": "tfs",
    "bounds": "legacy",
    "refine": 0,
    "refine_lead_walks": 0,
    "refine_patience": None,
    "refine_race": False,
    "refine_population": None,
    "refine_reference": False,
    "objective": "distance",
    "course": None,
    "true_pose": True,
}


@pytest.mark.parametrize("command", COMMANDS)
def test_upgrade_fills_each_legacy_value(command: str) -> None:
    current = {**defaults(command), "family": "tfs-plus", "robust_quantile": 0.5}
    for name in EXPECTED_LEGACY.keys() & current.keys():
        old = {k: v for k, v in current.items() if k != name}
        assert upgrade(old, command) == {**current, name: EXPECTED_LEGACY[name]}, name
    if command == "gala":
        old = {k: v for k, v in current.items() if k not in ("refine_family", "refine_quantile")}
        assert upgrade(old, command) == {**current, "refine_family": "tfs-plus", "refine_quantile": 0.5}
        # a main job from before the refinement never read the refinement's steps
        old = {k: v for k, v in current.items() if k not in ("refine", "refine_sigma")}
        assert upgrade(old, command) == {**current, "refine": 0}


#: A course's document as a run stores it.
COURSE = {
    "format": "course/1",
    "start": [-8.0, 0.0, 0.0],
    "poses": [[-6.0, 1.0, 90.0]],
    "reach": [0.3, 20.0],
    "time_limit": 30.0,
}


@pytest.mark.parametrize("command", COMMANDS)
def test_a_version_1_run_had_eq_9_no_course_and_the_true_pose(command: str) -> None:
    """Version 2 added the objective: a version-1 manifest stored every other setting, and its
    run walked eq. 9's distance with no course; the upgrade fills in just that."""
    current = {**defaults(command), "family": "tfs-plus", "robust_quantile": 0.5}
    version_1 = {k: v for k, v in current.items() if k not in ("objective", "course", "true_pose")}
    upgraded = upgrade(version_1, command, 1)
    assert upgraded == {**version_1, "objective": "distance", "course": None, "true_pose": True}
    record = Settings.from_stored(upgraded, command)
    assert record.scoring.objective == "distance" and record.scoring.course is None and record.episode.true_pose
    # a version-2 run keeps its course, and a course run's settings are not touched by the upgrade
    course_run = {**current, "objective": "course", "course": COURSE, "true_pose": False}
    assert upgrade(course_run, command, SETTINGS_VERSION) == course_run
    assert upgrade(course_run, command, 1) == course_run  # nothing a version 1 lacked is missing
    # a version this code does not know is refused
    with pytest.raises(ValueError, match="settings version 3"):
        upgrade(version_1, command, 3)


def test_a_course_run_stores_the_course_and_reads_it_back() -> None:
    stored = {**defaults("ga"), "objective": "course", "course": COURSE, "true_pose": False}
    record = Settings.from_stored(stored, "ga")
    assert record.scoring.objective == "course" and record.scoring.course == COURSE
    assert record.episode.true_pose is False
    assert json.loads(json.dumps(record.stored())) == stored
    assert list(record.stored()) == list(stored)


def test_upgraded_lists_are_the_runs_own() -> None:
    old = {k: v for k, v in defaults("ga").items() if k not in ("start", "check_jitter")}
    first, second = upgrade(old, "ga"), upgrade(old, "ga")
    first["start"].append(1.0)
    first["check_jitter"][0] = 9.0
    assert second["start"] == [0.0, 0.0, 0.0] and second["check_jitter"] == [0.05, 0.05, 10.0]


@pytest.mark.parametrize("command", COMMANDS)
def test_current_settings_pass_unchanged(command: str) -> None:
    current = defaults(command)
    for version in (0, SETTINGS_VERSION):
        upgraded = upgrade(current, command, version)
        assert json.dumps(upgraded) == json.dumps(current)
        assert upgraded is not current
    # a current version is not filled in: it stores every setting
    partial = {k: v for k, v in current.items() if k != "robust_walks"}
    assert upgrade(partial, command, SETTINGS_VERSION) == partial


def test_upgrade_refuses_what_no_version_stored() -> None:
    with pytest.raises(ValueError, match="walk_time"):
        upgrade({k: v for k, v in defaults("ga").items() if k != "walk_time"}, "ga")
    with pytest.raises(ValueError, match="refine_sigma"):  # a main job that refined stored its steps
        upgrade({k: v for k, v in defaults("gala").items() if k != "refine_sigma"}, "gala")
    with pytest.raises(ValueError, match="version"):
        upgrade(defaults("ga"), "ga", SETTINGS_VERSION + 1)


# --- the typed record -----------------------------------------------------------------------------


def like(value: Any) -> st.SearchStrategy[Any]:
    """Values of the JSON kind a setting stores (None: any of them)."""
    floats = st.floats(allow_nan=False, allow_infinity=False)
    if isinstance(value, bool):
        return st.booleans()
    if isinstance(value, int):
        return st.integers()
    if isinstance(value, float):
        return floats
    if isinstance(value, str):
        return st.text(max_size=10)
    if isinstance(value, list):
        return st.lists(st.text(max_size=5) if value and isinstance(value[0], str) else floats, max_size=4)
    return st.one_of(st.none(), st.integers(), floats, st.text(max_size=5), st.lists(floats, max_size=4))


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(COMMANDS), st.data())
def test_record_round_trip(command: str, data: st.DataObject) -> None:
    stored = {name: data.draw(like(value), label=name) for name, value in defaults(command).items()}
    names = data.draw(st.permutations(list(stored)))  # any key order (an upgraded run's) is kept
    stored = {name: stored[name] for name in names}
    record = Settings.from_stored(stored, command)
    assert json.dumps(record.stored()) == json.dumps(stored)
    for name, value in stored.items():
        assert type(record[name]) is type(value)


def test_record_sections() -> None:
    record = Settings.from_stored(defaults("gala"), "gala")
    assert record.refinement.budget == 4000
    assert record.refinement.sigma == (0.05, 0.1)
    assert record.scoring.quantile == 0.25
    assert record.check.jitter == (0.05, 0.05, 10.0)
    assert record.hand_over.walks == 200
    assert record.episode.family == "tfs"
    refine = Settings.from_stored({**defaults("refine"), "start_gait": [0.1, 0.2]}, "refine")
    assert refine.refinement.budget == 8000 and refine.refinement.start_gait == (0.1, 0.2)
    with pytest.raises(KeyError):
        record["mutation"]  # another command's setting
    with pytest.raises(KeyError):
        record["seed"]  # not stored with the settings
    with pytest.raises(ValueError, match="mutation"):
        Settings.from_stored({**defaults("gala"), "mutation": 0.1}, "gala")
    with pytest.raises(ValueError, match="upgrade"):
        Settings.from_stored({k: v for k, v in defaults("gala").items() if k != "bounds"}, "gala")


def test_every_stored_setting_has_a_field() -> None:
    for command in COMMANDS:
        record = Settings.from_stored(defaults(command), command)
        assert record.stored() == defaults(command)
        for setting in settings_of(command):
            assert setting.stored == (setting.section != "execution"), setting.name


# --- help -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", COMMANDS)
def test_help_shows_the_common_settings_first(command: str) -> None:
    text = build_parser(command, f"python -m optimizer.{command}").format_help()
    common = text.index(f"\n{table.COMMON_TITLE}:\n")
    shown = [title for title in table.SECTIONS.values() if f"\n{title}:\n" in text]
    assert len(shown) >= 4
    assert all(common < text.index(f"\n{title}:\n") for title in shown)
    common_part = text[common : min(text.index(f"\n{title}:\n") for title in shown)]
    assert "--seed" in common_part and "--walk-time" in common_part
    assert "--drift-penalty" not in common_part and "--drift-penalty" in text
    assert 8 <= common_part.count("\n  --") <= 16
