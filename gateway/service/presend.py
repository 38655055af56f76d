"""Every check made before something is sent on a client's behalf, in one place.

Two kinds of request reach a controller: an action on an axis (move, home, jog, step, a speed:
``AxisService``) and catalog commands (``/commands``, ``/raw`` and the controller resources:
``CommandRunner``). Both are checked here, in the same order, before anything is sent, so a
refusal leaves the device and the gateway as they were:

1. **Remote control**: a controller in local control (``gateway.service.control``) refuses
   whatever changes something (409 naming the state and who set it); queries and stops pass.
2. **Leases**: changing something needs the holder's lease, or none, on the controller and
   its axes (``Leases.check``); stops are never refused.
3. **The line and the controller**: for an axis action, the loop up (503), the controller
   answering (504, nothing sent) and not moving (409: its two motors never move together, §2;
   a motion command while one moves is ignored with a command error, §9-1 注意). For commands,
   the manual's refusals against the cached state: a form refused while a motor moves or a
   user program runs (409), or not available in the controller's mode (422).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Protocol

from gateway.bus.scheduler import LinkState
from gateway.errors import ConflictError, DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.reply_values import ProgramState
from gateway.protocol.spec import Effect
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef, ControllerRef

__all__ = ["ActiveMotion", "LeaseCheck", "PreSendChecks"]

#: Forms never sent through /commands or /raw, and why.
_REFUSED = {
    cmd.OPEN_PROGRAM: "I opens program reception: the controller would take the next command "
    "as program text; upload programs with PUT /controllers/{id}/program (§10 I)",
    # ES moves one controller to another rate: the gateway would lose it (and with a rate
    # other than the loop's, the whole loop hears noise from it). A loop's rate changes as a
    # whole: every controller, then the port (POST /loops/{loop}/baud, gateway.service.baud).
    cmd.SET_BAUD_RATE: "the baud rate of a loop is its configuration (loops[].baud), changed "
    "for every controller and the port at once with POST /loops/{loop}/baud: changing one "
    "controller's rate alone would cut it off the loop (§10 ES)",
}


class LeaseCheck(Protocol):
    """What the checks need of ``gateway.service.leases.Leases``."""

    def check(self, holder: str, resources: Iterable[str]) -> None:
        """Raise ``ConflictError`` when another holder leases one of ``resources``."""


class ActiveMotion(Protocol):
    """What the axis checks read of an operation in progress on the controller."""

    @property
    def axis(self) -> AxisRef:
        """The axis it moves."""


def _changes_something(command: Command) -> bool:
    return command.form.effect is not Effect.QUERY


class PreSendChecks:
    """The checks of ``gateway``'s requests, with ``leases`` (module docstring)."""

    def __init__(self, runtime: Runtime, leases: LeaseCheck) -> None:
        self.runtime = runtime
        self.leases = leases

    # ------------------------------------------------------------------ catalog commands

    def commands(self, ref: ControllerRef, commands: Sequence[Command], holder: str) -> None:
        """Every check of commands to ``ref``: sendable, remote, lease, the manual's refusals."""
        for command in commands:
            self.refuse_unsendable(command)
        self.control(ref, commands)
        self.lease(ref, commands, holder)
        self.state(ref, commands)

    def refuse_unsendable(self, command: Command, field: str = "command") -> None:
        """422 for the forms the API never sends on a client's behalf (``I``)."""
        reason = _REFUSED.get(command.form)
        if reason is not None:
            raise InvalidInputError(f"{command.wire()!r}: {reason}", field=field, rule=reason)

    def lease(self, ref: ControllerRef, commands: Sequence[Command], holder: str) -> None:
        """The lease rule: changing anything needs the controller and both axes free."""
        if any(_changes_something(c) and c.form.effect is not Effect.STOP for c in commands):
            self.leases.check(holder, [ref.id, *(a.id for a in ref.axes)])

    def control(self, ref: ControllerRef, commands: Sequence[Command]) -> None:
        """409 when ``ref`` is in local control and a command changes something; queries and
        stops (S, SS, GE, GES, GS) pass (``gateway.service.control``)."""
        for command in commands:
            if _changes_something(command) and command.form.effect is not Effect.STOP:
                self.runtime.control.check(ref, f"send {command.wire()!r}")

    def state(self, ref: ControllerRef, commands: Sequence[Command]) -> None:
        """The manual's refusals, against the cached state (module docstring)."""
        ctl = self.runtime.state.controller(ref.loop, ref.body)
        for command in commands:
            spec, form = command.spec, command.form
            if ctl.moving and not spec.form_while_moving(form):
                raise ConflictError(
                    f"{command.wire()!r} is refused while a motor of {ref.id} moves "
                    f"(§{spec.section} {spec.mnemonic}: not usable while moving); stop the "
                    "motion or wait for it to end",
                    field="command",
                )
            if ctl.program is ProgramState.RUNNING and not spec.while_program:
                raise ConflictError(
                    f"{command.wire()!r} is refused while the user program of {ref.id} runs "
                    "(§11-3 5.: G, I, IL, IW, AW, DW, AL, DL); stop it first (GE)",
                    field="command",
                )
            modes = spec.form_modes(form)
            if ctl.mode is not None and ctl.mode not in modes:
                shown = ", ".join(str(m) for m in sorted(modes))
                raise InvalidInputError(
                    f"{command.wire()!r} is not available in mode {ctl.mode} of {ref.id}",
                    field="command",
                    rule=f"§{spec.section} {spec.mnemonic} ({command.key}): modes {shown} only",
                )

    # ------------------------------------------------------------------ axis actions

    def axis_action(
        self, ref: AxisRef, holder: str, active: ActiveMotion | None, what: str = "move"
    ) -> None:
        """An action on ``ref``: remote control, leases, the loop up, the controller online and
        not moving (``active``: the operation in progress on its controller, if any)."""
        self.remote(ref, what)
        self.axis_lease(ref, holder)
        scheduler = self.runtime.scheduler(ref.loop)
        if scheduler.state is not LinkState.UP:
            raise scheduler.down_error()  # the line first: a dead loop is no busy controller
        ctl = self.runtime.state.controller(ref.loop, ref.body)
        if ctl.online is False:
            raise DeviceError(
                f"controller {ref.controller_id} does not answer (offline); nothing was sent",
                outcome="not_done",
                timeout=True,
            )
        if active is not None or ctl.moving:
            moving = active.axis.id if active is not None else f"motor {ctl.selected_motor}"
            raise ConflictError(
                f"cannot {what} {ref.id}: controller {ref.controller_id} is moving ({moving}); "
                "its two motors never move together (§2), a motion command now would be "
                "ignored with a command error (§9-1)",
                field="axis",
            )

    def axis_lease(self, ref: AxisRef, holder: str) -> None:
        """409 when another holder leases the axis or its controller."""
        self.leases.check(holder, (ref.id, ref.controller_id))

    def remote(self, ref: AxisRef, what: str) -> None:
        """409 when the axis's controller is in local control (``gateway.service.control``)."""
        controller = self.runtime.topology.controller(ref.controller_id)
        self.runtime.control.check(controller, f"{what} {ref.id}")
