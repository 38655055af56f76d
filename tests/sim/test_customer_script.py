"""A customer's own blocking pyserial program against ``rc233-gateway sim --pty``.

The program is written the way the manual's samples are (§8-1 RS.BAS, §13-2 233E0.BAS): it
sends one DATA line at a time, waits for each reply ('>' for a command, '>$1D' CR for ``""``),
and polls ``""`` until the motor stops before it sends the next line. It runs the chapter-8
communication check, the speed set-up and homing of both motors of the mode-0 sample, and its
loop of ``B`` moves, and prints the position (``6``) after every line that moves a motor. The
test checks those positions against what the DATA lines imply: the ``A`` table of the sample
(101 = 5000, 201 = 8000, 202 = 12000) and 0 after homing and after ``1``.

The sample's step-out detection lines (QS11, Q1024, 0Q) and its ``OL5`` after ``0Q`` are left
out here: the whole sample, with them, runs in test_sample_233e0.py.
"""

from __future__ import annotations

import json
from pathlib import Path

from tests.support.sim_process import run_script, sim_on_pty

PROGRAM = r'''
"""RC-233 mode 0, two motors (after 233E0.BAS of the RC-233 manual, §13-2)."""
import json
import sys

import serial

port = serial.Serial(sys.argv[1], 9600, timeout=10)  # §8-1: 9600 bps, 8 bits, no parity, 1 stop
LOOPS = int(sys.argv[2])


def put(text):
    port.write(("$1" + text + "\r").encode("ascii"))  # '$' B# command CR, nothing else (§13-1)


def query(text):
    put(text)
    reply = port.read_until(b"\r")
    if not reply.endswith(b"\r"):
        sys.exit("no reply to %r: %r" % (text, reply))
    return reply.decode("ascii")


def command(text):
    put(text)
    reply = port.read(1)  # RCV = 1
    if reply != b">":
        sys.exit("reply to %r: %r" % (text, reply))


def check():
    """Poll "" until the motor stops; stop the program on an error (CHECK of 233E0.BAS)."""
    while True:
        reply = query("")
        if reply[0] != ">":
            sys.exit("<communication error>")
        flags = int(reply[3], 16)
        if flags & 0xE:
            sys.exit("<error> %r" % reply)
        if not flags & 1:
            return


# chapter 8-1: communication check; on '?' send again until the reply is normal (§9-2 参考)
while True:
    put("")
    first = port.read(1)
    if first == b">":
        assert port.read_until(b"\r") == b"$10\r"
        break
    if first != b"?":
        sys.exit("no reply from body 1")

SETUP = ["E0", "EP0",
         "A1015000", "A2018000", "A20212000",
         "OC50", "OX300",
         "F1", "OL500", "OH4000", "OS930",
         "F2", "OL500", "OH4000", "OS930",
         "F1", "0S50", "0",
         "F2", "0S50", "0"]
REPEAT = ["F2", "B201",
          "F1", "B101", "1",
          "F2", "B202",
          "F1", "B101", "1",
          "F2", "1"]

for data in SETUP + REPEAT * LOOPS:
    command(data)
    check()
    if data in ("0", "1") or data.startswith("B"):  # homing, origin return, table move
        motor = query("F")[3]
        print(json.dumps([motor, data, query("6")[3:-1]]), flush=True)
print(json.dumps(["end", query("61")[3:-1], query("62")[3:-1]]), flush=True)
port.close()
'''


async def test_customer_program_homes_and_loops_over_a_pty(tmp_path: Path) -> None:
    script = tmp_path / "customer.py"
    script.write_text(PROGRAM, encoding="utf-8")
    async with sim_on_pty(tmp_path, "--time-scale", "50") as device:
        out = await run_script(script, device, "2")

    lines = [json.loads(x) for x in out.decode().splitlines()]
    homing = [["1", "0", "00000000"], ["2", "0", "00000000"]]
    loop = [
        ["2", "B201", "00008000"],
        ["1", "B101", "00005000"],
        ["1", "1", "00000000"],
        ["2", "B202", "00012000"],
        ["1", "B101", "00005000"],
        ["1", "1", "00000000"],
        ["2", "1", "00000000"],
    ]
    assert lines == [*homing, *loop, *loop, ["end", "00000000", "00000000"]]
