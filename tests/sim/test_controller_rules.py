"""The simulated controller keeps the manual's rules: command errors, flags, modes, motion.

Everything here is checked against the RC-233 manual (取扱説明書), not against the simulator's
code: the bytes a host would see, with the manual's own examples where it prints them.

- §9-1 注意: a command with a format error is ignored and sets the command-error flag; so is a
  motion command sent while a motor turns. The reply is still '>' (§9-2: '>' only means the
  communication was normal).
- §10 "" and §10 9: two separate flag stores, each cleared by its own read only; ``9{bit}``
  clears nothing; step-out (bit 6) survives ``9``; bits 4-5 are the mode, bit 7 the motor.
- §10 E0/E1/E2 columns: a form not usable in the current mode is ignored with the command error.
- §10 動作中 column: a form marked × is ignored with the command error while a motor moves;
  one marked ○ is executed.
- §9-1, §10 F: the motor suffix of a motion command selects the motor for good; the motor
  argument of 6, QD, CLM, CI does not; per-motor and shared settings.
- §7-1, §10 OC/OH/OL: the S-curve inequalities; §10 OS: OSI/OSD beyond the range.
- §10 EP, §7-4: one 24-bit counter shown unsigned (EP0) or signed (EP1, and always in mode 1).

Motion uses the default scene of ``gateway.sim.scene``: the axis starts at mechanical position
30,000 with the CW limit at 95,000, so a CW jog at the default Low speed (500 pps, §16 OL)
turns for 130 s before the limit stops it.
"""

from __future__ import annotations

import pytest

from tests.sim.direct import Direct

ACK = b">"
#: §10 "" replies of body 1: stopped and clean / moving (§8-2 ">$11") / moving + command error.
IDLE = b">$10\r"
MOVING = b">$11\r"
MOVING_AND_COMMAND_ERROR = b">$19\r"
COMMAND_ERROR = b">$18\r"  # §8-2: ">$18" = command error
#: 65,000 pulses at 500 pps: the default jog reaches the CW limit after 130 s.
JOG_TO_LIMIT = 200.0


def start_jog(direct: Direct, text: str = "7") -> None:
    """Start a CW jog (§10 7) and check that the motor turns without any error."""
    assert direct.cmd(text) == ACK
    direct.advance(1.0)
    assert direct.cmd("") == MOVING


def stop_motion(direct: Direct) -> None:
    """Stop at once (§10 S) and let the stop finish; flags are left as they are."""
    assert direct.cmd("S") == ACK
    direct.advance(1.0)


def wait_idle(direct: Direct, seconds: float = 30.0) -> None:
    """Let a short move finish."""
    direct.advance(seconds)


def latch_step_out(direct: Direct) -> None:
    """Latch the step-out error (bit 6 of 9), as a detected step-out does (§10 Q, §10 9).

    Set directly here: the rules below depend on the latch, not on how it was detected
    (detection: tests/sim/test_stepout.py).
    """
    direct["1"].flags.step_out = True


def sum8(body: bytes) -> bytes:
    """§10 SUM: the low byte of the sum of the ASCII codes, two upper-case hex digits."""
    return b"%02X" % (sum(body) % 256)


# ============================================================== command errors (§9-1 注意)

MALFORMED = [
    pytest.param("XYZ", id="unknown-mnemonic"),
    pytest.param("oh5000", id="lower-case"),  # §9-1 注意: 半角大文字 only
    pytest.param("OH0", id="OH-below-1"),  # §10 OH: 1-16,383
    pytest.param("OH16384", id="OH-above-16383"),
    pytest.param("OH123456", id="OH-six-digits"),  # 10進数5桁以下
    pytest.param("OH5000X", id="trailing-text"),
    pytest.param("OC101", id="OC-above-100"),  # §10 OC: 0-100
    pytest.param("OS0", id="OS-below-1"),  # §10 OS: 1-32,767
    pytest.param("OS32768", id="OS-above-32767"),
    pytest.param("OX1", id="OX-below-2"),  # §10 OX: 2-16,383
    pytest.param("OX16384", id="OX-above-16383"),
    pytest.param("E3", id="E-mode-3"),  # §10 E: 0-2
    pytest.param("F3", id="F-motor-3"),  # §10 F: 1 or 2
    pytest.param("F0", id="F-motor-0"),
    pytest.param("ES3", id="ES-3"),  # §10 ES: 0-2
    pytest.param("0B6", id="0B-above-5"),  # §10 0B: 0-5
    pytest.param("B01", id="B-two-digit-position-number"),  # §10 B: 必ず 3 桁
    pytest.param("A01", id="A-two-digit-position-number"),  # §10 A: 3 digits
    pytest.param("R16777216", id="R-beyond-24-bits"),  # §10 R: 0-16,777,215 (EP0)
    pytest.param("2-1", id="negative-position-in-EP0"),  # §10 2: EP0 is 0-16,777,215
    pytest.param("9 ", id="space"),
]


@pytest.mark.parametrize("text", MALFORMED)
def test_a_malformed_command_is_answered_ack_and_sets_the_command_error(text: str) -> None:
    direct = Direct()
    assert direct.cmd(text) == ACK  # §9-2: '>' = communication normal, not "command valid"
    assert direct.cmd("") == COMMAND_ERROR
    assert direct.cmd("9") == b">$108\r"  # the other store has it too (§10 9 bit 3)


@pytest.mark.parametrize(
    ("text", "query", "unchanged"),
    [
        ("OH16384", "OH", b">$105000\r"),
        ("oh1000", "OH", b">$105000\r"),
        ("OC101", "OC", b">$1000\r"),
        ("E3", "E", b">$10\r"),
        ("F3", "F", b">$11\r"),
        ("OX1", "OX", b">$100300\r"),
        ("R16777216", "6", None),  # compared with the reading before
    ],
)
def test_an_ignored_command_changes_nothing(text: str, query: str, unchanged: bytes | None) -> None:
    direct = Direct()
    before = direct.cmd(query)
    direct.cmd(text)
    assert direct.cmd(query) == (before if unchanged is None else unchanged)


