"""Mode 1: positions in encoder counts, the 8,388,608 rule, step-out by the encoder, QJ adjust.

§7-4 (動作モード 1 の制限), §10 E, PA, PB, QE, QS, QJ, QJT, QJA, QJO, RD, 9. Times are worked by
hand from the manual's formulas (§7-1) with the default speeds: fL 500 pps, fH 5,000 pps,
α 16,384 pps/s, a ramp fL -> fH takes 0.274658 s and 755.31 pulses, so a move of N >= 1,511
pulses lasts 2 × 0.274658 + (N - 1,510.62) / 5,000 s (2,000 pulses: 0.647192 s, as the
kinematics notes say). ``6`` in mode 1 is always signed (§7-4 ③).
"""

from __future__ import annotations

from tests.sim.direct import Direct

ACK = b">"
IDLE = b">$10\r"
MOVING = b">$11\r"
LIMIT = b">$12\r"


def move_time(pulses: int) -> float:
    """A move of ``pulses`` (>= 1,511) with the default speeds (module docstring)."""
    return 2 * 0.274658 + (pulses - 1510.62) / 5000


def mode_1(*setup: str) -> Direct:
    """Body 1 in mode 1 at position 0, with the given commands sent at time 0."""
    direct = Direct()
    for text in ("E1", "R0", *setup):
        assert direct.cmd(text) == ACK, text
    return direct


def test_a_move_is_counted_in_encoder_counts() -> None:
    # §10 PA: ×4; §10 PB: 10 output pulses per encoder pulse; so a count is 2.5 pulses and a
    # move to position 1,000 outputs 2,500 pulses (§7-4 ①: positions are encoder counts).
    direct = mode_1("PA4", "PB10", "21000", "3")
    end = move_time(2500)  # 0.747192 s; 1,000 pulses would take 0.436826 s
    assert direct.cmd("", at=end - 0.002) == MOVING
    assert direct.cmd("", at=end + 0.002) == IDLE
    assert direct.cmd("6") == b">$1+0001000\r"
    assert direct["1"].axes[1].mechanical(direct.now) == 30_000 + 2500


def test_the_manuals_pa_and_pb_example() -> None:
    # §10 PA 注意: PA 2 with a 1,000 pulse/turn encoder: one turn is position data 2,000.
    # §10 PB 解説: 200 steps × 50 microsteps / 1,000 = PB 10: one turn is 10,000 pulses.
    direct = mode_1("PA2", "PB10", "2+2000", "4")
    end = move_time(10_000)
    assert direct.cmd("", at=end - 0.002) == MOVING
    assert direct.cmd("", at=end + 0.002) == IDLE
    assert direct.cmd("6") == b">$1+0002000\r"
    assert direct.cmd("5") == ACK  # and back: 2,000 counts CCW
    assert direct.cmd("", at=direct.now + move_time(10_000) + 0.002) == IDLE
    assert direct.cmd("6") == b">$1+0000000\r"


def test_an_absolute_move_beyond_the_rule_is_a_limit_error() -> None:
    # §7-4 ②: |pp × PB / PA| < 8,388,608, else 3, 4, 5, B, B+(-) end in a limit error.
    # PA 1, PB 10: 838,861 × 10 = 8,388,610 breaks it; 838,860 × 10 = 8,388,600 keeps it.
    direct = mode_1("PB10", "2+838861")
    for move in ("3", "4", "5"):
        assert direct.cmd(move) == ACK
        assert direct.cmd("") == LIMIT, move  # not moving, limit error
    assert direct.cmd("A001+838861") == ACK
    assert direct.cmd("B001") == ACK
    assert direct.cmd("") == LIMIT
    assert direct.cmd("6") == b">$1+0000000\r"
    assert direct.cmd("2-838860") == ACK
    assert direct.cmd("3") == ACK
    assert direct.cmd("", at=1.0) == MOVING  # within the rule: it moves


def test_the_rule_depends_on_pa() -> None:
    # PA 2: 838,861 × 10 / 2 = 4,194,305 < 8,388,608.
    direct = mode_1("PA2", "PB10", "2+838861", "3")
    assert direct.cmd("", at=1.0) == MOVING


