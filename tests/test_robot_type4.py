"""Robot type 4, the toes (``nao_hetero.rsg 4``), against the real server's files and figures.

The real server's figures are in ``tests/data/rcssserver3d/robot_type4.json`` (written by
``python -m bench.bench_robot_type --data``): a standing type-4 robot's torso height, its FRPs and one
whole perception, and every walk of the calibration walk and ten fidelity gaits, 5 dithered walks
each. The last tests walk a real server where one is configured (``RCSSSERVER3D``).
"""

from __future__ import annotations

import json
import re
import statistics

import pytest

from gait import DEFAULT_GAIT_PATH, TFS, load_gait
from optimizer.episode import EpisodeConfig, EpisodeRunner
from optimizer.episode.real_server import RealServerProcess
from protocol.nao import JOINTS, SPEED_CAP, TOE_JOINTS, TOE_ROBOT_TYPES, joints_of, perception_layout
from protocol.perception import parse_perception
from server_stub.physics import nao_model
from server_stub.physics.world import World
from server_stub.sensors.perception_text import GameStateText, format_perception
from tests.stub_client import RawClient, StubProcess, joint

_ENTRY = re.compile(r"\((HJ|FRP) \(n (\w+)\)")
_TYPE4_SCENE = "(scene rsg/agent/nao/nao_hetero.rsg 4)"


@pytest.fixture(scope="module")
def real(fixtures_dir) -> dict:
    return json.loads((fixtures_dir / "robot_type4.json").read_text())


def _order(message: str) -> list[str]:
    return [f"{kind} {name}" for kind, name in _ENTRY.findall(message)]


# ----- the model: naolegtoe.rsg and naorobottypes.rb -----
def test_type4_splits_the_foot_into_foot_and_toe_as_naolegtoe_does():
    parts = {p.name: p for p in nao_model.body_parts(4)}
    foot, toe = parts["rfoot"], parts["rtoe"]
    assert foot.size == (0.08, 0.124482, 0.02) and toe.size == (0.08, 0.0355177, 0.01)
    assert foot.mass + toe.mass == pytest.approx(0.2, abs=1e-6)
    assert nao_model.total_mass(4) == pytest.approx(nao_model.total_mass(0), abs=1e-6)
    # heel where type 0's is, toe tip where type 0's foot ends, both undersides on the sole
    type0 = {p.name: p for p in nao_model.body_parts(0)}["rfoot"]
    assert foot.centre[1] - foot.size[1] / 2 == pytest.approx(type0.centre[1] - 0.08)
    assert toe.centre[1] + toe.size[1] / 2 == pytest.approx(type0.centre[1] + 0.08, abs=1e-6)
    assert toe.centre[2] - 0.005 == pytest.approx(foot.centre[2] - 0.01)
    assert parts["ltoe"].centre == (-toe.centre[0], toe.centre[1], toe.centre[2])


def test_type4_toe_hinges_join_toe_to_foot_on_the_sole_after_the_22_joints():
    hinges = nao_model.hinges(4)
    assert [h.effector for h in hinges] == [j.effector for j in JOINTS + TOE_JOINTS]
    by = {h.effector: h for h in hinges}
    for side in "rl":
        toe = by[f"{side}le7"]
        assert (toe.parent, toe.child, toe.axis) == (f"{side}foot", f"{side}toe", (1.0, 0.0, 0.0))
        assert toe.anchor[1:] == pytest.approx((0.0694821, -0.385))
        # the ankle roll is anchored in the (shorter) foot's frame: it moves back with its centre
        assert by[f"{side}le6"].anchor[1] == pytest.approx(-0.022759)
    assert [(j.min_deg, j.max_deg) for j in TOE_JOINTS] == [(-1.0, 70.0), (-1.0, 70.0)]
    assert nao_model.speed_caps(4)[-2:] == (SPEED_CAP, SPEED_CAP)


def test_types_0_to_3_keep_their_22_joints_and_parts():
    for robot_type in range(4):
        assert joints_of(robot_type) == JOINTS
        assert [h.effector for h in nao_model.hinges(robot_type)] == [j.effector for j in JOINTS]
        assert "rtoe" not in {p.name for p in nao_model.body_parts(robot_type)}
        assert nao_model.pressure_parts(robot_type) == {"lf": "lfoot", "rf": "rfoot"}
    assert nao_model.part_names(4) == (*nao_model.part_names(0)[:17], "rtoe", *nao_model.part_names(0)[17:], "ltoe")
    assert {t for t, rtype in nao_model.ROBOT_TYPES.items() if rtype.toes is not None} == TOE_ROBOT_TYPES


# ----- the perception: its order as the real server prints it -----
def test_the_type4_layout_is_the_real_servers_perception_order(real):
    message = real["standing"]["perception"]
    angles = {j.perceptor: 0.0 for j in joints_of(4)}
    contact = ((0.0, 0.0, -0.01), (0.0, 0.0, 10.0))
    ours = format_perception(
        1.0,
        GameStateText(0, 0, 0.0, "BeforeKickOff"),
        (0.0, 0.0, 0.0),
        (0.0, 0.0, 9.81),
        angles,
        dict.fromkeys(("rf", "rf1", "lf", "lf1"), contact),
        layout=perception_layout(4),
    )
    assert _order(ours) == _order(message) == real["standing"]["order"]
    assert "FRP rf1" in _order(message) and "HJ llj7" in _order(message)


def test_the_parser_reads_the_real_type4_perception(real):
    perception = parse_perception(real["standing"]["perception"])
    assert set(perception.joints) == {j.perceptor for j in joints_of(4)}
    assert set(perception.frp) == {"rf", "rf1", "lf", "lf1"}
    assert perception.frp["rf1"].force[2] == pytest.approx(real["standing"]["frp"]["rf1"][1][2])


