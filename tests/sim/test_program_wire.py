"""User programs over the simulated line: upload, run, output and autostart as the host sees them.

The ``wire`` fixture runs the loop 100 times faster than real time; the bytes are the ones a
host reads from the port (§10 I, G, GA; §11-3; §12 /CO, /CC; §10 ER).
"""

from __future__ import annotations

from tests.support.sim_wire import Wire

ACK = b">"


async def test_upload_in_pieces_run_and_read_the_output(wire: Wire) -> None:
    # §10 I: the body may come in pieces; only the first CR ends it (§13-2 example 3 style).
    assert await wire.exchange(b"$1I\r") == ACK
    wire.send(b"/CS1,10/CO123ABC*+-%")
    assert await wire.exchange(b"/6/CC1/END\r") == ACK
    assert await wire.exchange(b"$1IR\r") == b">$1/CS1,10/CO123ABC*+-%/6/CC1/END\r"
    assert await wire.exchange(b"$1G\r") == ACK
    # §12 /CO: ">123ABC*+-%" CR; §11-3: the query 6 without '>'; §12 /CC: ">$1" 1 00010 CR.
    assert await wire.message() == b">123ABC*+-%\r"
    assert await wire.message() == b"$100000000\r"
    assert await wire.message() == b">$1100010\r"
    assert await wire.exchange(b"$1GSS\r") == b">$10\r"
    assert await wire.exchange(b"$1GN\r") == b">$100005\r"


async def test_example_1_waits_for_the_input_the_control_surface_drives(wire: Wire) -> None:
    # §11-4 example 1: home, output bit 0 ON, wait for input bit 0, outputs OFF, go to 5,000.
    assert await wire.exchange(b"$1I\r") == ACK
    assert await wire.exchange(b"/D00/0//D01B/JON0+1/J-2/D00/25000/3//END\r") == ACK
    assert await wire.exchange(b"$1G\r") == ACK
    await wire.wait_idle(timeout=30.0)  # homed (about 60 simulated seconds)
    while await wire.exchange(b"$1CO\r") != b">$101\r":  # ④ comes right after the search
        pass
    assert await wire.exchange(b"$16\r") == b">$100000000\r"
    assert await wire.exchange(b"$1GSS\r") == b">$11\r"
    wire.controls.input("1", 0, True)
    while await wire.exchange(b"$1GSS\r") != b">$10\r":
        pass
    assert await wire.exchange(b"$16\r") == b">$100005000\r"
    assert await wire.exchange(b"$1CO\r") == b">$100\r"


async def test_a_command_error_in_the_program_sends_at_sign_with_er1(wire: Wire) -> None:
    # §10 ER 注意点: with ER1 a command error inside the program sends '@' alone.
    assert await wire.exchange(b"$1ER1\r") == ACK
    assert await wire.exchange(b"$1I\r") == ACK
    # T1000: 100 s of simulated waiting (1 s of real time), long enough for the two host
    # commands below to reach it while it waits, however busy the machine running the test.
    assert await wire.exchange(b"/T1000/22000/3/3/END\r") == ACK
    assert await wire.exchange(b"$1G\r") == ACK
    # While the program waits, a host command it may not send is refused and it goes on.
    assert await wire.exchange(b"$1IW\r") == b">@"
    assert await wire.exchange(b"$1GSS\r") == b">$11\r"
    assert await wire.message() == b"@"  # /3 while the first /3 still turns
    assert await wire.exchange(b"$1GSS\r") == b">$1E\r"
    assert await wire.exchange(b"$1GN\r") == b">$100004\r"


async def test_autostart_runs_the_stored_program_after_a_power_cycle(wire: Wire) -> None:
    # §10 GA: with GAS and the program written by IW, every power-on runs it.
    assert await wire.exchange(b"$1I\r") == ACK
    assert await wire.exchange(b"/22000/3//CO1/END\r") == ACK
    assert await wire.exchange(b"$1IW\r") == ACK
    assert await wire.message() == b"$1*\r"
    assert await wire.exchange(b"$1GAS\r") == ACK
    wire.controls.power_cycle("1")
    assert await wire.message() == b">1\r"
    assert await wire.exchange(b"$16\r") == b">$100002000\r"
    assert await wire.exchange(b"$1GSS\r") == b">$10\r"