def test_a_query_refused_as_a_command_error_gets_a_bare_ack() -> None:
    # §9-1 注意 (ignored) and §9-2 ('>' = communication normal): no data reply at all.
    direct = Direct()
    assert direct.cmd("QJ") == ACK  # QJ is a mode-1 command (§10 QJ); the mode is 0
    assert direct.cmd("") == COMMAND_ERROR


def test_program_text_not_starting_with_slash_is_a_command_error() -> None:
    # §10 I 注意点: ユーザープログラムの転送で、最初に転送した文字が "/" では無かった場合、
    # その時点で ">" をかえし、コマンドエラーになります.
    direct = Direct()
    assert direct.cmd("I") == ACK
    assert direct.send(b"/END\r") == ACK
    assert direct.cmd("I") == ACK
    assert direct.send(b"D00/END\r") == ACK
    assert direct.cmd("") == COMMAND_ERROR
    assert direct.cmd("IR") == b">$1/END\r"  # nothing of the refused text was stored


# ============================================================== the two flag stores


def test_power_on_flags_match_the_manual_examples() -> None:
    direct = Direct()
    assert direct.cmd("") == IDLE  # §8-1, §10 "" 応答例 (I)
    assert direct.cmd("9") == b">$100\r"  # §10 9 応答例 (I): no error, mode 0, motor 1


def test_status_read_clears_only_the_status_flags() -> None:
    # §10 "" 注意点: bits 1-3 are cleared after the reply; §10 9 ④: the stores are separate.
    direct = Direct()
    direct.cmd("XYZ")
    assert direct.cmd("") == COMMAND_ERROR
    assert direct.cmd("") == IDLE
    assert direct.cmd("9") == b">$108\r"
    assert direct.cmd("9") == b">$100\r"  # §10 9 ①: form I clears bits 0-3


def test_condition_read_clears_only_the_condition_flags() -> None:
    # §10 "" 注意点 (3rd item): executing 9 does not clear the "" flags.
    direct = Direct()
    direct.cmd("XYZ")
    assert direct.cmd("9") == b">$108\r"
    assert direct.cmd("9") == b">$100\r"
    assert direct.cmd("") == COMMAND_ERROR
    assert direct.cmd("") == IDLE


def test_errors_stay_latched_until_read() -> None:
    # §10 "" 注意点: the flag is kept until "" reads it, whatever comes in between.
    direct = Direct()
    direct.cmd("XYZ")
    for text in ("OH", "OL", "6", "F2", "F1", "OH5000"):
        direct.cmd(text)
    assert direct.cmd("") == COMMAND_ERROR


@pytest.mark.parametrize("bit", [0, 1, 2, 3, 6, 7])
def test_a_single_bit_read_clears_nothing(bit: int) -> None:
    # §10 9 ②: form II leaves every flag as it was.
    direct = Direct()
    direct.cmd("XYZ")
    expected = b">$11\r" if bit == 3 else b">$10\r"
    assert direct.cmd(f"9{bit}") == expected
    assert direct.cmd(f"9{bit}") == expected
    assert direct.cmd("9") == b">$108\r"
    assert direct.cmd("") == COMMAND_ERROR


@pytest.mark.parametrize(("mode", "bits_5_4"), [(0, b"0"), (1, b"1"), (2, b"2")])
def test_condition_bits_4_and_5_are_the_mode(mode: int, bits_5_4: bytes) -> None:
    # §10 9: b5 b4 = 00 mode 0, 01 mode 1, 10 mode 2; form II on bit 4 or 5 answers 0-2.
    direct = Direct()
    assert direct.cmd(f"E{mode}") == ACK
    assert direct.cmd("9") == b">$1" + bits_5_4 + b"0\r"
    assert direct.cmd("94") == b">$1%d\r" % mode
    assert direct.cmd("95") == b">$1%d\r" % mode


def test_manual_example_mode_2_through_bit_4() -> None:
    direct = Direct()
    direct.cmd("E2")
    assert direct.cmd("94") == b">$12\r"  # §10 9 使用例: "$194" -> ">$12"


def test_condition_bit_7_is_the_selected_motor() -> None:
    # §10 9 bit 7: 1 = the next command acts on motor 2.
    direct = Direct()
    assert direct.cmd("97") == b">$10\r"
    direct.cmd("F2")
    assert direct.cmd("9") == b">$180\r"
    assert direct.cmd("97") == b">$11\r"
    direct.cmd("F1")
    assert direct.cmd("9") == b">$100\r"


def test_communication_error_is_a_condition_flag_only() -> None:
    # §10 9 bit 0: noise or overflow; the status flags of "" have no such bit (§10 "").
    direct = Direct()
    direct["1"].note_noise(direct.now)
    assert direct.cmd("90") == b">$11\r"
    assert direct.cmd("") == IDLE
    assert direct.cmd("9") == b">$101\r"
    assert direct.cmd("9") == b">$100\r"


def test_manual_example_9A_command_and_limit_error_mode_1_motor_2() -> None:
    # §10 9 応答例 (II): ">$19A" = command error + limit error, mode 1, motor 2 selected.
    direct = Direct()
    direct.cmd("F2")
    assert direct.cmd("7") == ACK
    direct.advance(JOG_TO_LIMIT)  # the CW limit stops the jog with a limit error (§4-4)
    assert direct.cmd("E1") == ACK
    direct.cmd("XYZ")
    assert direct.cmd("9") == b">$19A\r"


def test_manual_example_A_command_and_limit_error_stopped() -> None:
    # §10 "" 応答例 (III): ">$1A" = command error + limit error, motor stopped.
    direct = Direct()
    direct.cmd("7")
    direct.advance(JOG_TO_LIMIT)
    direct.cmd("XYZ")
    assert direct.cmd("") == b">$1A\r"


def test_manual_example_29_command_error_while_moving_body_2() -> None:
    # §10 "" 応答例 (II): ">$29" = body 2, command error, motor moving.
    direct = Direct(bodies="2")
    assert direct.cmd("7", body="2") == ACK
    direct.advance(1.0)
    assert direct.cmd("7", body="2") == ACK  # a motion command while moving (§9-1 注意)
    assert direct.cmd("", body="2") == b">$29\r"


