"""The optimizer's in-process episodes (``optimizer.episode.inprocess``: the embedded stand-in's core and
the agent's behaviour in one process, no sockets, no text) against the same episodes over sockets
(a ``python -m server_stub`` process, the agent over TCP, the judge reading the monitor stream).

The in-process path is a shortcut of the socket path, so it must give the same outcome for every
gait: here, a set of slow and fast gaits (walkers and fallers, straight and turning, the shipped
gait and the fastest real walk) give the same distance, fall, time and fitness to the last bit,
and the same torso track the judge saw, from the default start and from a moved one.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from gait import TFS, Gait, load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner
from optimizer.episode.config import Start

GAITS_DIR = Path(__file__).resolve().parents[1] / "bench" / "fidelity_gaits"
#: From the fidelity sets: on the default physics the stand-in walks the first five for the 15 s
#: (1.0-6.8 m: slow, fast, turning), the rest fall after 0.4-7 s; line-10 is the fastest real walk
#: (13.3 m there).
GAITS = (
    "line-01",
    "found-stub0",
    "found-stub3",
    "turn-02",
    "random-033",
    "random-002",
    "line-05",
    "near-fast-r0.02-0",
    "line-10",
)


def _gaits() -> dict[str, Gait]:
    found = {"shipped": load_gait()}
    for name in ("training", "held_aside"):
        for gait in json.loads((GAITS_DIR / f"{name}.json").read_text())["gaits"]:
            if gait["name"] in GAITS:
                found[gait["name"]] = TFS.gait([gait["params"][n] for n in TFS.gene_names])
    assert len(found) == len(GAITS) + 1
    return found


def _walks(embedded_stub: str, starts: list[Start | None]) -> dict[tuple[str, int], tuple]:
    out = {}
    with EpisodeRunner(EpisodeConfig(embedded_stub=embedded_stub), trace=True) as runner:
        for name, params in _gaits().items():
            for index, start in enumerate(starts):
                result = runner.evaluate(params, start=start)
                assert result.status == "ok", result.reason
                out[name, index] = (result.distance, result.fell, result.time, result.fitness, runner.last_trace)
    return out


def test_inprocess_episodes_walk_as_the_socket_path_does() -> None:
    starts: list[Start | None] = [None, (-4.97, 0.03, 7.5)]
    inprocess = _walks("inprocess", starts)
    sockets = _walks("socket", starts)
    assert inprocess.keys() == sockets.keys()
    for key in inprocess:
        assert inprocess[key][:4] == sockets[key][:4], key  # exact: distance, fell, time, fitness
        assert inprocess[key][4] == sockets[key][4], key  # the judge saw the same torso, state by state
    outcomes = [d[:3] for d in inprocess.values()]
    assert any(fell for _, fell, _ in outcomes) and any(not fell for _, fell, _ in outcomes)
    assert max(distance for distance, _, _ in outcomes) > 5.0


def test_a_dithered_walk_is_the_same_on_both_paths_and_its_seed_decides_it() -> None:
    """The agent's command dither (``EpisodeConfig.command_noise``, seeded per episode) reaches the
    agent alike on the in-process path and over sockets: the same seed walks the same to the last bit,
    another seed, or none, walks elsewhere."""
    params = _gaits()["line-05"]
    walks = {}
    for mode, noise in (("inprocess", 0.001), ("socket", 0.001), ("inprocess", 0.0)):
        with EpisodeRunner(EpisodeConfig(walk_time=4.0, embedded_stub=mode, command_noise=noise)) as runner:
            for seed in (1, 2):
                result = runner.evaluate(params, seed=seed)
                assert result.status == "ok", result.reason
                walks[mode, noise, seed] = (result.distance, result.fell, result.time)
    for seed in (1, 2):
        assert walks["inprocess", 0.001, seed] == walks["socket", 0.001, seed]
    assert walks["inprocess", 0.001, 1] != walks["inprocess", 0.001, 2]
    assert walks["inprocess", 0.0, 1] == walks["inprocess", 0.0, 2]  # no dither: the seed is bookkeeping
    assert walks["inprocess", 0.001, 1] != walks["inprocess", 0.0, 1]
    with pytest.raises(ValueError, match="command_noise"):
        EpisodeConfig(command_noise=-1.0)


def test_an_agent_process_is_told_the_dither_and_the_episodes_seed(monkeypatch) -> None:
    """``--agent-mode process`` hands the dither to ``python -m agent`` on its command line (a
    process's walk starts by the wall clock, so its distance is no proof: its command line is)."""
    from agent.__main__ import build_parser
    from optimizer.episode import runner as runner_module

    seen: list[list[str]] = []
    popen = runner_module.subprocess.Popen

    def refuse_agents(command: list[str], **kwargs: Any) -> Any:
        if command[1:3] != ["-m", "agent"]:
            return popen(command, **kwargs)  # the stub server itself
        seen.append(command)
        raise OSError("no agent process in this test")

    monkeypatch.setattr(runner_module.subprocess, "Popen", refuse_agents)
    config = EpisodeConfig(walk_time=1.0, embedded_stub="socket", agent_mode="process", command_noise=0.001)
    with EpisodeRunner(config) as runner:
        assert runner.evaluate(load_gait(), seed=7).status == "failed"
    assert seen
    args = build_parser().parse_args(seen[0][3:])
    assert (args.command_noise, args.noise_seed) == (0.001, 7)


def test_inprocess_is_the_embedded_stubs_default_and_can_be_refused() -> None:
    assert EpisodeConfig().embedded_stub == "inprocess"
    with pytest.raises(ValueError, match="embedded_stub must be 'inprocess' or 'socket'"):
        EpisodeConfig(embedded_stub="pipes")


def test_inprocess_episodes_repeat_exactly_one_after_another() -> None:
    """One stub serves episode after episode (robots parked and reused), as over sockets."""
    with EpisodeRunner(EpisodeConfig(walk_time=2.0)) as runner:
        first = runner.evaluate(load_gait())
        runner.evaluate(_gaits()["line-10"])
        again = runner.evaluate(load_gait())
    assert first.status == "ok" and (first.distance, first.fell, first.time) == (again.distance, again.fell, again.time)


def test_the_episode_command_takes_either_path_and_refuses_others(capsys) -> None:
    from optimizer.cli.episode_command import main

    outputs = []
    for path in ("inprocess", "socket"):
        assert main(["--embedded-stub", path, "--walk-time", "1", "--json"]) == 0
        walk = json.loads(capsys.readouterr().out)
        outputs.append({k: v for k, v in walk.items() if k != "wall"})
    assert outputs[0] == outputs[1] and outputs[0]["status"] == "ok"
    with pytest.raises(SystemExit):
        main(["--embedded-stub", "pipes"])
    assert "invalid choice: 'pipes'" in capsys.readouterr().err
