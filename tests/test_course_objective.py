"""The course objective wired into the searches: course files (``optimizer.episode.course``), the
score's order, the course's judge fed monitor states, and every search command's ``--objective`` /
``--course`` / ``--no-true-pose``: refused combinations, what a run stores and resumes from, the
episodes it makes, its log and its walk cards. A fake evaluator stands in for the workers; a
real walk of a course waits for a steerable family (``omni``, being built elsewhere)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from test_driver import FakeEvaluator, synthetic_fitness

import gait
from gait import DEFAULT_GAIT_PATH
from optimizer.cli import ga_command, gala_command, refine_command
from optimizer.compare import __main__ as compare_command
from optimizer.episode import EpisodeConfig
from optimizer.episode.course import Course, CourseError, CourseJudge, leg_durations
from optimizer.episode.objectives import OBJECTIVES, judge_for
from optimizer.episode.scoring import Judge
from optimizer.episode.servers import ServerAddress
from optimizer.evaluation.pool import EpisodeOutcome, EpisodeTask
from optimizer.run import session
from optimizer.run.run_settings import episode_config, manifest_settings
from optimizer.run.walk_card import card_figure, read_card
from optimizer.settings import SETTINGS_VERSION
from protocol.monitor import MonitorState, RobotPose

#: A valid course's document: three poses, the second a turn on the spot.
DOCUMENT: dict[str, Any] = {
    "format": "course/1",
    "name": "a test course",
    "start": [-8, 0, 0],
    "poses": [[-6, 0, 0], [-6, 0, 90], [-6, 2, 90]],
    "reach": [0.25, 15],
    "time_limit": 20,
}


def course_file(tmp_path: Path, document: Any = DOCUMENT, name: str = "course.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(document))
    return path


# --- course files -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        ({"format": "course/2"}, '"format" must be "course/1", found "course/2"'),
        ({"format": None}, '"format" must be "course/1", found null'),
        ({"speed": 1}, "unknown field(s) speed"),
        ({"poses": "none"}, '"poses" must be a list of [x, y, deg]'),
        ({"poses": []}, '"poses" must hold at least one pose'),
        ({"poses": [[-6, 0]]}, '"poses"[0] must be [x, y, deg], three numbers'),
        ({"poses": [[-6, 0, 0], [-6, True, 0]]}, '"poses"[1] must be [x, y, deg], three numbers'),
        ({"poses": [[-6, 0, float("nan")]]}, '"poses"[0] must be [x, y, deg], three numbers'),
        ({"start": [-8, 0]}, '"start" must be [x, y, deg], three numbers'),
        ({"start": None}, '"start" must be [x, y, deg], three numbers'),
        ({"reach": 0.25}, '"reach" must be [metres, degrees]'),
        ({"reach": [0.25]}, '"reach" must be [metres, degrees]'),
        ({"reach": [0, 15]}, '"reach" must be [metres > 0, degrees in (0, 180]]'),
        ({"reach": [0.25, 0]}, '"reach" must be [metres > 0, degrees in (0, 180]]'),
        ({"reach": [0.25, 181]}, '"reach" must be [metres > 0, degrees in (0, 180]]'),
        ({"time_limit": "60"}, '"time_limit" must be a number of seconds'),
        ({"time_limit": True}, '"time_limit" must be a number of seconds'),
        ({"time_limit": 0}, '"time_limit" must be > 0 s'),
        ({"time_limit": -5}, '"time_limit" must be > 0 s'),
    ],
)
def test_a_course_with_a_wrong_field_is_refused_naming_it(change: dict, problem: str) -> None:
    with pytest.raises(CourseError) as refused:
        Course.from_document({**DOCUMENT, **change})
    assert problem in str(refused.value)


def test_a_course_document_must_be_an_object_and_a_file_must_be_one(tmp_path: Path) -> None:
    with pytest.raises(CourseError, match="a course is a JSON object"):
        Course.from_document([DOCUMENT])
    with pytest.raises(CourseError, match="cannot read a course"):
        Course.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(CourseError, match=f"{bad}: cannot read a course"):
        Course.load(bad)
    with pytest.raises(CourseError, match=f"{tmp_path / 'other.json'}: unknown field"):
        Course.load(course_file(tmp_path, {**DOCUMENT, "laps": 2}, "other.json"))
    course = Course.load(course_file(tmp_path))  # the name is allowed, and is no part of the course
    assert course.start == (-8.0, 0.0, 0.0) and len(course.poses) == 3 and course.time_limit == 20.0


def test_the_shipped_course_is_a_course() -> None:
    course = Course.load(Path("optimizer/courses/omni_course.json"))
    assert len(course.poses) == 8 and course.start == (-12.0, 0.0, 0.0)


finite = st.floats(-15, 15, allow_nan=False)
poses = st.tuples(finite, finite, st.floats(-180, 180))
courses = st.builds(
    Course,
    start=poses,
    poses=st.lists(poses, min_size=1, max_size=6).map(tuple),
    reach=st.tuples(st.floats(0.01, 2.0), st.floats(0.5, 180.0)),
    time_limit=st.floats(0.5, 600.0),
)


@settings(max_examples=200, deadline=None)
@given(courses)
def test_a_course_round_trips_through_its_document(course: Course) -> None:
    document = course.to_document()
    assert Course.from_document(document) == course
    assert Course.from_document(json.loads(json.dumps(document))) == course  # as a file holds it


# --- the score ----------------------------------------------------------------------------------------

#: Courses whose every leg has a size (no pose repeats the one before).
sized = courses.filter(lambda c: min(c.leg_sizes()) > 1e-3)


@settings(max_examples=200, deadline=None)
@given(sized, st.data())
def test_any_finished_walk_scores_above_any_unfinished_one(course: Course, data: st.DataObject) -> None:
    n = len(course.poses)
    finished = course.fitness(n, 0.0, data.draw(st.floats(0.0, course.time_limit)))
    reached = data.draw(st.integers(0, n - 1))
    # an unfinished walk has some of its leg to go: with none left it would have reached its pose
    # (a walk finished at the time limit ties with one at its last pose, which the judge never sees)
    left = data.draw(st.floats(1e-3, 50.0))
    assert finished > course.fitness(reached, left, data.draw(st.floats(0.0, course.time_limit)))


@settings(max_examples=200, deadline=None)
@given(sized, st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_a_faster_finished_walk_scores_higher(course: Course, a: float, b: float) -> None:
    assume(abs(a - b) > 1e-6)
    fast, slow = sorted((a, b))
    n, limit = len(course.poses), course.time_limit
    assert course.fitness(n, 0.0, fast * limit) > course.fitness(n, 0.0, slow * limit)


@settings(max_examples=200, deadline=None)
@given(sized, st.data())
def test_more_poses_reached_scores_higher(course: Course, data: st.DataObject) -> None:
    """Whatever is left of the next leg, a walk that reached one more pose scores higher (the walk
    with fewer has some of its leg to go: with none left it would have reached the pose)."""
    n = len(course.poses)
    assume(n >= 2)
    reached = data.draw(st.integers(0, n - 2))
    behind = data.draw(st.floats(1e-3, 50.0))
    ahead = data.draw(st.floats(0.0, 50.0))
    t = data.draw(st.floats(0.0, course.time_limit))
    assert course.fitness(reached + 1, ahead, t) > course.fitness(reached, behind, t)


@settings(max_examples=200, deadline=None)
@given(sized, st.data())
def test_less_left_to_go_in_the_same_leg_scores_higher(course: Course, data: st.DataObject) -> None:
    reached = data.draw(st.integers(0, len(course.poses) - 1))
    leg = course.leg_sizes()[reached]
    near, far = sorted((data.draw(st.floats(0.0, 1.0)) * leg, data.draw(st.floats(0.0, 1.0)) * leg))
    assume(far - near > 1e-6 * leg)
    t = data.draw(st.floats(0.0, course.time_limit))
    assert course.fitness(reached, near, t) > course.fitness(reached, far, t)


# --- the judge ---------------------------------------------------------------------------------------


def state(
    t: float, x: float, y: float, heading: float = 0.0, z: float = 0.38, up_z: float = 1.0, mode: str = "PlayOn"
) -> MonitorState:
    """One monitor state of the left team's robot 1 at (x, y) facing ``heading`` (deg)."""
    h = math.radians(heading)
    up = (math.sqrt(max(0.0, 1 - up_z**2)), 0.0, up_z)
    robot = RobotPose("left", 1, 0, (x, y, z), up, (math.cos(h), math.sin(h), 0.0))
    return MonitorState(t, mode, 1, 0, 0, "GALA", None, [robot])