def test_limit_sensor_stop_reads_12() -> None:
    # §8-2: ">$12" = the limit sensor is ON and the motor stopped.
    direct = Direct()
    direct.cmd("7")
    direct.advance(JOG_TO_LIMIT)
    assert direct.cmd("") == b">$12\r"
    assert direct.cmd("9") == b">$102\r"  # the condition store latched it too
    assert direct.cmd("96") == b">$10\r"  # §10 9 ⑥: bit 6 = 0, so the limit sensor did it


def test_step_out_bit_survives_the_condition_read() -> None:
    # §10 9 ⑤: bit 6 is not cleared by reading 9.
    direct = Direct()
    latch_step_out(direct)
    assert direct.cmd("9") == b">$140\r"
    assert direct.cmd("9") == b">$140\r"
    assert direct.cmd("96") == b">$11\r"
    assert direct.cmd("") == IDLE  # "" has no step-out bit


def test_motion_with_the_step_out_error_is_a_limit_error_and_does_not_move() -> None:
    # §10 9 ⑦: a motion command (homing excepted) with bit 6 set sets the limit error;
    # §10 RD: with the step-out error only homing is accepted.
    direct = Direct()
    direct.cmd("R0")
    direct.cmd("21000")
    latch_step_out(direct)
    assert direct.cmd("4") == ACK
    direct.advance(5.0)
    assert direct.cmd("6") == b">$100000000\r"
    assert direct.cmd("") == b">$12\r"


def test_completed_homing_clears_the_step_out_error() -> None:
    # §10 9 ⑤: when the origin search of "0" ends, bit 6 is cleared automatically.
    direct = Direct()
    latch_step_out(direct)
    assert direct.cmd("0") == ACK  # homing is accepted with the step-out error
    direct.advance(1.0)
    assert direct.cmd("") == MOVING
    direct.advance(300.0)  # 30,000 pulses at Low speed, then the ORG approach
    assert direct.cmd("") == IDLE
    assert direct.cmd("96") == b">$10\r"
    assert direct.cmd("6") == b">$100000000\r"  # the stop point is position 0 (§10 0)


def test_rd_clears_the_step_out_error_in_mode_1() -> None:
    # §10 9 ⑤: in mode 1, RD clears bit 6.
    direct = Direct()
    direct.cmd("E1")
    latch_step_out(direct)
    assert direct.cmd("RD") == ACK
    assert direct.cmd("96") == b">$10\r"
    assert direct.cmd("") == IDLE


def test_emergency_stop_is_latched_in_both_stores() -> None:
    # §10 "" bit 2, §10 9 bit 2: the EMS input was ON.
    direct = Direct()
    start_jog(direct)
    direct["1"].set_ems(direct.now, True)
    direct["1"].set_ems(direct.now, False)
    direct.advance(1.0)
    assert direct.cmd("") == b">$14\r"  # stopped (EMS stops everything), bit 2
    assert direct.cmd("9") == b">$104\r"


@pytest.mark.parametrize("text", ["K1,01", "K2,3", "K7,FF"])
def test_k_setting_clears_limit_and_ems_status_bits_only(text: str) -> None:
    # §10 K (I), (II): 実行すると同時に、ステータス・フラグのリミット・エラーと非常停止のビット
    # はクリア. Nothing is said of the condition flags, which are another store (§10 9 ④).
    direct = Direct()
    direct.cmd("7")
    direct.advance(JOG_TO_LIMIT)
    direct.cmd("XYZ")
    assert direct.cmd(text) == ACK
    assert direct.cmd("") == COMMAND_ERROR  # limit cleared, command error kept
    assert direct.cmd("9") == b">$10A\r"


def test_kc_clears_limit_status_when_the_function_is_on() -> None:
    # §10 K (IV): KC also clears the limit and EMS bits of the status flags.
    direct = Direct()
    direct.cmd("K1,01")
    direct.cmd("7")
    direct.advance(JOG_TO_LIMIT)
    assert direct.cmd("KC") == ACK
    assert direct.cmd("") == IDLE


def test_kc_with_the_function_off_is_a_command_error() -> None:
    # §10 K (IV): 書式 (III) で『エラー出力機能』が解除されている時は、無効です。コマンド・エラー.
    direct = Direct()
    assert direct.cmd("KC") == ACK
    assert direct.cmd("") == COMMAND_ERROR
    direct.cmd("K1,01")
    direct.cmd("K0")
    assert direct.cmd("KC") == ACK
    assert direct.cmd("") == COMMAND_ERROR


# ============================================================== operating modes (§10 E0/E1/E2)

#: (text, mode in which the manual marks it ×, mode in which it is ○). From the E0/E1/E2 row
#: of each §10 page (manual line of the row in the comment); △ rows from the form's own note.
MODE_REFUSED = [
    ("0Q20", 1, 0),  # §10 0Q ○×○ (1442)
    ("0QD", 1, 2),
    ("0QW", 1, 0),
    ("0X1", 0, 2),  # §10 0X ××○ (1672)
    ("0X", 1, 2),
    ("CI", 0, 2),  # §10 CI ××○ (2989)
    ("CI2", 1, 2),
    ("CA", 2, 0),  # §10 C (III): この書式は、動作モード 2 では使用出来ません (2899)
    ("COA", 2, 1),  # §10 CO (II): この書式は、動作モード 2 では使用出来ません (3262)
    ("D81B", 2, 0),  # §10 D: 動作モード 2 の時、bit 8, 9 の ON, OFF は出来ません (3365)
    ("DA100", 2, 1),  # §10 D (IV): この書式は、動作モード 2 では使用出来ません (3386)
    ("DS11", 0, 2),  # §10 DS ××○ (3475)
    ("DSR", 1, 2),
    ("DS", 0, 2),
    ("EP1", 1, 0),  # §10 EP ○×○ (4142)
    ("EP", 1, 2),
    ("PA2", 2, 1),  # §10 PA ×○× (5862)
    ("PB20", 2, 1),  # §10 PB ×○× (5936)
    ("Q500", 1, 0),  # §10 Q (step-out period) ○×○ (6033)
    ("QD", 1, 2),
    ("QD2", 1, 0),
    ("QE5", 2, 1),  # §10 QE ○○× (6171)
    ("QE", 2, 0),
    ("QJ11", 0, 1),  # §10 QJ ×○× (6298), every form
    ("QJ", 2, 1),
    ("QJR", 0, 1),
    ("QJT5", 2, 1),
    ("QJA900", 0, 1),
    ("QJO10", 2, 1),
    ("QSE11", 1, 0),  # §10 QSE ○×× (6556)
    ("QSE", 2, 0),
    ("RD", 0, 1),  # §10 RD ×○× (6638)
    ("RD", 2, 1),
]


