"""Sensor layout of an axis and the scene file (§3-V, §4-4, §10 EA, §10 Q)."""

from __future__ import annotations

from pathlib import Path

import pytest

from gateway.protocol.reply_values import Contact, SensorLogic
from gateway.sim.scene import (
    AxisScene,
    Direction,
    EzWiring,
    Scene,
    SceneError,
    SensorName,
    SensorReader,
    load_scene,
    parse_scene,
)

CW, CCW = Direction.CW, Direction.CCW
ORG, EZ = SensorName.ORG, SensorName.EZ
CWLS, CCWLS = SensorName.CW_LIMIT, SensorName.CCW_LIMIT


def test_cw_counts_up() -> None:
    # §10 4: "CW 方向に相対移動" adds to the position; §10 3: a larger target is CW.
    assert int(Direction.CW) == 1
    assert int(Direction.CCW) == -1


def test_default_scene_is_a_100000_pulse_stroke_with_org_inside() -> None:
    scene = AxisScene()
    assert scene.cw_limit - scene.ccw_limit == 100_000
    assert scene.ccw_limit < scene.org_start <= scene.org_end < scene.cw_limit
    assert scene.ccw_limit < scene.start < scene.cw_limit
    assert not scene.org_start <= scene.start <= scene.org_end  # starts clear of ORG
    assert scene.dog_period == 400  # §10 Q: s1 default 400


def test_where_each_sensor_is_actuated() -> None:
    scene = AxisScene(ccw_limit=-100, org_start=10, org_end=19, cw_limit=200)
    assert [scene.actuated(CCWLS, p) for p in (-101, -100, -99)] == [True, True, False]
    assert [scene.actuated(CWLS, p) for p in (199, 200, 201)] == [False, True, True]
    assert [scene.actuated(ORG, p) for p in (9, 10, 19, 20)] == [False, True, True, False]


def test_next_change_in_both_directions() -> None:
    scene = AxisScene(ccw_limit=-100, org_start=10, org_end=19, cw_limit=200)
    assert scene.next_change(ORG, 0, CW) == 10  # enters ORG
    assert scene.next_change(ORG, 10, CW) == 20  # first position past it
    assert scene.next_change(ORG, 20, CW) is None
    assert scene.next_change(ORG, 30, CCW) == 19
    assert scene.next_change(ORG, 19, CCW) == 9
    assert scene.next_change(ORG, 0, CCW) is None
    assert scene.next_change(CWLS, 0, CW) == 200
    assert scene.next_change(CWLS, 250, CCW) == 199
    assert scene.next_change(CCWLS, 0, CCW) == -100
    assert scene.next_change(CCWLS, -150, CW) == -99


def test_step_out_dog_is_on_for_half_of_each_period() -> None:
    scene = AxisScene(dog_period=400, dog_offset=100)  # ON where (p - 100) mod 400 < 200
    assert [scene.actuated(EZ, p) for p in (99, 100, 299, 300, 499, 500)] == [
        False,
        True,
        True,
        False,
        False,
        True,
    ]
    assert scene.next_change(EZ, 150, CW) == 300
    assert scene.next_change(EZ, 350, CW) == 500
    assert scene.next_change(EZ, 150, CCW) == 99
    assert scene.next_change(EZ, 350, CCW) == 299


def test_z_phase_pulses() -> None:
    scene = AxisScene(ez=EzWiring.Z, z_period=1000, z_width=10, z_offset=5)  # ON 5-14, 1005-
    assert [scene.actuated(EZ, p) for p in (4, 5, 14, 15, 1005)] == [False, True, True, False, True]
    assert scene.next_change(EZ, 500, CCW) == 14
    assert scene.next_change(EZ, 14, CCW) == 4
    assert scene.next_change(EZ, 500, CW) == 1005


def test_inputs_through_the_ea_logic() -> None:
    # §10 EA: an unconnected input reads OFF with A logic and always ON with B logic.
    scene = AxisScene(connected=frozenset({ORG, EZ}), cw_limit=2000)
    reader = SensorReader(scene)
    assert not reader.reads(CWLS, 0)
    assert not reader.reads(CWLS, 3000)  # nothing wired: the limit never reads ON
    reader.logic = SensorLogic(limit=Contact.B)
    assert reader.reads(CWLS, 0)
    assert reader.reads(CCWLS, 0)
    assert reader.next_change(CWLS, 0, CW) is None


