"""The manual's whole mode-0 sample (§13-2, 233E0.BAS) as a blocking pyserial program on a pty.

233E0.BAS sends its DATA lines one at a time, waits for each reply (RCV = 1: one '>'), then
polls ``""`` (RCV = 5) until the motor stops and ends the program on any error bit (CHECK).
Its DATA lines, in order (the OCR prints some 0/O ambiguously; the text under the listing
names them: "0S50" is 0S (原点サーチ, "50 パルス進んだ位置を原点"); "OL5" is OL, there is no
0L command):

    E0, EP0, QS11                     step-out detection on both motors
    F1, Q1024 / F2, Q1024             the dog's period: 1,024 pulses
    A1015000, A2018000, A20212000     positions 101, 201, 202
    OC50, OX300
    F1, OL500, OH4000, OS930 / F2, the same
    F1, 0S50, 0, 0Q, OL5 / F2, the same      home, centre on the dog, Low speed 5
    REPEATDATA: F2 B201 / F1 B101 1 / F2 B202 / F1 B101 1 / F2 1

The machine it is written for has a step-out dog of 1,024 pulses on each axis (Q1024): the
scene says so (``dog_period``). The program prints the position (``6``) after each line that
moves a motor; the test checks them against what the DATA lines imply: 0 after homing and
after 0Q (§10 0Q: the centre becomes the origin) and after ``1``, the A entries after each B.
That the program reaches its end also says that no step-out was detected on the way: CHECK
stops it on a limit error (§10 9 ⑦: a step-out sets bit 1).
"""

from __future__ import annotations

import json
from pathlib import Path

from tests.support.sim_process import run_script, sim_on_pty

SCENE = "[default]\ndog_period = 1024\n"

PROGRAM = r'''
"""RC-233 MODE 0 & 2MOTOR CONTROL (233E0.BAS of the RC-233 manual, §13-2), in Python."""
import json
import sys

import serial

port = serial.Serial(sys.argv[1], 9600, timeout=10)  # OPEN "com1:9600, n, 8, 1"
LOOPS = int(sys.argv[2])


def put(text):
    port.write(("$1" + text + "\r").encode("ascii"))  # CMMD$ + CR$


def receive(count):
    """RECEIVE: wait until RCV characters have come."""
    reply = port.read(count)
    if len(reply) != count:
        sys.exit("no reply: %r" % reply)
    return reply.decode("ascii")


def check():
    """CHECK: poll "" until the motor stops; stop the program on an error bit."""
    while True:
        put("")
        reply = receive(5)
        if reply[0] != ">":
            sys.exit("<communication error>")
        flags = int(reply[3], 16)
        if flags & 0xE:
            sys.exit("<error> %r" % reply)
        if not flags & 1:
            return


def query(text):
    put(text)
    return port.read_until(b"\r").decode("ascii")


DATA = ["E0", "EP0", "QS11",
        "F1", "Q1024",
        "F2", "Q1024",
        "A1015000", "A2018000", "A20212000",
        "OC50", "OX300",
        "F1", "OL500", "OH4000", "OS930",
        "F2", "OL500", "OH4000", "OS930",
        "F1", "0S50", "0", "0Q", "OL5",
        "F2", "0S50", "0", "0Q", "OL5"]
REPEATDATA = ["F2", "B201",
              "F1", "B101", "1",
              "F2", "B202",
              "F1", "B101", "1",
              "F2", "1"]

for data in DATA + REPEATDATA * LOOPS:
    put(data)
    if receive(1) != ">":  # RCV = 1
        sys.exit("reply to %r" % data)
    check()
    if data in ("0", "0Q", "1") or data.startswith("B"):
        print(json.dumps([query("F")[3], data, query("6")[3:-1]]), flush=True)
print(json.dumps(["end", query("61")[3:-1], query("62")[3:-1], query("96")[3:-1]]), flush=True)
port.close()
'''


async def test_the_manuals_mode_0_sample_runs_to_its_end_over_a_pty(tmp_path: Path) -> None:
    script = tmp_path / "233e0.py"
    script.write_text(PROGRAM, encoding="utf-8")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE, encoding="utf-8")
    async with sim_on_pty(tmp_path, "--time-scale", "50", "--scene", str(scene)) as device:
        out = await run_script(script, device, "2")

    lines = [json.loads(x) for x in out.decode().splitlines()]
    homing = [
        ["1", "0", "00000000"],
        ["1", "0Q", "00000000"],
        ["2", "0", "00000000"],
        ["2", "0Q", "00000000"],
    ]
    loop = [
        ["2", "B201", "00008000"],
        ["1", "B101", "00005000"],
        ["1", "1", "00000000"],
        ["2", "B202", "00012000"],
        ["1", "B101", "00005000"],
        ["1", "1", "00000000"],
        ["2", "1", "00000000"],
    ]
    assert lines == [*homing, *loop, *loop, ["end", "00000000", "00000000", "0"]]