@pytest.mark.parametrize(("text", "refused_in", "usable_in"), MODE_REFUSED, ids=lambda v: str(v))
def test_a_form_outside_its_modes_is_a_command_error(
    text: str, refused_in: int, usable_in: int
) -> None:
    direct = Direct()
    assert direct.cmd(f"E{refused_in}") == ACK
    assert direct.cmd(text) == ACK  # ignored: no data reply even for a query
    assert direct.cmd("") == COMMAND_ERROR


@pytest.mark.parametrize(("text", "refused_in", "usable_in"), MODE_REFUSED, ids=lambda v: str(v))
def test_the_same_form_is_accepted_in_its_mode(text: str, refused_in: int, usable_in: int) -> None:
    direct = Direct()
    assert direct.cmd(f"E{usable_in}") == ACK
    direct.cmd(text)
    assert direct.cmd("") == IDLE


@pytest.mark.parametrize(
    ("setting", "query", "reply", "mode"),
    [
        ("PA2", "PA", b">$12\r", 1),
        ("PB20", "PB", b">$1020\r", 1),
        ("QJ10", "QJ", b">$110\r", 1),
        ("QJT5", "QJT", b">$1005\r", 1),
        ("QJA900", "QJA", b">$100900\r", 1),
        ("QJO10", "QJO", b">$100010\r", 1),
        ("QE5", "QE", b">$15\r", 1),
        ("Q500", "QD", b">$100500\r", 2),
        ("0Q20", "0QD", b">$100020\r", 2),
        ("0X1", "0X", b">$11\r", 2),
        ("EP1", "EP", b">$11\r", 2),
        ("QSE10", "QSE", b">$110\r", 0),
    ],
)
def test_a_mode_specific_setting_is_stored_in_its_mode(
    setting: str, query: str, reply: bytes, mode: int
) -> None:
    direct = Direct()
    direct.cmd(f"E{mode}")
    assert direct.cmd(setting) == ACK
    assert direct.cmd(query) == reply


def test_a_refused_mode_setting_keeps_the_old_value() -> None:
    direct = Direct()
    direct.cmd("E1")
    direct.cmd("EP1")  # §10 EP: × in mode 1
    direct.cmd("E0")
    assert direct.cmd("EP") == b">$10\r"


def test_mode_1_reports_signed_positions_whatever_ep_says() -> None:
    # §10 E 注意点, §10 EP 注意点, §7-4 ③: mode 1 is always signed.
    direct = Direct()
    direct.cmd("R1234")
    assert direct.cmd("6") == b">$100001234\r"
    direct.cmd("E1")
    assert direct.cmd("6") == b">$1+0001234\r"
    direct.cmd("E0")
    assert direct.cmd("6") == b">$100001234\r"


# ============================================================== while a motor moves (動作中)

#: Forms marked × in the 動作中 column (manual line of the row), each with a query that shows
#: after the stop that nothing changed (None: the command error is the only trace).
REFUSED_WHILE_MOVING = [
    ("0", None),  # §10 0 (1141)
    ("02", "F"),  # motor suffix of an ignored command: selection unchanged
    ("0A", None),  # §10 0A (1242)
    ("0H", None),  # §10 0H (1374)
    ("0R", None),  # §10 0R (1527)
    ("0Z", None),  # §10 0Z × (1828), every form
    ("0Z3", "0ZD"),
    ("0ZD", None),
    ("0Q", None),  # §10 0Q △: the centring motion (1442)
    ("1", None),  # §10 1 (1948)
    ("12", "F"),
    ("3", None),  # §10 3 (2021)
    ("4", None),  # §10 4 (2092)
    ("5", None),  # §10 5 (2157)
    ("7", None),  # §10 7 (2261)
    ("72", "F"),
    ("7*", None),  # §10 7* (2325)
    ("8", None),  # §10 8 (2357)
    ("82", "F"),
    ("8*", None),  # §10 8* (2400)
    ("B001", None),  # §10 B (2721)
    ("B", None),
    ("B0012", "F"),
    ("B001+", None),  # §10 B+(-) (2808)
    ("B-", None),
    ("AL", None),  # §10 AL (2666)
    ("AW", None),  # §10 AW (2699)
    ("CLM1", None),  # §10 CL (III): モータが回転中の時に書式 (III) は使えません (3239)
    ("DL", None),  # §10 DL (3429)
    ("DW", None),  # §10 DW (3563)
    ("E1", "E"),  # §10 E (3630)
    ("E", None),
    ("EA0E", "EA"),  # §10 EA (3680)
    ("EAH", "EA"),
    ("EA", None),
    ("ED0", "ED"),  # §10 ED (3798)
    ("EE1", "EE"),  # §10 EE (3857)
    ("EE", None),
    ("EE///", None),  # §10 EE/// (4038)
    ("EL1", "EL"),  # §10 EL (4074)
    ("EL", None),
    ("EP1", "EP"),  # §10 EP (4142)
    ("ER1", "ER"),  # §10 ER (4189)
    ("ES1", "ES"),  # §10 ES (4228)
    ("F2", "F"),  # §10 F (4331): "モータ動作中にコマンド F を実行する事が出来ない"
    ("F", None),
    ("GAS", "GA"),  # §10 GA (4444)
    ("IL", None),  # §10 IL (4845)
    ("IW", None),  # §10 IW (4888)
    ("N11000,2000", "N1"),  # §10 N (5093), every form
    ("NS", "N"),
    ("N", None),
    ("OC10", "OC"),  # §10 OC (5340)
    ("OC", None),
    ("R", None),  # §10 R (6589)
    ("R100", None),
]

