"""Host commands inside a program: the ``/cmd`` form of every command usable there (§11-3).

The command goes through the same rules and handlers as from the host, with two differences
the manual states: a general command answers nothing (no '>'), and a query sends its normal
reply without the '>' (§11-3: ``$B#data`` CR). A rule it breaks (a mode, a motion while a motor
turns) is a command error that ends the program (§10 G 注意点). The host-only restriction of
§11-3 5. (``AL``, ``DL`` ... refused while a program runs) is about the host: in the program
they run.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.framing import framing_switch
from gateway.protocol.params import PositionFormat
from gateway.protocol.replies import encode_reply
from gateway.sim.dispatch import HANDLERS, Refused
from gateway.sim.program.output import query_output

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = ["execute"]


def execute(ctl: ControllerView, cmd: Any, t: float) -> None:
    """Run the host command ``cmd`` as a program statement at ``t``."""
    ctl.program_rules(cmd, t)
    if cmd.form.switches_framing:
        # EE/EL/ER/SUM in a program: no reply of its own to frame, so only the switch.
        switch = framing_switch(ctl.framing, cmd.wire())
        if switch.refused:  # EE1 with SUM1 on, or SUM1 with EE1 on (§10 EE, SUM)
            raise Refused("EE1 and SUM1 cannot be on together")
        ctl.settings.shared.framing = switch.after
        return
    value = HANDLERS[cmd.key](ctl, cmd, t)
    if cmd.reply_format.has_data:
        data = encode_reply(
            cmd.reply_format,
            value,  # type: ignore[arg-type]
            signed_positions=ctl.position_format is PositionFormat.SIGNED,
        )
        ctl.emit(t, query_output(ctl, data))