# ----- standing, in the stand-in's world -----
def test_a_standing_type4_robot_rests_and_presses_as_on_the_real_server(real):
    with World() as world:
        robot = world.add_robot(4)
        robot.beam(-3.0, 2.0, 0.0)
        for _ in range(200):
            world.step()
        standing = real["standing"]
        assert robot.torso_position()[2] == pytest.approx(standing["torso_height"], abs=2e-5)
        pressure = robot.foot_pressure()
        assert set(pressure) == set(standing["frp"])
        for name, (_, force) in standing["frp"].items():
            # printed with 2 decimals by the real server; the toe's share is within a hundredth
            assert pressure[name][1][2] == pytest.approx(force[2], abs=0.02), name
        assert max(abs(a) for a in robot.joint_degrees()) < 0.01


# ----- over the socket -----
def _stand(client: RawClient) -> str:
    """After the scene: init as player 9, beam to (-3, 2), stand 60 cycles; the last perception."""
    client.send("(init (unum 9)(teamname Toes))(syn)")
    client.receive()
    client.send("(beam -3 2 0)(syn)")
    message = ""
    for _ in range(60):
        message = client.receive()
        client.send("(syn)")
    return message


def test_type4_over_the_socket_perceives_and_drives_its_toes(real):
    with StubProcess("--sync", "--no-realtime", "--agent-timeout", "3") as stub:
        client = RawClient(stub.agent_port)
        client.send(_TYPE4_SCENE + "(syn)")
        client.receive()
        message = _stand(client)
        assert _order(message) == real["standing"]["order"]
        assert joint(message, "rlj7") == 0.0
        # the toe effectors are accepted: the right toe rises, the left one is held
        for _ in range(20):
            client.send("(rle7 2.0)(lle7 0.0)(syn)")
            message = client.receive()
        client.close()
        assert joint(message, "rlj7") > 20.0 and abs(joint(message, "llj7")) < 0.5
        assert "ignored" not in stub.stop()


def test_a_type0_robot_over_the_socket_has_no_toes():
    with StubProcess("--sync", "--no-realtime", "--agent-timeout", "3") as stub:
        client = RawClient(stub.agent_port)
        client.send("(scene rsg/agent/nao/nao_hetero.rsg 0)(syn)")
        first = client.receive()
        client.send("(rle7 1.0)(syn)")
        client.receive()
        client.close()
        assert "rlj7" not in first and "FRP (n rf1)" not in first and len(_order(first)) == 22
        assert "(rle7 ...) ignored" in stub.stop()


# ----- walking: the stand-in's walks against the stored real ones -----
def test_the_type4_calibration_walk_walks_as_far_as_on_the_real_server(real):
    """The stand-in's undithered walk is one draw: it stands, as most real walks do, and ends
    inside the spread of the real walks that stood (5% slack)."""
    walks = real["walks"]["gaits"]["shipped"]
    stood = [d for d, fell in zip(walks["distances"], walks["fell"]) if not fell]
    with EpisodeRunner(EpisodeConfig(robot_type=4)) as runner:
        result = runner.evaluate(load_gait(DEFAULT_GAIT_PATH))
    assert not result.fell and len(stood) * 2 > len(walks["fell"])
    assert 0.95 * min(stood) <= result.distance <= 1.05 * max(stood)


@pytest.mark.slow
def test_type4_fidelity_gaits_fall_and_walk_as_on_the_real_server(real):
    """One undithered stand-in walk per gait against the real server's 5 dithered ones: the fall
    verdict (the real majority) agrees for nearly all, and the walking gaits' distances are close."""
    gaits = real["walks"]["gaits"]
    agree, ratios = 0, []
    with EpisodeRunner(EpisodeConfig(robot_type=4)) as runner:
        for stored in gaits.values():
            result = runner.evaluate(TFS.gait(tuple(stored["genes"])))
            real_fell = sum(stored["fell"]) * 2 > len(stored["fell"])
            agree += result.fell == real_fell
            if not real_fell and not result.fell:
                ratios.append(result.distance / statistics.fmean(stored["distances"]))
    assert agree >= len(gaits) - 1
    assert len(ratios) >= 5 and statistics.median(abs(1 - r) for r in ratios) <= 0.15


# ----- against a real server, where one is configured -----
@pytest.mark.real_server
def test_a_real_server_perceives_type4_as_recorded(rcssserver3d: str, real) -> None:
    server = RealServerProcess(rcssserver3d)
    try:
        address = server.ensure_running()
        client = RawClient(address.agent_port)
        client.send(_TYPE4_SCENE + "(syn)")
        client.sock.settimeout(0.05)
        while True:  # a silent new agent is answered only after about 2 s: nudge it
            try:
                client.receive()
                break
            except TimeoutError:
                client.send("(syn)")
        client.sock.settimeout(10.0)
        message = _stand(client)
        client.close()
    finally:
        server.stop()
    assert _order(message) == real["standing"]["order"]


@pytest.mark.real_server
@pytest.mark.slow
def test_the_type4_calibration_walk_on_a_real_server_matches_the_stand_in(rcssserver3d: str) -> None:
    gait = load_gait(DEFAULT_GAIT_PATH)
    with EpisodeRunner(EpisodeConfig(robot_type=4)) as runner:
        stand_in = runner.evaluate(gait)
    with EpisodeRunner(EpisodeConfig(robot_type=4), RealServerProcess(rcssserver3d)) as runner:
        on_real = runner.evaluate(gait)
    assert on_real.status == "ok" and not on_real.fell and not stand_in.fell
    assert stand_in.distance == pytest.approx(on_real.distance, rel=0.1)