#: What the state queries above read after the stop when the command was refused (§16).
UNCHANGED = {
    "F": b">$11\r",
    "0ZD": b">$11\r",
    "E": b">$10\r",
    "EA": b">$100\r",
    "ED": b">$11\r",
    "EE": b">$10\r",
    "EL": b">$10\r",
    "EP": b">$10\r",
    "ER": b">$10\r",
    "ES": b">$10\r",
    "GA": b">$10\r",
    "N1": b">$100000,00000000\r",
    "N": b">$10\r",
    "OC": b">$1000\r",
}


@pytest.mark.parametrize(("text", "check"), REFUSED_WHILE_MOVING, ids=lambda v: str(v))
def test_a_form_marked_x_while_moving_is_a_command_error(text: str, check: str | None) -> None:
    direct = Direct()
    start_jog(direct)
    assert direct.cmd(text) == ACK  # ignored: a bare '>' also for a query
    # An accepted EE/// would make the controller deaf here (§10 EE///).
    assert direct.cmd("") == MOVING_AND_COMMAND_ERROR
    stop_motion(direct)
    direct.advance(30.0)
    assert direct.due() == []  # no $1* of an EEPROM write or erase that was refused
    assert direct.cmd("9") == b">$108\r"  # bit 7 = 0: a motor-2 suffix selected nothing
    if check is not None:
        assert direct.cmd(check) == UNCHANGED[check]


#: Forms marked ○ in the 動作中 column: executed while the motor turns, no command error.
ACCEPTED_WHILE_MOVING = [
    '""',  # §10 "" (1047)
    "0B3",  # §10 0B (1338)
    "0B",
    "0S40",  # §10 0S (1622)
    "0S",
    "0Q20",  # §10 0Q △: the settings and queries (II)-(IV)
    "0QD",
    "2123",  # §10 2 (I): only form II is marked as not usable while turning
    "2D",
    "6",  # §10 6 (2219)
    "62",
    "9",  # §10 9 (2420)
    "97",
    "A000100",  # §10 A (2601)
    "A000",
    "A000D",
    "C",  # §10 C (2875)
    "C0",
    "CL",  # §10 CL (I), (II) (3239: "回転中は書式 (I) を使用してください")
    "CL0",
    "CO",  # §10 CO (3246)
    "D01",  # §10 D (3296)
    "D01B",
    "GN",  # §10 GN (4595)
    "GSS",  # §10 GSS (4705)
    "GR1",  # §10 GR (4625)
    "GW1123",  # §10 GW (4733)
    "H",  # §10 H (4786)
    "IR",  # §10 IR (4873)
    "K1,01",  # §10 K (4907)
    "K",
    "L",  # §10 L (5080)
    "OH6000",  # §10 OH (5453)
    "OH",
    "OHI10",
    "OL600",  # §10 OL (5553)
    "OLD10",
    "OS400",  # §10 OS (5636)
    "OSI10",
    "OX300",  # §10 OX (5735)
    "OX",
    "P010",  # §10 P (5810)
    "Q",  # §10 Q (6008)
    "Q500",  # §10 Q step-out period (6033)
    "QD",
    "QE5",  # §10 QE (6171)
    "QS11",  # §10 QS (6478)
    "QS",
    "QSE11",  # §10 QSE (6556)
    "SUM",  # §10 SUM (6689)
    "T10",  # §10 T (6791)
    "T",
    "GRT",
    "V",  # §10 V (6861)
]


@pytest.mark.parametrize("text", ACCEPTED_WHILE_MOVING)
def test_a_form_marked_o_while_moving_is_accepted(text: str) -> None:
    direct = Direct()
    start_jog(direct)
    direct.cmd("" if text == '""' else text)
    assert direct.cmd("") in (MOVING, IDLE)  # no command error; L/H keep it moving


def test_settings_marked_o_take_effect_while_moving() -> None:
    direct = Direct()
    start_jog(direct)
    for text, query, reply in [
        ("OH6000", "OH", b">$106000\r"),
        ("OL600", "OL", b">$100600\r"),
        ("OS400", "OS", b">$100400\r"),
        ("0S40", "0S", b">$100040\r"),
        ("0B3", "0B", b">$13\r"),
        ("2123", "2D", b">$100000123\r"),
        ("A000100", "A000D", b">$100000100\r"),
        ("QS11", "QS", b">$111\r"),
    ]:
        assert direct.cmd(text) == ACK
        assert direct.cmd(query) == reply
    assert direct.cmd("") == MOVING


def test_sum1_is_usable_while_moving() -> None:
    # §10 SUM: 動作中 ○ (6689), unlike EE, EL and ER.
    direct = Direct()
    start_jog(direct)
    assert direct.cmd("SUM1") == ACK
    frame = b"$1SUM"
    assert direct.send(frame + sum8(frame) + b"\r") == b">$11C4\r"  # §10 SUM (III) example


def test_storing_the_current_position_while_moving_stores_the_start_point() -> None:
    # §10 2 注意点: "モータの回転中に書式 (II) を実行すると、エラーにはなりませんが、移動の起点
    # となったポジション (モータが動きだす前の位置) が記憶されます".
    direct = Direct()
    direct.cmd("R1000")
    start_jog(direct)
    assert direct.cmd("2") == ACK
    assert direct.cmd("") == MOVING
    assert direct.cmd("2D") == b">$100001000\r"


def test_a_motion_command_for_the_other_motor_while_one_moves_is_refused() -> None:
    # §2, §3-II: the two motors never move together; §9-1 注意: motion while moving.
    direct = Direct()
    direct.cmd("F2")
    direct.cmd("R0")
    direct.cmd("F1")
    start_jog(direct)
    assert direct.cmd("82") == ACK
    assert direct.cmd("") == MOVING_AND_COMMAND_ERROR
    assert direct.cmd("97") == b">$10\r"  # the suffix of the ignored command selected nothing
    direct.advance(2.0)
    assert direct.cmd("62") == b">$100000000\r"  # motor 2 never moved


