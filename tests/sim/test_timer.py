"""The internal timer: T, T*, GRT, GWT, P from the host, and /T, /TB, /JT, /TS in programs.

§10 T, GRT, GWT, P and §12 /T, /TB, /JT, /TS: one timer in 0.1 s units that all of them share.
Times are checked against the manual's numbers (TIME x 100 ms), a little before and after.
"""

from __future__ import annotations

from tests.sim.direct import Direct
from tests.support.program_rig import CH10_GN, gn, position, run_until, start

ACK = b">"
TIMER_UP = b"$1T\r"  # §10 T form I: "$B#T" CR at time-up


def test_t_sends_b_t_at_time_up_and_t_query_reads_1_then_0() -> None:
    direct = Direct()
    assert direct.cmd("T10") == ACK  # 1 s
    direct.advance(0.95)
    assert direct.due() == []
    assert direct.cmd("T") == b">$11\r"  # §10 T (III): 1 = counting
    direct.advance(0.06)
    assert direct.due() == [TIMER_UP]
    assert direct.cmd("T") == b">$10\r"  # 0 = timed up


def test_t_star_counts_without_a_message() -> None:
    # §10 T 使用例: "$1T*10" then "$1T" until ">$10" CR; "[\$1TCR] を送信しない".
    direct = Direct()
    assert direct.cmd("T*10") == ACK
    direct.advance(0.95)
    assert direct.cmd("T") == b">$11\r"
    direct.advance(0.1)
    assert direct.cmd("T") == b">$10\r"
    direct.advance(5.0)
    assert direct.due() == []


def test_grt_counts_down_in_tenths_and_reads_0_at_time_up() -> None:
    direct = Direct()
    direct.cmd("T100")
    direct.advance(2.55)
    assert direct.cmd("GRT") == b">$100075\r"  # §10 GRT: 0.1 s units, 5 digits
    direct.advance(8.0)
    assert direct.cmd("GRT") == b">$100000\r"


def test_gwt_rewrites_the_counting_time() -> None:
    # §10 GWT: the counting timer restarts from the new time; $B#T follows that time.
    direct = Direct()
    direct.cmd("T100")
    direct.advance(2.0)
    assert direct.cmd("GWT50") == ACK
    assert direct.cmd("GRT") == b">$100050\r"
    direct.advance(4.95)
    assert direct.due() == []
    direct.advance(0.1)
    assert direct.due() == [TIMER_UP]
    direct.advance(10.0)
    assert direct.due() == []  # the first time-up (at 10 s) was called off


def test_gwt_with_the_timer_up_is_a_command_error() -> None:
    # §10 GWT 注意点: "タイム・アップした状態（タイマーを使用していない時）にこのコマンドを実行す
    # ると、コマンド・エラーになります。"
    direct = Direct()
    assert direct.cmd("GWT50") == ACK  # '>' only says it was received (§9-2)
    assert direct.cmd("") == b">$18\r"  # "" (status) bit 3: command error
    assert direct.cmd("GRT") == b">$100000\r"  # still not counting


def test_p_turns_a_bit_on_for_the_time_given() -> None:
    # §10 P 使用例: "$1P2300": output bit 2 ON for 30 s (300 x 0.1 s), then OFF.
    direct = Direct()
    assert direct.cmd("P2300") == ACK
    assert direct.cmd("CO") == b">$104\r"
    direct.advance(29.9)
    assert direct.cmd("CO2") == b">$11\r"
    direct.advance(0.2)
    assert direct.cmd("CO") == b">$100\r"
    assert direct.due() == []  # P uses the timer without $B#T


def test_p_in_a_program() -> None:
    direct = start("/P2300/END")
    direct.run(1.0)
    assert direct.cmd("CO") == b">$104\r"
    direct.run(29.9)
    assert direct.cmd("CO") == b">$104\r"
    direct.run(30.1)
    assert direct.cmd("CO") == b">$100\r"


def test_program_t_waits_for_time_up_without_a_message() -> None:
    # §12 /T: start the timer and wait for time-up; the host's $B#T is not sent.
    direct = start("/T10/CO1/END")
    assert direct.run(0.99) == []
    assert direct.cmd("GRT") != b">$100000\r"
    assert direct.run(1.1) == [b">1\r"]


def test_gwt_shortens_a_program_t_wait() -> None:
    direct = start("/T100/CO1/END")
    direct.run(1.0)
    assert direct.cmd("GWT10") == ACK  # §10 GWT: "/T" counting too
    assert direct.run(1.9) == []
    assert direct.run(2.1) == [b">1\r"]


def test_tb_and_jt_repeat_a_move_until_the_timer_is_up() -> None:
    # §12 /TB: "/TB100/G1//4//JTG11/END": 10 s timer; /4 again while it counts.
    direct = Direct()
    direct.cmd("2100")  # position data: each /4 moves 100 pulses CW
    direct.upload("/TB100/G1//4//JTG11/END")
    direct.cmd("G")
    direct.run(9.9)
    assert direct.cmd("GSS") == b">$11\r"
    done = run_until(direct, lambda: direct.cmd("GSS") == b">$10\r", 20.0)
    assert 10.0 <= done < 11.0  # ends with the first /JT after time-up
    moved = position(direct)
    assert moved > 100 and moved % 100 == 0


def test_ts_waits_after_every_null() -> None:
    # §12 /TS (reconstructed example, docs "The §12 /TS example"): 1 s after the search,
    # then 2,000 and 1 s after that move.
    direct = start("/TS10/0//22000/3//END")
    ctl = direct["1"]
    homed = run_until(direct, lambda: ctl.moving_motor(direct.now) is None and gn(direct) > 3, 200)
    assert position(direct) == 0
    direct.run(homed + 0.9)
    assert direct.cmd("") == b">$10\r"  # still in the stop wait
    started = run_until(direct, lambda: ctl.moving_motor(direct.now) is not None, homed + 2)
    # Both times are sampled every 10 ms: the stop wait is 1 s give or take one sample.
    assert homed + 0.99 <= started <= homed + 1.02
    arrived = run_until(direct, lambda: ctl.moving_motor(direct.now) is None, started + 30)
    assert position(direct) == 2000
    direct.run(arrived + 0.9)
    assert direct.cmd("GSS") == b">$11\r"
    direct.run(arrived + 1.1)
    assert direct.cmd("GSS") == b">$10\r"


def test_gn_example_timer_stops_a_jog_after_ten_seconds() -> None:
    # §10 GN "/7/T100/S/END": the jog runs 10 s before /S.
    direct = start(CH10_GN)
    direct.run(9.9)
    assert direct.cmd("") == b">$11\r"
    direct.run(10.1)
    assert direct.cmd("") == b">$10\r"
