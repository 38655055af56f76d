"""The manual's example programs run to where their text says (§11-3, §11-4, §12, §13-2, §10 GN).

The direct harness drives simulated time exactly. The default scene has the axis at 30,000
(mechanical) at power-on with ORG at 0-499; the counter reads 0 at power-on, and an origin
search ends at position 0.
"""

from __future__ import annotations

from tests.sim.direct import Direct
from tests.support.program_rig import ACK, CH10_GN, gn, position, run_until, start

# The manual's texts, verbatim (the project never reads the manual at test time).
CH11_3 = "/0//JON1+1/END/3//END"  # §11-3 note on /END
CH11_4_EX1 = "/D00/0//D01B/JON0+1/J-2/D00/25000/3//END"
CH11_4_EX2 = "/G1/25000/3//END/G2/26000/3//END/G3/27000/3//END"
CH11_4_EX3 = "//EC//22000//3//?//T10//4//?//END"
CH11_4_EX3_WITHOUT = "//22000//3//T10//4//END"  # §11-4: the same without /?
CH12_SC = "/SCG11/END/G1/D00/SR/END"
CH13_2_PIECES = (
    "/E0/OC30/OH8000/OL1000/OS300/OX60/A00130000/CS1,10",
    "/0//B001//1//CD1/JC1+1/J-7/END",
)


def test_ch11_4_example_1_homes_signals_waits_for_input_0_then_moves_to_5000() -> None:
    direct = start(CH11_4_EX1)
    direct.run(100.0)  # the search from 30,000 to ORG is long at the factory Low speed
    # ①-④: homed, output bit 0 ON; ⑤⑥: waiting for input bit 0 (GN 5 or 6: the /J loop).
    assert position(direct) == 0
    assert direct.cmd("CO") == b">$101\r"
    assert direct.cmd("GSS") == b">$11\r"
    assert gn(direct) in (5, 6)
    direct.run(200.0)
    assert position(direct) == 0  # still waiting: nothing moves without the input
    direct.set_input(0, True)
    direct.run(300.0)
    # ⑦-⑪: outputs off, absolute move to 5,000, wait, /END (GN names the /END: step 11).
    assert direct.cmd("CO") == b">$100\r"
    assert position(direct) == 5000
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 11


def test_ch11_4_example_2_three_programs_by_label() -> None:
    direct = Direct()
    assert direct.upload(CH11_4_EX2) == ACK + ACK
    for command, target, end_step in (("G2", 6000, 10), ("G", 5000, 5), ("G3", 7000, 15)):
        assert direct.cmd(command) == ACK
        direct.run(direct.now + 100.0)
        assert position(direct) == target, command
        assert direct.cmd("GSS") == b">$10\r"
        assert gn(direct) == end_step, command


def test_ch11_4_example_3_moves_to_2000_waits_then_2000_cw() -> None:
    direct = start(CH11_4_EX3)
    direct.run(100.0)
    assert position(direct) == 4000
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 16


def _ems_during_the_move_to_2000(direct: Direct) -> int:
    """Press EMS for 0.5 s while ``//3`` runs (§11-4); the position where it stopped."""
    ctl = direct["1"]
    # The counter reads 0 at power-on: //3 is a move of 2,000 pulses CW.
    run_until(direct, lambda: ctl.moving_motor(direct.now) is not None, 60, step=0.001)
    direct.run(direct.now + 0.2)
    ctl.set_ems(direct.now, True)
    ctl.nudge(direct.now)
    stopped = position(direct)
    assert 0 < stopped < 2000
    direct.run(direct.now + 0.5)
    ctl.set_ems(direct.now, False)
    ctl.nudge(direct.now)
    return stopped


def test_ch11_4_example_3_with_ems_ends_at_the_question_mark() -> None:
    direct = start(CH11_4_EX3)
    stopped = _ems_during_the_move_to_2000(direct)
    direct.run(direct.now + 30.0)
    # §11-4: "ユーザープログラムは、/? の位置で停止します": nothing moved after the stop.
    assert position(direct) == stopped
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 8  # the /? after //3


def test_ch11_4_example_3_without_question_mark_moves_on_after_the_ems() -> None:
    direct = start(CH11_4_EX3_WITHOUT)
    stopped = _ems_during_the_move_to_2000(direct)
    direct.run(direct.now + 30.0)
    # §11-4: /3 is cut short, /T10 waits 1 s (EMS is off again by then), /4 moves 2,000 CW.
    assert position(direct) == stopped + 2000
    assert direct.cmd("GSS") == b">$10\r"


def test_ch11_3_end_in_the_middle_ends_the_program() -> None:
    # §11-3: "/0//JON1+1/END/3//END": with input 1 OFF the first /END ends it after homing.
    direct = start(CH11_3)
    direct.run(100.0)
    assert position(direct) == 0
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 4  # the first /END


def test_ch12_subroutine_example_turns_every_output_off() -> None:
    direct = Direct()
    direct.cmd("DFF")
    assert direct.upload(CH12_SC) == ACK + ACK
    assert direct.cmd("G") == ACK
    direct.run(1.0)
    assert direct.cmd("CO") == b">$100\r"  # /G1/D00/SR ran
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 2  # back after /SC, then the /END right after it


def test_ch10_gn_example_counts_slashes_while_the_program_waits() -> None:
    # §10 GN: "/7/T100/S/END"; while /T100 counts, GN = 3 means /S runs next.
    direct = start(CH10_GN)
    direct.run(5.0)
    assert gn(direct) == 3
    assert direct.cmd("") == b">$11\r"  # /7 turns the motor
    direct.run(12.0)
    assert direct.cmd("") == b">$10\r"  # /S stopped it
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 4  # ended by /END: GN names the /END (§10 GN)


def test_ch13_2_example_3_uploads_in_two_pieces_and_loops_ten_times() -> None:
    direct = Direct()
    assert direct.cmd("GES") == ACK  # the example's first frame; nothing runs: no error
    assert direct.cmd("") == b">$10\r"
    assert direct.cmd("I") == ACK
    assert direct.send(CH13_2_PIECES[0].encode()) == b""  # no CR yet: no answer
    assert direct.send(CH13_2_PIECES[1].encode() + b"\r") == ACK
    assert direct.cmd("IR") == b">$1" + "".join(CH13_2_PIECES).encode() + b"\r"
    assert direct.cmd("IW") == ACK
    assert direct.run(2.0) == [b"$1*\r"]  # §13-2: IW answers ">$1*CR" (the write's end)
    assert direct.cmd("G") == ACK
    direct.run(600.0)
    # /E0 ... /CS1,10 set up, /0 homes; then B001 (30,000) and 1 (back to 0), ten times,
    # until /CD1 brings counter 1 to 0 and /JC1+1 lands on /END.
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 18
    assert direct.cmd("GR1") == b">$100000\r"
    assert position(direct) == 0
    assert direct.cmd("OH") == b">$108000\r"
    trips = [
        leg for leg in direct["1"].axes[1].legs if leg.end_position - leg.start_position == 30000
    ]
    assert len(trips) == 10
