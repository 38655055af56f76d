"""Motor selection that is never refused, and errors pinned on what caused them.

F is refused while a motor of the controller moves (§10 F, 動作中 ×) with the same bare '>' as
an accepted one, and the refusal raises a command error that the next ``""`` reports. A
per-motor command for the other motor therefore waits until the motion has ended; it is never
sent after a refused F, and the move is never blamed for the scheduler's own F.
"""

from __future__ import annotations

from gateway.bus.state_types import ErrorKind
from tests.support.sim_app import running_app


async def test_a_command_for_the_other_motor_waits_and_the_move_stays_done() -> None:
    async with running_app() as api:
        await api.identified()
        start = api.position("1", 1)
        mark = api.mark()
        move = await api.client.post(
            "/axes/sim.1.1/move", json={"position": 60000, "relative": True, "unit": "pulse"}
        )
        assert move.status_code == 202, move.text
        # Right behind the move: motor 1 turns (or is about to) when this reaches the line.
        other = await api.client.post(
            "/controllers/sim.1/commands", params={"motor": 2}, json={"command": "OH"}
        )
        op = await api.operations.wait(move.json()["id"], timeout=20)
        done = op.view().model_dump(mode="json")
        assert done["state"] == "done", done
        assert done["error"] is None
        assert api.position("1", 1) == start + 60000
        # The read for motor 2 went out once motor 1 had stopped, after one F2 the device took.
        assert other.status_code == 200, other.text
        assert other.json()["results"][0]["value"] == 5000  # the simulator's OH of motor 2
        heard = api.heard("1", mark)
        assert heard.count("F2") == 1, heard
        after_f2 = heard[heard.index("F2") + 1 :]
        assert after_f2[:2] == ["97", "OH"], heard
        # No command error was raised at all: nothing was sent that the device refused.
        assert ErrorKind.COMMAND not in api.cached("1").latched