COURSE = Course.from_document(DOCUMENT)


def judge(trace: bool = False) -> CourseJudge:
    found = judge_for(EpisodeConfig().on_course(COURSE), trace)
    assert isinstance(found, CourseJudge)
    return found


def test_the_objectives_judge_a_course_config_on_its_course_and_others_by_eq_9() -> None:
    assert isinstance(judge_for(EpisodeConfig()), Judge)
    assert set(OBJECTIVES) == {"distance", "course"} and OBJECTIVES["course"].needs_course
    config = EpisodeConfig().on_course(COURSE)
    assert (config.objective, config.start, config.heading, config.walk_time) == ("course", (-8.0, 0.0), 0.0, 20.0)


def test_poses_are_reached_in_order_only() -> None:
    walk = judge()
    walk.feed(state(0.0, -6.0, 2.0, 90.0, mode="BeforeKickOff"))  # not walking yet: nothing counts
    walk.feed(state(1.0, -6.0, 2.0, 90.0))  # on the last pose first: it does not count
    walk.feed(state(2.0, -6.0, 0.0, 90.0))  # on the second pose's spot and heading, before the first
    assert walk.legs == []
    walk.feed(state(3.0, -6.1, 0.1, 10.0))  # the first pose: within 0.25 m and 15 deg
    assert walk.legs == [3.0]
    walk.feed(state(4.0, -6.0, 0.0, 70.0))  # the second's spot, 20 deg off its heading: not yet
    assert walk.legs == [3.0] and walk.result is None
    walk.feed(state(5.0, -6.0, 0.0, 80.0))
    assert walk.legs == [3.0, 5.0] and walk.result is None
    walk.feed(state(6.0, -6.0, 2.2, 95.0))  # the last pose ends the walk
    result = walk.result
    assert result is not None and result.finished and not result.fell
    assert result.reached == 3 and result.legs == (3.0, 5.0, 6.0) and result.time == 6.0
    assert leg_durations(result.legs) == [3.0, 2.0, 1.0]
    assert result.distance == pytest.approx(COURSE.size)
    assert result.fitness == pytest.approx(10 * COURSE.size * (2 - 6.0 / 20.0))
    walk.feed(state(7.0, 0.0, 0.0))  # after the end: ignored
    assert walk.result is result


