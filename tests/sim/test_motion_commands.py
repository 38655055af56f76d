"""Motion commands of the simulated controller where docs/manual-notes.md records a choice.

Each test names the manual section and the note ("The simulated controller") it holds.
Positions are preset with R so that nothing depends on the counter at power-on; the default
scene leaves tens of thousands of pulses free on both sides of the start.
"""

from __future__ import annotations

from tests.sim.direct import Direct

ACK = b">"
STOPPED = b">$10\r"


def _run_to_rest(direct: Direct, seconds: float = 30.0) -> None:
    direct.advance(seconds)
    assert direct.cmd("") == STOPPED


def test_sequential_b_starts_at_entry_001_while_bn_reads_00000() -> None:
    # §10 B 注意点: with no B since power-on, form III uses entry 001; BN reads 00000 (§10 B V).
    direct = Direct()
    direct.cmd("R0")
    direct.cmd("A0011000")
    direct.cmd("A0022000")
    assert direct.cmd("BN") == b">$100000\r"
    assert direct.cmd("B") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$100001000\r"
    assert direct.cmd("BN") == b">$100002\r"
    assert direct.cmd("B") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$100002000\r"


def test_the_sequence_goes_on_at_000_after_999() -> None:
    direct = Direct()
    direct.cmd("R0")
    assert direct.cmd("B999") == ACK
    _run_to_rest(direct)
    assert direct.cmd("BN") == b">$100000\r"


def test_b_plus_minus_moves_by_the_absolute_value_of_the_entry() -> None:
    # §10 B+(-) 注意点: A001 = +5000 or -5000, B001+ moves 5,000 CW, B001- 5,000 CCW.
    direct = Direct()
    direct.cmd("EP1")
    direct.cmd("R+0")
    direct.cmd("A001-5000")
    assert direct.cmd("B001+") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$1+0005000\r"
    assert direct.cmd("B001-") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$1+0000000\r"


def test_4_and_5_move_by_the_position_data() -> None:
    direct = Direct()
    direct.cmd("R10000")
    direct.cmd("2300")
    assert direct.cmd("4") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$100010300\r"
    assert direct.cmd("5") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$100010000\r"


def test_s_stops_the_motor_that_moves_even_when_the_other_is_selected() -> None:
    # §10 S / F: docs/manual-notes.md "S and SS": a stop never misses the moving motor.
    direct = Direct()
    assert direct.cmd("72") == ACK  # jog motor 2; the suffix selects it (§10 F)
    direct["1"].selected = 1  # as if F1 had been accepted: F is refused while moving
    direct.advance(0.1)
    assert direct.cmd("S") == ACK
    direct.advance(0.001)
    assert direct.cmd("") == STOPPED


def test_a_motion_command_while_ems_is_on_does_not_move_and_latches_ems() -> None:
    # §11-4 "/?" example: while the EMS signal is ON, motion commands are not executed.
    direct = Direct()
    direct.cmd("R0")
    direct["1"].set_ems(direct.now, True)
    assert direct.cmd("") == b">$14\r"
    assert direct.cmd("21000") == ACK
    assert direct.cmd("3") == ACK
    direct.advance(0.1)
    assert direct.cmd("") == b">$14\r"  # EMS again, not a command error, not moving
    assert direct.cmd("6") == b">$100000000\r"
    direct["1"].set_ems(direct.now, False)
    assert direct.cmd("3") == ACK
    _run_to_rest(direct)
    assert direct.cmd("6") == b">$100001000\r"


def test_0q_with_the_step_out_sensor_off_is_a_command_error() -> None:
    # §10 0Q: the step-out sensor must be ON when 0Q starts.
    direct = Direct()
    ctl = direct["1"]
    ctl.force_sensor(direct.now, 1, "ez", False)
    assert direct.cmd("0Q") == ACK
    assert direct.cmd("") == b">$18\r"
    ctl.force_sensor(direct.now, 1, "ez", None)


def test_n_points_serve_one_move_only() -> None:
    # §10 N form II: NS arms the points for the next move; the move uses them up.
    direct = Direct()
    direct.cmd("R0")
    direct.cmd("N12000,500")
    assert direct.cmd("NS") == ACK
    assert direct.cmd("N") == b">$11\r"
    direct.cmd("21000")
    assert direct.cmd("3") == ACK
    _run_to_rest(direct)
    assert direct.cmd("N") == b">$10\r"
    assert direct.cmd("N1") == b">$102000,00000500\r"  # the point itself is kept (§10 N)


def test_h_and_l_without_a_jog_change_nothing() -> None:
    direct = Direct()
    assert direct.cmd("H") == ACK
    assert direct.cmd("L") == ACK
    assert direct.cmd("") == STOPPED


def test_g_without_a_program_is_a_command_error() -> None:
    # §10 G 注意点: G with no program in RAM, or G{lb} with a label the program lacks, is an
    # error. Programs that run: tests/sim/test_program_*.py.
    direct = Direct()
    assert direct.cmd("G") == ACK
    assert direct.cmd("") == b">$18\r"
    assert direct.cmd("GSS") == b">$10\r"
    direct.cmd("I")
    assert direct.send(b"/G1/END\r") == ACK
    assert direct.cmd("G2") == ACK
    assert direct.cmd("") == b">$18\r"
    assert direct.cmd("GSS") == b">$10\r"