def test_the_rule_does_not_apply_in_mode_0() -> None:
    direct = Direct()
    direct.cmd("2838861")
    direct.cmd("3")
    assert direct.cmd("", at=1.0) == MOVING


def test_slip_beyond_qe_stops_the_motor_with_the_step_out_error() -> None:
    # §10 QE: default 4 = ± 64 output pulses, checked every 50 ms while the motor turns
    # (§10 QE 備考, §13-2); §10 QS 01: motor 1 only. 100 pulses lost at 0.52 s are seen on the
    # check at 0.55 s: the motor stops (§13-2 "脱調し止まります"), bit 6 of 9 and the limit
    # error are set (§10 9 bit 1, ⑥).
    direct = mode_1("QS01", "2+1000", "3")  # PA 1, PB 10: 10,000 pulses
    direct["1"].slip(0.52, 1, -100)
    assert direct.cmd("", at=0.549) == MOVING
    assert direct.cmd("", at=0.551) == LIMIT
    assert direct.cmd("96") == b">$11\r"
    assert direct.cmd("Q") == b">$11\r"
    assert direct.cmd("9") == b">$152\r"  # bit 6, mode 1 (bits 5-4 = 01), bit 1 (own store)


def test_slip_within_qe_is_no_step_out() -> None:
    direct = mode_1("QS01", "2+1000", "3")
    direct["1"].slip(0.52, 1, -64)  # ± 64 is still inside
    assert direct.cmd("", at=move_time(10_000) + 0.01) == IDLE
    assert direct.cmd("96") == b">$10\r"


def test_qe_sets_the_window() -> None:
    # QE0: ± 4 pulses; 5 lost is a step-out.
    direct = mode_1("QS01", "QE0", "2+1000", "3")
    direct["1"].slip(0.52, 1, -5)
    assert direct.cmd("", at=0.551) == LIMIT
    assert direct.cmd("96") == b">$11\r"


def test_without_qs_nothing_is_detected() -> None:
    direct = mode_1("2+1000", "3")
    direct["1"].slip(0.52, 1, -500)
    assert direct.cmd("", at=move_time(10_000) + 0.01) == IDLE
    assert direct.cmd("96") == b">$10\r"
    assert direct.cmd("6") == b">$1+0000950\r"  # the encoder counted what really happened


def step_out(direct: Direct) -> None:
    direct["1"].slip(0.52, 1, -100)
    assert direct.cmd("", at=0.6) == LIMIT


def test_after_a_step_out_motion_commands_are_refused_until_rd() -> None:
    # §10 Q 解説, §10 RD: only homing is taken, or RD in mode 1; a motion command meanwhile
    # ends in a limit error (§10 9 ⑦).
    direct = mode_1("QS01", "2+1000", "3")
    step_out(direct)
    position = direct.cmd("6")
    for move in ("3", "4", "1", "7", "8*", "B001"):
        assert direct.cmd(move) == ACK
        assert direct.cmd("") == LIMIT, move
    assert direct.cmd("6") == position
    assert direct.cmd("RD") == ACK
    assert direct.cmd("96") == b">$10\r"
    assert direct.cmd("3") == ACK  # §10 RD: moves again from where the encoder says it is
    assert direct.cmd("", at=direct.now + 0.01) == MOVING
    assert direct.cmd("", at=direct.now + 3.0) == IDLE
    assert direct.cmd("6") == b">$1+0001000\r"


def test_homing_clears_the_step_out_error() -> None:
    direct = mode_1("QS01", "2+1000", "3")
    step_out(direct)
    assert direct.cmd("0") == ACK
    assert direct.cmd("", at=direct.now + 1.0) == MOVING
    assert direct.cmd("", at=direct.now + 300.0) == IDLE
    assert direct.cmd("96") == b">$10\r"
    assert direct.cmd("6") == b">$1+0000000\r"