def test_a_fall_ends_the_walk_with_the_poses_reached_so_far() -> None:
    walk = judge(trace=True)
    walk.feed(state(1.0, -7.0, 0.0))
    walk.feed(state(2.0, -6.0, 0.0))
    walk.feed(state(2.5, -6.0, 0.0, 30.0, up_z=0.5))  # fallen
    result = walk.result
    assert result is not None and result.fell and not result.finished
    assert result.reached == 1 and result.legs == (2.0,) and result.time == 2.5
    left = COURSE.leg_sizes()[1] - 0.5 * math.radians(30)  # the turn on the spot: 30 of its 90 deg done
    assert result.fitness == pytest.approx(10 * (COURSE.leg_sizes()[0] + COURSE.leg_sizes()[1] - left))
    assert result.track is not None and [p[0] for p in result.track] == [1.0, 2.5]  # thinned: the first, the last


def test_the_time_limit_ends_an_unfinished_walk() -> None:
    walk = judge()
    walk.feed(state(10.0, -7.0, 0.0))
    assert walk.result is None
    walk.feed(state(20.0, -7.0, 0.0))
    result = walk.result
    assert result is not None and not result.finished and not result.fell
    assert result.reached == 0 and result.legs == () and result.time == 20.0
    assert result.fitness == pytest.approx(10 * 1.0)  # 1 m of the first 2-m leg done
    assert result.to_dict()["finished"] is False and result.to_dict()["legs"] == ()


# --- the search commands' flags -------------------------------------------------------------------

SMALL_GA = ["--population", "6", "--generations", "2", "--robust-walks", "1", "--check-repeats", "2", "--quiet"]