# ============================================================== motor selection (§9-1, §10 F)


def test_a_motor_suffix_selects_the_motor_for_good() -> None:
    # §9-1 注意 example: "$132" = F2 then 3; a later "$14" acts on motor 2.
    direct = Direct()
    for motor in (1, 2):
        direct.cmd(f"F{motor}")
        direct.cmd("R0")
    direct.cmd("F1")
    direct.cmd("21000")
    assert direct.cmd("32") == ACK
    direct.advance(1.0)
    assert direct.cmd("97") == b">$11\r"
    wait_idle(direct)
    assert direct.cmd("F") == b">$12\r"
    assert direct.cmd("61") == b">$100000000\r"
    assert direct.cmd("62") == b">$100001000\r"
    assert direct.cmd("4") == ACK  # no suffix: motor 2, selected by "32"
    wait_idle(direct)
    assert direct.cmd("61") == b">$100000000\r"
    assert direct.cmd("62") == b">$100002000\r"


@pytest.mark.parametrize("text", ["0", "1", "3", "4", "5", "7", "8", "B001", "B", "B001+"])
def test_every_motion_suffix_selects_motor_2(text: str) -> None:
    # §10 F <モータを指定して動かすコマンド>: 0, 0R, 0H, 0A, 1, 3, 4, 5, 7, 8, B, B+(-).
    direct = Direct()
    direct.cmd("21000")
    direct.cmd("A001500")
    suffixed = text[:-1] + "2" + text[-1] if text.endswith("+") else text + "2"
    assert direct.cmd(suffixed) == ACK
    assert direct.cmd("97") == b">$11\r"


@pytest.mark.parametrize("text", ["62", "QD2", "CLM2"])
def test_a_query_with_a_motor_number_keeps_the_selection(text: str) -> None:
    # §10 F <モータを指定してデータを問い合わせるコマンド>: 6, QD, CL(M1, M2), CI.
    direct = Direct()
    direct.cmd(text)
    assert direct.cmd("F") == b">$11\r"
    assert direct.cmd("") == IDLE


def test_ci_with_a_motor_number_keeps_the_selection() -> None:
    direct = Direct()
    direct.cmd("E2")  # CI is a mode-2 command (§10 CI)
    direct.cmd("CI2")
    assert direct.cmd("F") == b">$11\r"


@pytest.mark.parametrize(("text", "query"), [("2", "2D"), ("A007", "A007D")])
def test_storing_the_current_position_takes_the_selected_motor(text: str, query: str) -> None:
    # §10 2 (II), §10 A (II): "現在のポジション" -- of the motor the commands act on (§10 F).
    direct = Direct()
    direct.cmd("R111")
    direct.cmd("F2")
    direct.cmd("R222")
    assert direct.cmd(text) == ACK
    assert direct.cmd(query) == b">$100000222\r"
    direct.cmd("F1")
    assert direct.cmd(text) == ACK
    assert direct.cmd(query) == b">$100000111\r"


def test_6_with_a_motor_number_reads_that_motor() -> None:
    direct = Direct()
    direct.cmd("R111")
    direct.cmd("F2")
    direct.cmd("R222")
    direct.cmd("F1")
    assert direct.cmd("61") == b">$100000111\r"
    assert direct.cmd("62") == b">$100000222\r"
    assert direct.cmd("6") == b">$100000111\r"


#: Settings stored per motor (§10 F list: 0S, OH, OL, OS, OC, Q, PA, PB, R; §10 0B, 0Q, EA).
PER_MOTOR = [
    ("0S40", "0S", b">$100040\r", b">$100020\r", 0),
    ("0B3", "0B", b">$13\r", b">$12\r", 0),
    ("0Q20", "0QD", b">$100020\r", b">$100010\r", 0),
    ("OH6000", "OH", b">$106000\r", b">$105000\r", 0),
    ("OL600", "OL", b">$100600\r", b">$100500\r", 0),
    ("OS400", "OS", b">$100400\r", b">$100300\r", 0),
    ("OC10", "OC", b">$1010\r", b">$1000\r", 0),
    ("Q500", "QD", b">$100500\r", b">$100400\r", 0),
    ("PA2", "PA", b">$12\r", b">$11\r", 1),
    ("PB20", "PB", b">$1020\r", b">$1010\r", 1),
    ("R777", "6", b">$100000777\r", None, 0),
    ("EA08", "EA", b">$108\r", b">$100\r", 0),  # ORG logic: per motor (§10 EA)
]


@pytest.mark.parametrize(
    ("setting", "query", "set_reply", "default", "mode"), PER_MOTOR, ids=lambda v: str(v)
)
def test_a_per_motor_setting_leaves_the_other_motor_alone(
    setting: str, query: str, set_reply: bytes, default: bytes | None, mode: int
) -> None:
    direct = Direct()
    direct.cmd(f"E{mode}")
    other_before = direct.cmd(query)  # motor 1
    direct.cmd("F2")
    assert direct.cmd(setting) == ACK
    assert direct.cmd(query) == set_reply
    direct.cmd("F1")
    assert direct.cmd(query) == (other_before if default is None else default)


@pytest.mark.parametrize(
    ("setting", "query", "reply", "mode"),
    [
        ("2700", "2D", b">$100000700\r", 0),  # §10 2: モータ 1, 2 共用
        ("A123700", "A123D", b">$100000700\r", 0),  # §10 A: shared table
        ("E2", "E", b">$12\r", 0),  # §10 E: モータ 1, 2 共有
        ("EP1", "EP", b">$11\r", 0),  # §10 EP: モータ 1, 2 共有
        ("OX600", "OX", b">$100600\r", 0),  # §10 OX: 共通データ
        ("EA10", "EA", b">$110\r", 0),  # §10 EA 注意点: the EMS bit is common
        ("QJT5", "QJT", b">$1005\r", 1),  # §10 QJ (IV): 共通データ
        ("QJA900", "QJA", b">$100900\r", 1),  # §10 QJ (VI)
        ("QJO10", "QJO", b">$100010\r", 1),  # §10 QJ (VIII)
    ],
)
def test_a_shared_setting_is_the_same_for_both_motors(
    setting: str, query: str, reply: bytes, mode: int
) -> None:
    direct = Direct()
    direct.cmd(f"E{mode}")
    direct.cmd("F2")
    assert direct.cmd(setting) == ACK
    direct.cmd("F1")
    assert direct.cmd(query) == reply


