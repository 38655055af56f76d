"""Mode 2: the servo's INP after every motion, the CLR pulses, 0X and the §13-2 sample set-up.

§6-3, §10 CI, DS, 0X, 0Z, 9 ⑦; §13-2 (サンプルプログラム 動作モード 2). Times with the default
speeds (fL 500 pps, fH 5,000 pps): a move of 2,000 pulses puts its last pulse out at
0.647192 s (§7-1 formulas, as in test_mode1.py). INP: the scene's ``inp_delay`` is the
driver's settling time; the control surface gives INP or holds it OFF (``Controls.inp``).
"""

from __future__ import annotations

import json

import pytest

from gateway.sim.clock import RecordKind
from gateway.sim.controller import Controller
from gateway.sim.scene import AxisScene, EzWiring
from tests.sim.direct import Direct
from tests.support.sim_wire import Wire

ACK = b">"
IDLE = b">$10\r"
MOVING = b">$11\r"
LIMIT = b">$12\r"
PULSES_END = 0.647192  # 2,000 pulses with the default speeds
#: §10 DS, §10 0X: CLR is ON for 100 µs.
CLR = 100e-6


def mode_2(scene: AxisScene | None = None, *setup: str) -> Direct:
    """Body 1 in mode 2 (with ``scene`` for both motors), position 0, ``setup`` sent at 0."""
    direct = Direct()
    if scene is not None:
        direct.controllers["1"] = Controller("1", scene={1: scene, 2: scene})
    for text in ("E2", "R0", *setup):
        assert direct.cmd(text) == ACK, text
    return direct


def clr_pulses(direct: Direct, motor: int = 1) -> list[float]:
    return list(direct["1"].snapshot(direct.now)["axes"][str(motor)]["clr_pulses"])


def test_a_move_ends_when_inp_comes() -> None:
    # §10 CI 解説: at the end of a motion CI = 1 is the normal end; here INP comes 0.2 s after
    # the last pulse (the servo's settling).
    direct = mode_2(AxisScene(inp_delay=0.2), "22000", "3")
    assert direct.cmd("CI", at=0.3) == b">$10\r"  # the servo turns
    assert direct.cmd("", at=PULSES_END + 0.199) == MOVING
    assert direct.cmd("CI") == b">$10\r"
    assert direct.cmd("", at=PULSES_END + 0.201) == IDLE
    assert direct.cmd("CI") == b">$11\r"
    assert direct.cmd("6") == b">$100002000\r"
    assert clr_pulses(direct) == []  # a normal end: no CLR (§10 DS ①-⑥)


def test_no_inp_within_3_s_is_a_limit_error_with_a_clr_pulse() -> None:
    # §10 DS ③, §10 9 ⑦, §10 CI: pulses out, INP not there 3 s later: CLR 100 µs, limit error.
    direct = mode_2(None, "22000", "3")
    direct["1"].set_inp(0.1, 1, False)  # the control surface holds INP OFF
    assert direct.cmd("", at=PULSES_END + 2.99) == MOVING
    assert direct.cmd("DS", at=PULSES_END + 3.0 + CLR / 2) == b">$101\r"  # CLR1 ON ...
    assert direct.cmd("DS", at=PULSES_END + 3.0 + CLR * 1.5) == b">$100\r"  # ... for 100 µs
    assert direct.cmd("") == LIMIT
    assert direct.cmd("96") == b">$10\r"  # no step-out
    assert clr_pulses(direct) == [pytest.approx(PULSES_END + 3.0, abs=1e-5)]


def test_inp_given_during_the_wait_ends_the_motion() -> None:
    direct = mode_2(None, "22000", "3")
    direct["1"].set_inp(0.1, 1, False)
    assert direct.cmd("", at=1.5) == MOVING
    direct["1"].set_inp(1.5, 1, True)
    assert direct.cmd("", at=1.5) == IDLE
    assert clr_pulses(direct) == []
    direct["1"].set_inp(2.0, 1, None)  # back to the driver's own INP
    assert direct.cmd("CI", at=2.0) == b">$11\r"


def test_inp_wait_follows_single_pulses() -> None:
    direct = mode_2(AxisScene(inp_delay=0.5))
    assert direct.cmd("7*") == ACK  # one pulse: 2 ms at fL
    assert direct.cmd("", at=0.4) == MOVING
    assert direct.cmd("", at=0.503) == IDLE


def test_s_while_moving_pulses_clr() -> None:
    # §10 DS ④.
    direct = mode_2(None, "22000", "3")
    assert direct.cmd("S", at=0.3) == ACK
    assert clr_pulses(direct) == [0.3]
    assert direct.cmd("DS", at=0.3 + CLR / 2) == b">$101\r"


def test_a_limit_during_a_move_pulses_clr() -> None:
    # §10 DS ②: the limit sensor ON during a motion command (searches excepted).
    direct = mode_2(None, "7")
    direct["1"].force_sensor(0.5, 1, "cw_limit", True)
    assert direct.cmd("", at=0.6) == LIMIT
    assert clr_pulses(direct) == [0.5]