def refused(main, argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as exit_info:
        main(argv, make_evaluator=lambda setup: pytest.fail("must not start evaluating"))
    assert exit_info.value.code == 2
    return capsys.readouterr().err


#: Each search command's main and the arguments it needs besides the flags under test.
COMMANDS = {
    "gala": (gala_command.main, []),
    "ga": (ga_command.main, []),
    "refine": (refine_command.main, [str(DEFAULT_GAIT_PATH)]),
    "compare": (compare_command.main, []),
}


@pytest.mark.parametrize("command", COMMANDS)
def test_every_search_command_refuses_an_objective_without_its_course_and_the_reverse(
    command: str, tmp_path: Path, capsys
) -> None:
    main, needed = COMMANDS[command]
    path = str(course_file(tmp_path))
    out = ["--out", str(tmp_path / "run")]
    err = refused(main, [*needed, "--objective", "course", *out], capsys)
    assert "--objective course: give the course to walk, --course FILE" in err
    err = refused(main, [*needed, "--objective", "distance", "--course", path, *out], capsys)
    assert "--course: a course is walked with --objective course, not --objective distance" in err
    err = refused(main, [*needed, "--no-true-pose", *out], capsys)
    assert "--no-true-pose: only a course walker steers by its pose" in err
    err = refused(
        main, [*needed, "--course", str(course_file(tmp_path, {**DOCUMENT, "poses": []}, "b.json")), *out], capsys
    )
    assert "argument --course" in err and '"poses" must hold at least one pose' in err
    err = refused(main, [*needed, "--objective", "walk", *out], capsys)
    assert "--objective" in err and "invalid choice" in err
    # the TFS walks of today cannot steer
    err = refused(main, [*needed, "--course", path, *out], capsys)
    assert "a course is walked by a steerable family" in err and "which tfs is not" in err
    assert not (tmp_path / "run").exists()  # refused before a run folder is made


def test_a_course_sets_the_start_and_time_and_takes_no_drift_penalty(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(session, "steers", lambda family: True)  # a stand-in for a steerable family
    path = str(course_file(tmp_path))
    err = refused(ga_command.main, ["--course", path, "--start", "-7", "0", "0"], capsys)
    assert "--course sets the start and the time limit of every walk: leave out --start" in err
    err = refused(ga_command.main, ["--course", path, "--walk-time", "30"], capsys)
    assert "leave out --walk-time" in err
    err = refused(ga_command.main, ["--course", path, "--drift-penalty", "0.5"], capsys)
    assert "--drift-penalty 0.5: a course walk is scored by its time" in err


def test_the_refinement_families_of_a_course_run_must_steer_too(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(session, "steers", lambda family: family.name == "tfs")
    path = str(course_file(tmp_path))
    err = refused(gala_command.main, ["--course", path, "--out", str(tmp_path / "r")], capsys)
    assert "--refine-family tfs-start: a course is walked by a steerable family" in err


class CourseEvaluator(FakeEvaluator):
    """Course walks with a synthetic outcome: the better the genes, the faster the walk finishes;
    the worst walks run out of time at the second pose. Traced walks get a track from their start."""

    def __init__(self, course: Course) -> None:
        super().__init__()
        self.course = course

    def evaluate(self, tasks: Sequence[EpisodeTask]) -> Iterator[EpisodeOutcome]:
        course = self.course
        for task in tasks:
            self.evaluated.append(task.key)
            quality = synthetic_fitness(task.genes) / 50.0  # at most 1
            finished = quality > 0.3
            time = course.time_limit * (1.2 - quality) if finished else course.time_limit
            time = min(time, course.time_limit)
            reached = len(course.poses) if finished else 1
            legs = [time * (i + 1) / reached for i in range(reached)]
            left = 0.0 if finished else 1.0
            fitness = course.fitness(reached, left, time)
            x, y, heading = task.start or course.start
            track = [[t, x + 0.1 * t, y, 0.35, 1.0, heading] for t in (0.0, time / 2, time)] if task.trace else None
            result: dict[str, Any] = {
                "distance": course.size if finished else fitness / 10,
                "fell": False,
                "time": time,
                "fitness": fitness,
                "mean_speed": 0.1,
                "status": "ok",
                "reason": "",
                "wall": 0.01,
                "finished": finished,
                "reached": reached,
                "legs": tuple(legs),
            }
            if track is not None:
                result.update(drift=0.0, heading_change=0.0, track=track)
            yield EpisodeOutcome(task, 0, result)


def test_a_course_run_stores_its_course_walks_it_and_resumes_without_the_file(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    monkeypatch.setattr(session, "steers", lambda family: True)  # a stand-in for a steerable family
    path = course_file(tmp_path)
    out = tmp_path / "run"
    setups = []

    def make(setup):
        setups.append(setup)
        return CourseEvaluator(COURSE)

    argv = ["--course", str(path), "--no-true-pose", *SMALL_GA, "--seed", "3", "--out", str(out)]
    assert ga_command.main(argv, make_evaluator=make) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    stored = manifest["settings"]
    assert manifest["settings_version"] == SETTINGS_VERSION == 2
    assert stored["objective"] == "course" and stored["course"] == COURSE.to_document()
    assert stored["start"] == [-8.0, 0.0, 0.0] and stored["walk_time"] == 20.0 and stored["true_pose"] is False
    assert str(path) not in json.dumps(stored)  # the course itself, not where it was
    # what the workers are given: the course's episodes
    setup = setups[0]
    assert setup.course == COURSE and setup.start == COURSE.start and setup.walk_time == 20.0
    assert setup.true_pose is False
    config = episode_config(
        setup.walk_time, setup.start, setup.agent_mode, setup.command_noise, setup.family, 0.0, setup.course, False
    )
    assert config == EpisodeConfig(family="tfs", command_noise=setup.command_noise, true_pose=False).on_course(COURSE)
    assert config.goals == COURSE.poses
    # the log keeps each walk's outcome on the course; the check's starts are the course start moved
    lines = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert all({"finished", "reached", "legs"} <= line.keys() for line in lines)
    checks = [line for line in lines if line["kind"] == "check"]
    assert len(checks) == 2
    for line in checks:
        assert all(abs(a - b) <= j for a, b, j in zip(line["start"], COURSE.start, (0.05, 0.05, 10.0)))
    # the reports say what a course run's figures are
    results = json.loads((out / "results.json").read_text())
    assert results["check"]["finished"] == 2 and results["check"]["walks"][0]["reached"] == 3
    summary = capsys.readouterr().out
    assert "course finished in" in summary and "finished 2 in" in summary
    card = read_card(out / "best_gait.json")
    assert card is not None and card.course == COURSE
    assert card.summary("stand-in")["finished"] == 2
    gids = {a.get_gid() for ax in card_figure(card).axes for a in ax.get_children() if a.get_gid()}
    assert {"pose:0", "pose:2", "reach:0", "reach:2", "start"} <= gids
    assert {f"walk:{line['key']}" for line in checks} <= gids
    assert "finished" in (out / "best_gait.card.md").read_text()
    # a resumed run reads its course from the manifest: the file may be gone
    path.unlink()
    resumed = CourseEvaluator(COURSE)
    assert ga_command.main(["--resume", str(out), "--quiet"], make_evaluator=lambda s: resumed) == 0
    assert resumed.evaluated == []  # every episode answered from the log
    other = course_file(tmp_path, {**DOCUMENT, "time_limit": 30}, "other.json")
    err = refused(ga_command.main, ["--resume", str(out), "--course", str(other)], capsys)
    assert "--course" in err and "conflicts with the run's --course" in err


def test_a_default_run_stores_eq_9_and_its_log_and_cards_are_as_before(tmp_path: Path) -> None:
    out = tmp_path / "run"
    setups = []

    def make(setup):
        setups.append(setup)
        return FakeEvaluator()

    assert ga_command.main([*SMALL_GA, "--seed", "3", "--out", str(out)], make_evaluator=make) == 0
    stored = json.loads((out / "manifest.json").read_text())["settings"]
    assert (stored["objective"], stored["course"], stored["true_pose"]) == ("distance", None, True)
    assert setups[0].course is None and setups[0].start == (-5.0, 0.0, 0.0)
    lines = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert not any({"finished", "reached", "legs"} & line.keys() for line in lines)
    card = json.loads((out / "best_gait.card.json").read_text())
    assert "course" not in card and "speed" in card["summary"]["stand-in"]


def test_a_run_of_settings_version_1_resumes_as_an_eq_9_run(tmp_path: Path) -> None:
    out = tmp_path / "old"
    assert ga_command.main([*SMALL_GA, "--seed", "4", "--out", str(out)], make_evaluator=lambda s: FakeEvaluator()) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    for name in ("objective", "course", "true_pose"):  # what version 1 did not store
        del manifest["settings"][name]
    manifest["settings_version"] = 1
    (out / "manifest.json").write_text(json.dumps(manifest))
    settings_ = manifest_settings(manifest)
    assert settings_.scoring.objective == "distance" and settings_.scoring.course is None
    setups = []

    def make(setup):
        setups.append(setup)
        return FakeEvaluator()

    assert ga_command.main(["--resume", str(out), "--quiet"], make_evaluator=make) == 0
    assert setups[0].course is None and setups[0].true_pose is True


def test_the_pool_evaluators_workers_walk_the_course(monkeypatch) -> None:
    made = []
    monkeypatch.setattr(session, "ProcessPoolEvaluator", lambda factory, workers, task_timeout: made.append(factory))
    setup = session.EvaluationSetup(
        20.0, COURSE.start, "inprocess", (ServerAddress("127.0.0.1", 3100, 3200),), 1, 7, course=COURSE
    )
    session.pool_evaluator(setup)
    config = made[0].config
    assert config.objective == "course" and config.course == COURSE and config.goals == COURSE.poses
    assert (config.start, config.heading, config.walk_time) == ((-8.0, 0.0), 0.0, 20.0)
    plain = session.EvaluationSetup(15.0, (-5.0, 0.0, 0.0), "inprocess", setup.servers, 1, 7)
    session.pool_evaluator(plain)
    assert made[1].config.objective == "distance" and made[1].config.course is None


# --- a real walk of a course ------------------------------------------------------------------------


def test_a_steerable_gait_walks_a_course_on_the_stand_in() -> None:
    if "omni" not in gait.FAMILIES:
        pytest.skip("no steerable gait family yet: the omni family is being built on another branch")
    from optimizer.episode import EpisodeRunner

    family = gait.FAMILIES["omni"]
    genes = family.repair(family.bounds.mean(axis=1), family.bounds)
    short = Course(start=(-8.0, 0.0, 0.0), poses=((-7.5, 0.0, 0.0),), time_limit=10.0)
    with EpisodeRunner(episode_config(15.0, (-5.0, 0.0, 0.0), "inprocess", family="omni", course=short)) as runner:
        result = runner.evaluate(genes, seed=1, trace=True)
    assert result.status == "ok", result.reason
    assert result.finished is not None and result.reached in (0, 1) and result.track
    assert 0 < result.time <= 10.0


def test_a_course_comparison_says_what_its_figures_are_and_succeeds_by_finishing(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(session, "steers", lambda family: True)  # a stand-in for a steerable family
    out = tmp_path / "compare"
    argv = ["--methods", "random", "--seeds", "2", "--budget", "12", "--population", "4", "--check-repeats", "1"]
    argv += ["--robust-walks", "1", "--course", str(course_file(tmp_path)), "--quiet", "--out", str(out)]
    argv += ["--success-distance", "1000"]  # a distance a course's success does not ask for
    assert compare_command.main(argv, make_evaluator=lambda s: CourseEvaluator(COURSE)) == 0
    text = (out / "comparison.md").read_text()
    assert text.startswith(f"A course (3 poses, {COURSE.size:.2f} m, at most 20 s)")
    runs = json.loads((out / "results.json").read_text())["runs"]
    for run in runs:  # success: the best finished (its score above 10 x the size) and held its check
        assert run["success"] == (run["best_distance"] >= COURSE.size and run["check_falls"] == 0)
    assert any(run["success"] for run in runs)


def test_a_course_runs_transfer_walks_the_course_from_its_start(tmp_path: Path, monkeypatch, capsys) -> None:
    from optimizer.cli import transfer_command

    monkeypatch.setattr(session, "steers", lambda family: True)  # a stand-in for a steerable family
    out = tmp_path / "run"
    argv = ["--course", str(course_file(tmp_path)), *SMALL_GA, "--seed", "3", "--out", str(out)]
    assert ga_command.main(argv, make_evaluator=lambda s: CourseEvaluator(COURSE)) == 0
    err = refused(transfer_command.main, [str(out), "--start", "-7", "0", "0"], capsys)
    assert "--start: the run walks a course" in err
    setups = []

    def make(setup):
        setups.append(setup)
        return CourseEvaluator(COURSE)

    assert transfer_command.main([str(out), "--repeats", "2"], make_evaluator=make) == 0
    assert setups[0].course == COURSE and setups[0].start == COURSE.start
    card = read_card(out / "best_gait.json")
    assert card is not None and card.course == COURSE and len(card.sides["stand-in"]) == 2