def test_normally_closed_sensors_need_b_logic() -> None:
    scene = AxisScene(normally_closed=frozenset({ORG}), org_start=10, org_end=19)
    reader = SensorReader(scene)
    # A logic with a B-contact sensor: ON everywhere but on the sensor (§8-2 ② symptom).
    assert reader.reads(ORG, 0)
    assert not reader.reads(ORG, 15)
    reader.logic = SensorLogic(org=Contact.B)
    assert not reader.reads(ORG, 0)
    assert reader.reads(ORG, 15)


def test_forced_sensor_reads_what_it_is_told() -> None:
    reader = SensorReader(AxisScene())
    reader.forced[ORG] = True
    assert reader.reads(ORG, 50_000)
    assert reader.next_change(ORG, 0, CW) is None
    reader.logic = SensorLogic(org=Contact.B)  # forcing acts after the logic: CL shows it
    assert reader.reads(ORG, 50_000)


def test_scene_rejects_inconsistent_layouts() -> None:
    with pytest.raises(SceneError, match="org_start"):
        AxisScene(org_start=100, org_end=50)
    with pytest.raises(SceneError, match="z_width"):
        AxisScene(z_period=10, z_width=10)
    with pytest.raises(SceneError, match="inp_delay"):
        AxisScene(inp_delay=-1.0)


SCENE_TEXT = """
[default]
cw_limit = 50000
connected = ["cw_limit", "ccw_limit", "org"]

[body.1.motor.2]
org_start = 1000
org_end = 1099
normally_closed = ["org"]
ez = "z"
inp_delay = 0.25

[body.a.motor.1]
start = 7
"""


def test_parse_scene_defaults_and_overrides() -> None:
    scene = parse_scene(SCENE_TEXT)
    axis = scene.axis("1", 2)
    assert (axis.org_start, axis.org_end, axis.cw_limit) == (1000, 1099, 50_000)
    assert axis.normally_closed == {ORG}
    assert axis.connected == {CWLS, CCWLS, ORG}
    assert axis.ez is EzWiring.Z
    assert axis.inp_delay == 0.25
    assert scene.axis("A", 1).start == 7  # body numbers are hex digits, either case
    other = scene.axis("3", 1)
    assert other.cw_limit == 50_000  # [default] applies to axes not named
    assert other.org_start == AxisScene().org_start


def test_empty_scene_is_the_default() -> None:
    assert parse_scene("") == Scene()
    assert Scene().axis("0", 1) == AxisScene()


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("[body.1.motor.2]\norg_stat = 5\n", "body.1.motor.2.org_stat"),
        ("[default]\ncw_limit = 'far'\n", "default.cw_limit"),
        ("[default]\ncw_limit = true\n", "default.cw_limit"),
        ("[default]\nconnected = ['org', 'home']\n", "default.connected"),
        ("[default]\nez = 'encoder'\n", "default.ez"),
        ("[default]\ninp_delay = 'soon'\n", "default.inp_delay"),
        ("[body.1.motor.3]\nstart = 1\n", "body.1.motor.3"),
        ("[body.F.motor.1]\nstart = 1\n", "body.F"),
        ("[body.1.motor.1]\norg_start = 90000\n", "body.1.motor.1"),
        ("[bodies.1]\n", "bodies"),
    ],
)
def test_bad_scene_names_the_key(text: str, key: str) -> None:
    with pytest.raises(SceneError) as caught:
        parse_scene(text)
    assert key in str(caught.value)


def test_bad_toml_is_a_scene_error() -> None:
    with pytest.raises(SceneError, match="TOML"):
        parse_scene("[default\n")


def test_load_scene_reads_a_file(tmp_path: Path) -> None:
    path = tmp_path / "scene.toml"
    path.write_text(SCENE_TEXT, encoding="utf-8")
    assert load_scene(path) == parse_scene(SCENE_TEXT)
