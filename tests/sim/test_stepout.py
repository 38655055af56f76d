"""Step-out detection in modes 0 and 2: the slotted dog (QS, Q, 0Q) and the encoder (QSE, QE).

§10 Q, 0Q, QS, QSE, QE, 9 ⑤-⑦, DS ⑥; §13-2. Scene: the default dog on EZ, ON where
position mod 400 < 200; ``Q`` 400 (default) matches it. The axis starts at 30,000 (ON), so
``0Q`` goes CCW to the first OFF (29,999), CW across the dog (ON 30,000 to 30,199: width 200)
and back 100: position 0 is at 30,100, the middle of a dog (§10 0Q 図(B)).

Times with the default speeds (§7-1): from 0, a move reaches 755.31 pulses at 0.274658 s, then
runs at 5,000 pps, so pulse 1,000 is out at 0.274658 + 244.69 / 5,000 = 0.323596 s.
"""

from __future__ import annotations

from collections.abc import Callable

from tests.sim.direct import Direct
from tests.support.sim_wire import Wire

ACK = b">"
IDLE = b">$10\r"
MOVING = b">$11\r"
LIMIT = b">$12\r"
PULSE_1000 = 0.323596


def centred(*setup: str) -> Direct:
    """Body 1 after 0Q (position 0 in the middle of a dog), then ``setup``, the clock at 10 s."""
    direct = Direct()
    assert direct.cmd("0Q") == ACK
    assert direct.cmd("", at=10.0) == IDLE
    assert direct.cmd("0QW") == b">$100200\r"
    assert direct["1"].axes[1].mechanical(10.0) == 30_100
    for text in setup:
        assert direct.cmd(text) == ACK, text
    return direct


def test_the_dog_catches_more_than_a_quarter_period_lost() -> None:
    # 150 pulses lost at 0.3 s (882 pulses out): the controller expects ON at positions
    # 0, 400, 800, ... and OFF at 200, 600, ...; at position 1,000 (expected OFF) the sensor,
    # 150 pulses behind, reads the dog: step-out, the motor stops there.
    direct = centred("QS01", "22000", "3")
    direct["1"].slip(10.3, 1, -150)
    assert direct.cmd("", at=10.0 + PULSE_1000 - 0.001) == MOVING
    assert direct.cmd("", at=10.0 + PULSE_1000 + 0.001) == LIMIT
    assert direct.cmd("6") == b">$100001000\r"
    assert direct.cmd("96") == b">$11\r"
    assert direct.cmd("Q") == b">$11\r"
    # Only homing is taken now (§10 Q 解説 ①): a move is a limit error and does not move.
    assert direct.cmd("1") == ACK
    assert direct.cmd("", at=direct.now + 1.0) == LIMIT
    assert direct.cmd("0Q") == ACK  # 0Q is an origin search: taken, and clears bit 6
    assert direct.cmd("", at=direct.now + 10.0) == IDLE
    assert direct.cmd("96") == b">$10\r"
    assert direct.cmd("6") == b">$100000000\r"
    assert direct.cmd("3") == ACK  # to 2,000 again, watched from the new origin
    assert direct.cmd("", at=direct.now + 0.1) == MOVING
    assert direct.cmd("", at=direct.now + 1.0) == IDLE


def test_the_dog_forgives_less_than_a_quarter_period() -> None:
    direct = centred("QS01", "22000", "3")
    direct["1"].slip(10.3, 1, -90)
    assert direct.cmd("", at=12.0) == IDLE
    assert direct.cmd("96") == b">$10\r"


def test_no_detection_without_qs() -> None:
    direct = centred("22000", "3")
    direct["1"].slip(10.3, 1, -150)
    assert direct.cmd("", at=12.0) == IDLE
    assert direct.cmd("96") == b">$10\r"


def test_qs_for_the_other_motor_does_not_watch_this_one() -> None:
    direct = centred("QS10", "22000", "3")
    direct["1"].slip(10.3, 1, -150)
    assert direct.cmd("", at=12.0) == IDLE


def test_a_period_that_does_not_fit_the_dog_is_a_step_out() -> None:
    # Q 1024 with a 400-pulse dog: the first check that reads wrong stops the motor, as the
    # manual warns when Q does not match the dog (§10 Q 備考).
    direct = centred("QS01", "Q1024", "22000", "3")
    assert direct.cmd("", at=12.0) == LIMIT
    assert direct.cmd("96") == b">$11\r"


def test_the_sensor_off_at_the_origin_is_a_step_out() -> None:
    # §10 Q 重要な注意事項: the sensor must read ON at position 0 (else invert it with EA).
    direct = Direct()
    for text in ("R200", "QS01", "22000", "3"):  # position 0 now lies in a gap
        direct.cmd(text)
    assert direct.cmd("", at=2.0) == LIMIT
    assert direct.cmd("96") == b">$11\r"


def test_qse_uses_the_encoder_in_mode_0() -> None:
    # §10 QSE: mode 0 with the encoder: QE window (QE2 = ± 16), checks every 50 ms.
    # 20 pulses lost at 10.31 s: seen on the check at 10.35 s.
    direct = centred("QS01", "QSE01", "QE2", "22000", "3")
    direct["1"].slip(10.31, 1, -20)
    assert direct.cmd("", at=10.349) == MOVING
    assert direct.cmd("", at=10.351) == LIMIT
    assert direct.cmd("96") == b">$11\r"


def test_qse_forgives_what_the_dog_would_too() -> None:
    direct = centred("QS01", "QSE01", "QE2", "22000", "3")
    direct["1"].slip(10.31, 1, -16)
    assert direct.cmd("", at=12.0) == IDLE


def test_mode_2_watches_the_dog_and_pulses_clr() -> None:
    # §13-2 mode 2 注: Q and 0Q work in mode 2 too; §10 DS ⑥: CLR on a step-out.
    direct = centred("E2", "QS01", "22000", "3")
    direct["1"].slip(10.3, 1, -150)
    assert direct.cmd("", at=10.0 + PULSE_1000 + 0.001) == LIMIT
    assert direct.cmd("96") == b">$11\r"
    clr = direct["1"].snapshot(direct.now)["axes"]["1"]["clr_pulses"]
    assert [round(t, 6) for t in clr] == [round(10.0 + PULSE_1000, 6)]


async def test_slip_through_the_control_surface_stops_a_jog(
    make_wire: Callable[..., Wire],
) -> None:
    wire = make_wire("1")
    for frame in (b"$10Q\r",):
        assert await wire.exchange(frame) == ACK
    await wire.wait_idle()
    for frame in (b"$1QS01\r", b"$17\r"):
        assert await wire.exchange(frame) == ACK
    assert await wire.exchange(b"$1\r") == MOVING
    reply = wire.controls.handle({"op": "slip", "body": "1", "motor": 1, "pulses": -150})
    assert reply == {"ok": True}
    await wire.wait_idle()  # the jog stopped by itself
    assert await wire.exchange(b"$196\r") == b">$11\r"
    assert await wire.exchange(b"$17\r") == ACK  # refused: limit error, no motion
    assert await wire.exchange(b"$1\r") == LIMIT