def test_mode_0_has_no_inp_wait_and_no_clr() -> None:
    direct = Direct()
    direct.cmd("22000")
    direct.cmd("3")
    direct["1"].set_inp(0.1, 1, False)
    assert direct.cmd("", at=PULSES_END + 0.001) == IDLE
    direct.cmd("7")
    direct.cmd("S", at=1.0)
    assert clr_pulses(direct) == []


# --- homing in mode 2 -------------------------------------------------------------------------

#: The default scene: ORG 0-499, start 30,000. "0" from there: CCW at fL to ORG (recognised
#: 10 pulses late, at 489), 5 pulses to 484, 0S 20 to 464: the last pulse at 29,536 / 500 s.
SEARCH_PULSES_END = (30_000 - 464) / 500


def test_0x0_waits_for_inp_once_0x1_after_every_step() -> None:
    # §10 0X: 0X0 waits for INP after the 0S pulses (CLR then); 0X1 pulses CLR with the
    # recognition stop and waits for INP after the 5-pulse step and after the 0S pulses.
    old = mode_2(AxisScene(inp_delay=0.05), "0")
    new = mode_2(AxisScene(inp_delay=0.05), "0X1", "0")
    assert old.cmd("", at=SEARCH_PULSES_END + 0.051) == IDLE
    assert new.cmd("", at=SEARCH_PULSES_END + 0.051) == MOVING
    assert new.cmd("", at=SEARCH_PULSES_END + 0.101) == IDLE
    assert clr_pulses(old) == [pytest.approx(SEARCH_PULSES_END + 0.05, abs=1e-5)]
    assert clr_pulses(new) == [pytest.approx((30_000 - 489) / 500, abs=1e-5)]
    for direct in (old, new):
        assert direct.cmd("6") == b">$100000000\r"


def test_the_manuals_mode_2_sample_homes_on_the_third_z_pulse() -> None:
    # §13-2 mode 2: E2, EA51B (INP high-active), A101 5000, A201 8000, F1, OC100, OX100, OL50,
    # OH4000, OS1240, 0Z3, 0Z. The encoder's Z phase on EZ: ON for 10 pulses of every 1,000
    # (0-9, -1,000 to -991, ...). §10 0Z: CCW to ORG, then the 3rd Z (-2,000 to -1,991),
    # reverse CW to its OFF (-1,990), 5 pulses CCW: the origin is at -1,995. CLR after the
    # final 5 pulses (§10 DS ①).
    z = AxisScene(ez=EzWiring.Z)
    setup = ("EA51B", "A1015000", "A2018000", "F1", "OC100", "OX100", "OL50", "OH4000")
    direct = mode_2(z, *setup, "OS1240", "0Z3")
    assert direct.cmd("EA") == b">$120\r"  # bit 5: INP B contact
    assert direct.cmd("0Z") == ACK
    assert direct.cmd("", at=100.0) == MOVING  # 30,000 pulses at 150 pps take 200 s
    assert direct.cmd("", at=300.0) == IDLE
    assert direct.cmd("6") == b">$100000000\r"
    assert direct["1"].axes[1].mechanical(direct.now) == -1995
    assert len(clr_pulses(direct)) == 1
    # The sample's loop: OH5000, B101, 1, OH7000, B201, 1 (each ending with INP).
    for text, position in (("B101", 5000), ("1", 0), ("B201", 8000), ("1", 0)):
        assert direct.cmd(text) == ACK
        assert direct.cmd("", at=direct.now + 10.0) == IDLE, text
        assert direct.cmd("6") == b">$1%08d\r" % position


# --- the control surface ----------------------------------------------------------------------


async def test_the_control_surface_holds_and_gives_inp(make_wire: object) -> None:
    wire: Wire = make_wire()  # type: ignore[operator]
    held = wire.controls.handle({"op": "inp", "body": "1", "motor": 1, "on": False})
    assert held == {"ok": True}
    for frame in (b"$1E2\r", b"$17*\r"):
        assert await wire.exchange(frame) == ACK
    assert await wire.exchange(b"$1CI\r") == b">$10\r"
    assert await wire.exchange(b"$1\r") == MOVING  # one pulse out, INP held OFF
    assert wire.controls.handle({"op": "inp", "body": "1", "motor": 1, "on": True}) == {"ok": True}
    assert await wire.exchange(b"$1\r") == IDLE
    assert await wire.exchange(b"$1CI\r") == b">$11\r"
    state = wire.controls.handle({"op": "state"})
    assert json.loads(json.dumps(state))["ok"] is True
    assert wire.controls.handle({"op": "inp", "body": "1", "motor": 3, "on": True})["ok"] is False
    assert not [r for r in wire.records(RecordKind.LATER)]
