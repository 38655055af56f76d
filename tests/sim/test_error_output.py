"""The K error output: output bits ON at the chosen errors, KC turns them OFF (§10 K).

§10 K: DT 1 limit, 2 EMS, 4 step-out (sums for several); the bits go ON when the watched flag
goes 0 -> 1 (a limit only while the step-out bit is 0); KC turns the chosen bits OFF and
clears the limit and EMS status bits; K0 stops the function but leaves the bits ON; KC with
the function off is a command error. The port is read with CO (§10 CO).
"""

from __future__ import annotations

from tests.sim.direct import Direct

ACK = b">"
IDLE = b">$10\r"
LIMIT = b">$12\r"


def limit_error(direct: Direct, at: float) -> None:
    """Jog motor 1 into its CW limit (forced ON at ``at``)."""
    assert direct.cmd("7", at=at) == ACK
    direct["1"].force_sensor(at + 0.1, 1, "cw_limit", True)
    direct.now = at + 0.2
    direct["1"].force_sensor(direct.now, 1, "cw_limit", None)


def test_a_limit_error_turns_the_chosen_bits_on_and_kc_off() -> None:
    direct = Direct()
    assert direct.cmd("K1,81") == ACK  # form I: limit error -> bits 7 and 0
    assert direct.cmd("CO") == b">$100\r"
    limit_error(direct, 1.0)
    assert direct.cmd("CO") == b">$181\r"
    assert direct.cmd("KC") == ACK
    assert direct.cmd("CO") == b">$100\r"
    assert direct.cmd("") == IDLE  # KC cleared the limit bit too (§10 K form IV)


def test_the_manuals_example_k5_3() -> None:
    # §10 K 使用例: "$1K5, 3": a limit error or a step-out turns bit 3 ON.
    direct = Direct()
    assert direct.cmd("K5,3") == ACK
    limit_error(direct, 1.0)
    assert direct.cmd("CO") == b">$108\r"


def test_the_manuals_example_k2_ff_on_emergency_stop() -> None:
    # §10 K 使用例: "$1K2, FF": the EMS input ON turns every output bit ON.
    direct = Direct()
    assert direct.cmd("K2,FF") == ACK
    limit_error(direct, 1.0)
    assert direct.cmd("CO") == b">$100\r"  # a limit error is not watched
    direct["1"].set_ems(2.0, True)
    assert direct.cmd("CO", at=2.0) == b">$1FF\r"


def test_bits_already_on_stay_and_only_the_chosen_ones_go_off() -> None:
    direct = Direct()
    assert direct.cmd("D10") == ACK  # bit 4 ON by D
    assert direct.cmd("K1,0") == ACK  # form II: bit 0
    limit_error(direct, 1.0)
    assert direct.cmd("CO") == b">$111\r"
    assert direct.cmd("KC") == ACK
    assert direct.cmd("CO") == b">$110\r"


def test_k0_stops_the_function_and_leaves_the_bits() -> None:
    direct = Direct()
    direct.cmd("K1,1")
    limit_error(direct, 1.0)
    assert direct.cmd("K0") == ACK
    assert direct.cmd("CO") == b">$102\r"
    assert direct.cmd("KC") == ACK  # §10 K: KC with the function off is a command error
    assert direct.cmd("") == b">$1A\r"  # and K0 left the limit bit: limit + command error
    limit_error(direct, 2.0)
    assert direct.cmd("CO") == b">$102\r"  # nothing more turned ON, nothing OFF


def test_a_step_out_is_not_a_limit_error_for_k() -> None:
    # §10 K 解説: the limit bit counts only while the step-out bit is 0; a step-out sets both.
    for dt, port in ((1, b">$100\r"), (4, b">$101\r"), (5, b">$101\r")):
        direct = Direct()
        for text in ("0Q",):
            direct.cmd(text)
        assert direct.cmd("", at=10.0) == IDLE
        for text in (f"K{dt},0", "QS01", "22000", "3"):
            assert direct.cmd(text) == ACK
        direct["1"].slip(10.3, 1, -150)  # the dog sees it (test_stepout.py)
        assert direct.cmd("", at=11.0) == LIMIT
        assert direct.cmd("CO") == port, dt
        # With bit 6 set, a motion command's limit error does not count either (§10 9 ⑦).
        direct.cmd("KC")
        direct.cmd("3")
        assert direct.cmd("CO") == b">$100\r", dt


def test_the_function_fires_again_once_the_flag_was_cleared() -> None:
    # §10 K 解説: to fire again, KC (or a "" read) must have cleared the flag first.
    direct = Direct()
    direct.cmd("K1,0")
    limit_error(direct, 1.0)
    assert direct.cmd("KC") == ACK
    limit_error(direct, 2.0)
    assert direct.cmd("CO") == b">$101\r"
    assert direct.cmd("D00") == ACK
    limit_error(direct, 3.0)  # the limit bit from 2.0 is still set: no 0 -> 1 change
    assert direct.cmd("CO") == b">$100\r"
    assert direct.cmd("") == LIMIT
    limit_error(direct, 4.0)
    assert direct.cmd("CO") == b">$101\r"