def test_eah_and_eal_set_both_motors() -> None:
    # §10 EA (III), (IV): モータ 1 側とモータ 2 側のセンサの入力論理を一括して; RC-231HA = 0E.
    direct = Direct()
    direct.cmd("EAH")
    assert direct.cmd("EA") == b">$10E\r"
    direct.cmd("F2")
    assert direct.cmd("EA") == b">$10E\r"
    direct.cmd("EAL")
    assert direct.cmd("EA") == b">$100\r"
    direct.cmd("F1")
    assert direct.cmd("EA") == b">$100\r"


# ============================================================== S-curve rules (§7-1, §10 OC/OH/OL)

# §10 OC/OH/OL 重要な注意事項: with X = (OH - OL) / (2 × (200 - OC)) × OC,
#   X <= 4,095,  X <= 16,383 - OH,  X <= 16,383 - OL;  else command error, value not set.
SCURVE = [
    # (commands before, the command, accepted?) -- X worked out in the comment.
    (["OC100"], "OH8690", True),  # X = 8190 / 200 × 100 = 4095
    (["OC100"], "OH8691", False),  # X = 4095.5 > 4,095
    (["OC100"], "OHI3690", True),  # the same through form III: 5000 + 3690 = 8690
    (["OC100"], "OHI3691", False),
    (["OC100", "OH8690"], "OL499", False),  # X = 8191 / 2 = 4095.5
    (["OC100", "OH8690"], "OLD1", False),  # the same through form IV
    (["OC100", "OH8690"], "OL501", True),
    (["OH9000"], "OC100", False),  # X = 8500 / 200 × 100 = 4250
    (["OH9000"], "OC94", True),  # X = 8500 / 212 × 94 = 3768.9
    (["OC1"], "OH16343", True),  # X = 15843 / 398 = 39.81 <= 16,383 - 16,343 = 40
    (["OC1"], "OH16344", False),  # X = 39.81 > 39
    (["OC1"], "OH16383", False),  # X = 39.91 > 0
    ([], "OH16383", True),  # OC = 0: X = 0
    (["OH16383", "OL16000"], "OC100", False),  # X = 191.5 > 16,383 - 16,383 = 0
    (["OH16383", "OL16383"], "OC100", True),  # X = 0
]


@pytest.mark.parametrize(("before", "text", "accepted"), SCURVE, ids=lambda v: str(v))
def test_speed_settings_keep_the_s_curve_inequalities(
    before: list[str], text: str, accepted: bool
) -> None:
    direct = Direct()
    for setup in before:
        assert direct.cmd(setup) == ACK
    assert direct.cmd("") == IDLE, "the set-up itself was refused"
    mnemonic = text[:2]
    old = direct.cmd(mnemonic)
    assert direct.cmd(text) == ACK
    assert direct.cmd("") == (IDLE if accepted else COMMAND_ERROR)
    if not accepted:
        assert direct.cmd(mnemonic) == old  # "設定が出来ません"


def test_s_curve_rule_with_oh_below_ol_uses_the_magnitude() -> None:
    # docs/manual-notes.md "Sign of OH − OL in the S-curve rule": |OH − OL|, so the third
    # inequality can bite: OH 1, OL 16,383, OC 1 gives X = 16382 / 398 = 41.2 > 0.
    direct = Direct()
    direct.cmd("OH1")
    direct.cmd("OL16383")
    assert direct.cmd("") == IDLE
    direct.cmd("OC1")
    assert direct.cmd("") == COMMAND_ERROR
    assert direct.cmd("OC") == b">$1000\r"


def test_s_curve_rule_applies_per_motor() -> None:
    # OC, OH, OL are per motor (§10 F): motor 2's OC 100 does not constrain motor 1's OH.
    direct = Direct()
    direct.cmd("F2")
    direct.cmd("OC100")
    direct.cmd("F1")
    direct.cmd("OH16383")
    assert direct.cmd("") == IDLE
    direct.cmd("F2")
    direct.cmd("OH16383")
    assert direct.cmd("") == COMMAND_ERROR


# ============================================================== OS, OH, OL, OX ranges

RANGE_STEPS = [
    # §10 OS 注意点: form III beyond the range / form IV at 0 or below: command error, unchanged.
    ("OS32766", "OSI1", True, b">$132767\r"),
    ("OS32767", "OSI1", False, b">$132767\r"),
    ("OS1", "OSI32765", True, b">$132766\r"),
    ("OS3", "OSI32765", False, b">$100003\r"),
    ("OS2", "OSD1", True, b">$100001\r"),
    ("OS1", "OSD1", False, b">$100001\r"),
    ("OS300", "OSD300", False, b">$100300\r"),
    ("OS300", "OSI32766", False, b">$100300\r"),  # id: 1-32,765
    ("OS300", "OSI0", False, b">$100300\r"),
    ("OS300", "OSD0", False, b">$100300\r"),
    # §10 OH/OL: 1-16,383; id and dd 1-16,382. The manual states the out-of-range result for
    # OS only; OH and OL take the same rule (their range is the same kind of limit).
    ("OH16382", "OHI1", True, b">$116383\r"),
    ("OH16383", "OHI1", False, b">$116383\r"),
    ("OH2", "OHD1", True, b">$100001\r"),
    ("OH1", "OHD1", False, b">$100001\r"),
    ("OH300", "OHI16383", False, b">$100300\r"),
    ("OL16383", "OLI1", False, b">$116383\r"),
    ("OL1", "OLD1", False, b">$100001\r"),
    ("OL1", "OLI16382", True, b">$116383\r"),
]