def test_qs_2_detects_at_rest_for_the_selected_motor() -> None:
    # §10 QS setting 2 (mode 1): detection at rest too, for the motor F selects.
    direct = mode_1("QS02")
    direct["1"].slip(1.0, 1, -100)
    assert direct.cmd("96", at=1.1) == b">$11\r"
    other = mode_1("QS20")  # motor 2 set to 2, but motor 1 is selected
    other["1"].slip(1.0, 2, -100)
    assert other.cmd("96", at=1.1) == b">$10\r"


# --- QJ adjustment (§10 QJ ①-④) ------------------------------------------------------------

#: PA 1, PB 10: position 1,000 is 10,000 pulses.
MOVE_END = move_time(10_000)  # 2.247192 s


def adjusted(*setup: str, lost: int = -100) -> Direct:
    """A move to 1,000 with QJ on for motor 1 and ``lost`` pulses lost at 1 s."""
    direct = mode_1("QJ01", *setup, "2+1000", "3")
    direct["1"].slip(1.0, 1, lost)
    return direct


def test_qj_corrects_a_deviation_after_qjt() -> None:
    # 100 pulses lost: the move ends at count 990. QJT 30 = 300 ms (§13-2 "QJT30": 0.3 s),
    # then Low speed (500 pps) CW until the count passes 1,000: 110 pulses (0.22 s), then one
    # pulse back to count 1,000 (0.002 s). "" reports moving all along (§10 QJ 注意点).
    direct = adjusted("QJT30")
    assert direct.cmd("", at=MOVE_END + 0.001) == MOVING  # waiting QJT
    assert direct.cmd("6") == b">$1+0000990\r"
    assert direct.cmd("", at=MOVE_END + 0.3 + 0.101) == MOVING  # adjusting
    assert direct.cmd("6") == b">$1+0000995\r"  # 50 pulses done: 5 counts
    assert direct.cmd("", at=MOVE_END + 0.3 + 0.22 + 0.002 - 0.0005) == MOVING
    assert direct.cmd("", at=MOVE_END + 0.3 + 0.22 + 0.002 + 0.0005) == IDLE
    assert direct.cmd("6") == b">$1+0001000\r"
    assert direct.cmd("96") == b">$10\r"


def test_qj_uses_the_qjo_speed() -> None:
    # §10 QJ form VIII: QJO × 300 / OX pps: QJO 1000 = 1,000 pps, 111 pulses = 0.111 s.
    direct = adjusted("QJO1000")  # QJT default 3 = 30 ms
    assert direct.cmd("", at=MOVE_END + 0.03 + 0.111 - 0.0005) == MOVING
    assert direct.cmd("", at=MOVE_END + 0.03 + 0.111 + 0.0005) == IDLE
    assert direct.cmd("6") == b">$1+0001000\r"


def test_no_deviation_no_adjustment() -> None:
    direct = adjusted(lost=0)
    assert direct.cmd("", at=MOVE_END + 0.029) == MOVING  # QJT 30 ms
    assert direct.cmd("", at=MOVE_END + 0.031) == IDLE
    assert direct.cmd("6") == b">$1+0001000\r"


def test_a_deviation_over_qja_ends_in_a_limit_error() -> None:
    # §10 QJ ③, §10 9 ⑦: after QJA pulses (here 50) of adjusting, stop with a limit error.
    direct = adjusted("QJA50")
    assert direct.cmd("", at=MOVE_END + 0.03 + 0.1 - 0.0005) == MOVING  # 50 pulses: 0.1 s
    assert direct.cmd("", at=MOVE_END + 0.03 + 0.1 + 0.0005) == LIMIT
    assert direct.cmd("6") == b">$1+0000995\r"
    assert direct.cmd("96") == b">$10\r"  # a limit error, not a step-out


def test_qj_off_for_the_motor_leaves_the_deviation() -> None:
    direct = mode_1("QJ10", "2+1000", "3")  # motor 2 only
    direct["1"].slip(1.0, 1, -100)
    assert direct.cmd("", at=MOVE_END + 0.001) == IDLE
    assert direct.cmd("6") == b">$1+0000990\r"
