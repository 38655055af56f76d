"""Running programs from the host: G, GS/GC, GE, GES, GSS, GN, output, refusals, GA (§10, §11-3).

Direct harness: the test moves simulated time; ``Direct.run`` wakes the program as the loop
does and returns the messages it sent by then. Positions: the counter reads 0 at power-on.
"""

from __future__ import annotations

from tests.sim.direct import Direct
from tests.support.program_rig import gn, position, start

ACK = b">"
# Three moves of 1,000 pulses CW, each followed by a NULL wait (steps 1-3, 4-6, 7-9; END 10).
STAIRS = "/21000/3//22000/3//23000/3//END"


def test_query_in_a_program_sends_its_reply_without_the_ack() -> None:
    # §11-3: "(II) の問い合わせコマンド ... 通常の応答書式から [>] を除いたデータ".
    direct = start("/6/OH/F/END")
    assert direct.run(1.0) == [b"$100000000\r", b"$105000\r", b"$11\r"]


def test_general_commands_in_a_program_answer_nothing() -> None:
    # §11-3: a general command in a program returns no '>' to the PC.
    direct = start("/OH4000/D01B/EP1/END")
    assert direct.run(1.0) == []
    assert direct.cmd("OH") == b">$104000\r"
    assert direct.cmd("CO") == b">$101\r"


def test_co_cc_and_o3_send_their_lines() -> None:
    # §12 /CO: "/CO123ABC*+-%" sends ">123ABC*+-%" CR. §12 /CC: '>' '$' B# CT 5 digits CR.
    # §12 /O PT 3: the buffer as DU DL (our format: like /CC, docs "/O3 output").
    direct = Direct()
    direct.cmd("GWA5A")
    direct.upload("/CO123ABC*+-%/CS2,345/CC2/O3A/END")
    direct.cmd("G")
    assert direct.run(1.0) == [b">123ABC*+-%\r", b">$1200345\r", b">$15A\r"]


def test_program_output_carries_the_checksum_with_sum1() -> None:
    # §10 SUM: every CR-terminated message carries the checksum (">1" -> 3E+31 = 6F).
    direct = start("/SUM1/CO1/END")
    assert direct.run(1.0) == [b">16F\r"]


def test_gs_pauses_after_the_motion_under_way_and_gc_resumes() -> None:
    direct = start(STAIRS)
    direct.run(0.02)
    assert direct.cmd("") == b">$11\r"  # the first move runs
    assert direct.cmd("GS") == ACK
    assert direct.cmd("GSS") == b">$1P\r"
    direct.run(30.0)
    # §10 GS: executed "up to the boundary of the operation": the move ends, nothing follows.
    assert position(direct) == 1000
    assert gn(direct) == 4
    assert direct.cmd("GSS") == b">$1P\r"
    assert direct.cmd("GC") == ACK
    assert direct.cmd("GSS") == b">$11\r"
    direct.run(60.0)
    assert position(direct) == 3000
    assert direct.cmd("GSS") == b">$10\r"


def test_ge_ends_the_program_and_the_motion_goes_on() -> None:
    direct = start(STAIRS)
    direct.run(0.05)
    assert direct.cmd("GE") == ACK
    assert direct.cmd("GSS") == b">$10\r"
    assert direct.cmd("") == b">$11\r"  # §10 GE: the motor keeps moving to its target
    direct.run(30.0)
    assert position(direct) == 1000  # and the program started nothing more
    assert gn(direct) == 4  # §10 GN: the statement it would have run next


def test_ges_ends_the_program_and_stops_the_motor_at_once() -> None:
    direct = start(STAIRS)
    direct.run(0.1)
    assert direct.cmd("GES") == ACK
    assert direct.cmd("") == b">$10\r"  # §10 GES: the motor stops at once
    stopped = position(direct)
    assert 0 < stopped < 1000
    direct.run(30.0)
    assert position(direct) == stopped
    assert direct.cmd("GSS") == b">$10\r"
    assert direct.cmd("GC") == ACK  # §10 GS 注意点: an ended program cannot be resumed
    direct.run(60.0)
    assert position(direct) == stopped


def test_a_command_error_in_the_program_ends_it_with_e_read_once() -> None:
    # Step 3 is a motion command while the motor turns: a command error (§10 G 注意点).
    direct = start("/21000/3/3//END")
    direct.run(30.0)
    assert position(direct) == 1000  # the first move is not disturbed
    assert direct.cmd("GSS") == b">$1E\r"  # §11-3 <GSS>: E, then 0
    assert direct.cmd("GSS") == b">$10\r"
    assert gn(direct) == 3  # §11-3: GN shows which command failed
    assert direct.cmd("") == b">$18\r"  # the command-error bit
    assert direct.due() == []  # ER0: no '@'


def test_a_command_error_in_the_program_sends_at_sign_with_er1() -> None:
    # §10 ER 注意点: "@" alone to the host, and the program ends.
    direct = Direct()
    direct.cmd("ER1")
    direct.upload("/CO1/OH99999/CO2/END")
    direct.cmd("G")
    assert direct.run(1.0) == [b">1\r", b"@"]
    assert direct.cmd("GSS") == b">$1E\r"


def test_gn_is_0_before_any_program_ran() -> None:
    assert Direct().cmd("GN") == b">$100000\r"


def test_host_commands_refused_while_a_program_runs_and_the_program_goes_on() -> None:
    # §11-3 5.: G, I, IL, IW, AW, DW, AL, DL cannot be used while a program runs; a host
    # command error does not end the program (§10 G 注意点).
    direct = start("/T50/21000/3//END")
    for text in ("G", "I", "IL", "IW", "AW", "DW", "AL", "DL", "OH99999"):
        assert direct.cmd(text) == ACK, text
        assert direct.cmd("") == b">$18\r", text
        assert direct.cmd("GSS") == b">$11\r", text
    assert direct.send(b"/G9/END\r") == b""  # I was refused: this is no program text
    assert direct.run(1.0) == []  # neither IW nor AW/DW wrote anything: no $1*
    direct.run(30.0)
    assert position(direct) == 1000
    assert direct.cmd("GSS") == b">$10\r"
    assert direct.cmd("IR") == b">$1/T50/21000/3//END\r"


def test_gw_and_gr_share_the_buffers_and_counters_with_the_program() -> None:
    direct = Direct()
    direct.cmd("GWB0F")
    direct.cmd("GW1100")
    direct.upload("/ORBF0/RLB/CU1/LDCRB/END")
    direct.cmd("G")
    direct.run(1.0)
    assert direct.cmd("GRB") == b">$1FF\r"  # 0F | F0 = FF, rotated left: FF
    assert direct.cmd("GRC") == b">$1FF\r"
    assert direct.cmd("GR1") == b">$100101\r"


def test_autostart_runs_the_stored_program_at_power_on() -> None:
    # §10 GA, §11-3 4.: with GAS and the program in EEPROM (IW), power-on runs it.
    direct = Direct()
    direct.upload("/22000/3//CO1/END")
    direct.cmd("IW")
    direct.cmd("GAS")
    direct.run(5.0)
    direct.power_cycle()
    assert direct.cmd("GSS") == b">$11\r"
    assert direct.run(30.0) == [b">1\r"]
    assert position(direct) == 2000


def test_without_autostart_power_on_runs_nothing() -> None:
    direct = Direct()
    direct.upload("/22000/3//CO1/END")
    direct.cmd("IW")
    direct.run(5.0)
    direct.power_cycle()
    assert direct.cmd("GSS") == b">$10\r"
    assert direct.run(30.0) == []
    assert position(direct) == 0