@pytest.mark.parametrize(("setup", "text", "accepted", "after"), RANGE_STEPS, ids=lambda v: str(v))
def test_increments_and_decrements_stay_in_range(
    setup: str, text: str, accepted: bool, after: bytes
) -> None:
    direct = Direct()
    assert direct.cmd(setup) == ACK
    assert direct.cmd("") == IDLE
    assert direct.cmd(text) == ACK
    assert direct.cmd("") == (IDLE if accepted else COMMAND_ERROR)
    assert direct.cmd(setup[:2]) == after


@pytest.mark.parametrize(
    ("text", "reply"),
    [
        ("OX2", b">$100002\r"),
        ("OX16383", b">$116383\r"),
        ("OX30", b">$100030\r"),  # §10 OX (II): the data set by form I, not the internal 28
    ],
)
def test_ox_accepts_its_whole_range_and_reads_back_the_value_set(text: str, reply: bytes) -> None:
    direct = Direct()
    assert direct.cmd(text) == ACK
    assert direct.cmd("OX") == reply
    assert direct.cmd("") == IDLE


# ============================================================== EP and the 24-bit counter

# §10 EP 解説 table: the same counter read in EP0 and EP1 (24-bit two's complement; the OCR of
# the signed column is garbled in rows 1-3, docs/manual-notes.md "Position replies").
EP_TABLE = [
    ("0", b"00000000", b"+0000000"),
    ("8388607", b"08388607", b"+8388607"),
    ("8388608", b"08388608", b"-8388608"),
    ("16777215", b"16777215", b"-0000001"),
]


@pytest.mark.parametrize(("preset", "unsigned", "signed"), EP_TABLE)
def test_the_position_reads_in_both_views_of_the_24_bit_counter(
    preset: str, unsigned: bytes, signed: bytes
) -> None:
    direct = Direct()
    assert direct.cmd(f"R{preset}") == ACK
    assert direct.cmd("6") == b">$1" + unsigned + b"\r"
    assert direct.cmd("EP1") == ACK
    assert direct.cmd("6") == b">$1" + signed + b"\r"
    assert direct.cmd("EP0") == ACK
    assert direct.cmd("6") == b">$1" + unsigned + b"\r"


@pytest.mark.parametrize(("preset", "unsigned", "signed"), EP_TABLE)
def test_stored_positions_read_in_both_views(preset: str, unsigned: bytes, signed: bytes) -> None:
    # §10 2 (III), §10 A (III): the same two formats as command 6.
    direct = Direct()
    direct.cmd(f"2{preset}")
    direct.cmd(f"A042{preset}")
    direct.cmd("EP1")
    assert direct.cmd("2D") == b">$1" + signed + b"\r"
    assert direct.cmd("A042D") == b">$1" + signed + b"\r"
    direct.cmd("EP0")
    assert direct.cmd("2D") == b">$1" + unsigned + b"\r"
    assert direct.cmd("A042D") == b">$1" + unsigned + b"\r"


@pytest.mark.parametrize(
    ("signed_text", "unsigned"),
    [("-1", b"16777215"), ("-8388608", b"08388608"), ("+8388607", b"08388607")],
)
def test_a_signed_preset_reads_unsigned_in_ep0(signed_text: str, unsigned: bytes) -> None:
    direct = Direct()
    direct.cmd("EP1")
    assert direct.cmd(f"R{signed_text}") == ACK
    assert direct.cmd("") == IDLE
    direct.cmd("EP0")
    assert direct.cmd("6") == b">$1" + unsigned + b"\r"


@pytest.mark.parametrize(
    ("ep", "text"),
    [("EP0", "R16777216"), ("EP0", "R-1"), ("EP1", "R+8388608"), ("EP1", "R-8388609"),
     ("EP0", "216777216"), ("EP1", "2-8388609"), ("EP1", "A000+8388608")],
)  # fmt: skip
def test_a_position_outside_the_managed_range_is_a_command_error(ep: str, text: str) -> None:
    # §10 2, A, R: 0-16,777,215 (EP0) or -8,388,608-+8,388,607 (EP1).
    direct = Direct()
    direct.cmd(ep)
    assert direct.cmd(text) == ACK
    assert direct.cmd("") == COMMAND_ERROR


@pytest.mark.parametrize("text", ["R8388608", "R16777215", "28388608", "A0008388608"])
def test_mode_1_refuses_unsigned_positions_beyond_the_signed_range(text: str) -> None:
    # §7-4 table: mode 1 sets -8,388,608-+8,388,607 only, whatever EP says (§10 2, R 注).
    direct = Direct()
    direct.cmd("E1")
    assert direct.cmd(text) == ACK
    assert direct.cmd("") == COMMAND_ERROR


def test_mode_1_accepts_negative_positions_with_ep0() -> None:
    direct = Direct()
    direct.cmd("E1")
    assert direct.cmd("R-1") == ACK
    assert direct.cmd("") == IDLE
    assert direct.cmd("6") == b">$1-0000001\r"


def test_moving_below_zero_in_unsigned_management_wraps_like_the_manual_says() -> None:
    # §7-4: in unsigned management, moving to -2000 leaves the position at 16,775,216.
    direct = Direct()
    direct.cmd("R0")
    direct.cmd("22000")
    assert direct.cmd("5") == ACK  # §10 5: CCW by the position data
    wait_idle(direct)
    assert direct.cmd("") == IDLE
    assert direct.cmd("6") == b">$116775216\r"
    direct.cmd("EP1")
    assert direct.cmd("6") == b">$1-0002000\r"


def test_a_counter_wraps_at_24_bits_going_up() -> None:
    # §10 EP table row 4 and §7-4: 16,777,215 + 1 is 0 on the 24-bit counter.
    direct = Direct()
    direct.cmd("R16777215")
    direct.cmd("21")
    assert direct.cmd("4") == ACK  # one pulse CW
    wait_idle(direct, 5.0)
    assert direct.cmd("6") == b">$100000000\r"
