"""Sending catalog commands to one controller on a client's behalf: who may, when, and how.

Every controller request of the API (the typed ``/commands``, ``/raw``, the position table,
I/O, sensor logic, mode, EEPROM and program resources) goes through ``CommandRunner``:

* **Role** (``required_role``): sending anything needs the operator role; the forms that
  write or load the EEPROM, change the operating mode or the position range, change the
  framing, or switch program autostart need admin (rule ``ROLE_RULE``). Queries of those
  settings stay operator. ``I`` is never sent this way: it leaves the controller reading
  program text, so the next command would become part of a program (``PUT .../program``).
* **Remote control**: a controller in local control (``gateway.service.control``) refuses
  every command that changes something (409 naming the state and who set it); queries and
  stops pass.
* **Leases**: a request that changes something checks the controller's lease and both its
  axes' (``Leases.check``); stops (``S``, ``SS``, ``GE``, ``GES``, ``GS``) never are refused.
* **The manual's refusals**, checked before sending against the state cache: a form refused
  while a motor moves (the catalog's ``while_moving``, §10 per-command tables) or while a user
  program runs (§11-3 5.) is answered 409 naming the rule; a form not available in the
  controller's operating mode (§10 E, each table's mode row) 422. The device would take such a
  command with '>' and only set its command-error flag (§9-1 注意), which a client would
  never see on its request.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Protocol

from gateway.bus.requests import Outcome, ReplyKind, TransactionResult
from gateway.errors import ConflictError, DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.reply_values import ProgramState
from gateway.protocol.spec import Effect
from gateway.service.axes.soft_limits import SoftLimits
from gateway.service.roles import Role
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import ControllerRef

__all__ = [
    "ADMIN_MNEMONICS",
    "ROLE_RULE",
    "CommandRunner",
    "LeaseCheck",
    "require_done",
    "required_role",
]

#: Mnemonics whose non-query forms need the admin role: what outlives the request or changes
#: how the line talks (raw, EEPROM, programs, mode, framing). EEPROM: AW, DW, IW write it,
#: EE/// erases it, AL, DL, IL load it over RAM, ES writes the baud rate to it at once
#: (§10 ES); mode: E, and EP / ED which change how positions are counted and pulses are
#: output (§10 EP, ED); framing: EE, EL, ER, SUM (§10); programs: I (upload) and GA
#: (GAS/GAR write the EEPROM at once, §10 GA).
ADMIN_MNEMONICS = frozenset(
    {"AW", "DW", "IW", "EE///", "AL", "DL", "IL", "ES", "E", "EP", "ED", "EE", "EL", "ER", "SUM",
     "I", "GA"}
)  # fmt: skip

ROLE_RULE = (
    "operator for every command; admin for the forms that write, load or erase the EEPROM "
    "(AW, DW, IW, EE///, AL, DL, IL, ES), change the mode or position range (E, EP, ED), the "
    "framing (EE, EL, ER, SUM) or program autostart (GAS, GAR); their queries stay operator"
)

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


#: The mode as the condition bits show it: clears nothing, allowed while moving (§10 9 form II).
_MODE_READ = cmd.condition_bit(4)


def required_role(command: Command) -> Role:
    """The role a client needs to send ``command`` (``ROLE_RULE``)."""
    effect = command.form.effect
    if command.mnemonic in ADMIN_MNEMONICS and effect is not Effect.QUERY:
        return Role.ADMIN
    return Role.OPERATOR


class LeaseCheck(Protocol):
    """What the runner needs of ``gateway.service.leases.Leases``."""

    def check(self, holder: str, resources: Iterable[str]) -> None:
        """Raise ``ConflictError`` when another holder leases one of ``resources``."""


def _changes_something(command: Command) -> bool:
    return command.form.effect is not Effect.QUERY


class CommandRunner:
    """Checks and sends commands to controllers of ``gateway``."""

    def __init__(self, gateway: Runtime, leases: LeaseCheck) -> None:
        self.gateway = gateway
        self.leases = leases
        self.limits = SoftLimits(gateway)

    # ------------------------------------------------------------------ checks

    def refuse_unsendable(self, command: Command, field: str = "command") -> None:
        """422 for the forms the API never sends on a client's behalf (``I``)."""
        reason = _REFUSED.get(command.form)
        if reason is not None:
            raise InvalidInputError(f"{command.wire()!r}: {reason}", field=field, rule=reason)

    def check_lease(self, ref: ControllerRef, commands: Sequence[Command], holder: str) -> None:
        """The lease rule: changing anything needs the controller and both axes free."""
        if any(_changes_something(c) and c.form.effect is not Effect.STOP for c in commands):
            self.leases.check(holder, [ref.id, *(a.id for a in ref.axes)])

    def check_control(self, ref: ControllerRef, commands: Sequence[Command]) -> None:
        """409 when ``ref`` is in local control and a command changes something; queries and
        stops (S, SS, GE, GES, GS) pass (``gateway.service.control``)."""
        for command in commands:
            if _changes_something(command) and command.form.effect is not Effect.STOP:
                self.gateway.control.check(ref, f"send {command.wire()!r}")

    def check_state(self, ref: ControllerRef, commands: Sequence[Command]) -> None:
        """The manual's refusals, against the cached state (module docstring)."""
        ctl = self.gateway.state.controller(ref.loop, ref.body)
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

    # ------------------------------------------------------------------ sending

    async def run(
        self,
        ref: ControllerRef,
        commands: Command | Sequence[Command],
        *,
        holder: str,
        motor: int | None = None,
        field: str = "command",
    ) -> TransactionResult:
        """Check ``commands`` (leases, the manual's refusals, the soft limits of the axis a
        motion command moves) and send them as one transaction.

        A query-only transaction needs no lease. A motion command on an axis with soft limits
        is sent with what fixes its target (``SoftLimits.guard``). Raises ``ConflictError``,
        ``InvalidInputError`` (``field``: the request's field holding the command) and the
        scheduler's ``LoopDown`` / ``DeadlineExpired`` / ``TransactionError``.
        """
        cmds = [commands] if isinstance(commands, Command) else list(commands)
        for command in cmds:
            self.refuse_unsendable(command)
        self.check_control(ref, cmds)
        self.check_lease(ref, cmds, holder)
        self.check_state(ref, cmds)
        guarded = await self.limits.guard(ref, cmds, motor, field)
        result = await self.send(ref, guarded.commands, motor=guarded.motor)
        if any(c.form in (cmd.SET_MODE, cmd.LOAD_SETTINGS) for c in cmds):
            # The cache learns the mode from reads only (the poller reads it once, at first
            # contact): read it back after E or a DL (which loads E from the EEPROM, §10 DL)
            # so that the mode checks above see the new one (§10 9 bits 5,4).
            await self.send(ref, [_MODE_READ])
        return result

    async def send(
        self, ref: ControllerRef, commands: Sequence[Command], *, motor: int | None = None
    ) -> TransactionResult:
        """Send without the checks (reads the service makes for itself)."""
        # Stops (S, SS, GES) go at stop priority: ``submit`` sees to that (DESIGN invariant 8).
        scheduler = self.gateway.scheduler(ref.loop)
        return await scheduler.submit(ref.body, commands, motor=motor)


def require_done(ref: ControllerRef, result: TransactionResult) -> TransactionResult:
    """``result`` when every command is DONE; otherwise the error a resource request answers.

    '>@' or '?' every time (the controller refused it): 409; a lost or garbled reply: 504
    with the outcome (``not_done`` / ``unknown``).
    """
    if result.ok:
        return result
    failed = next(r for r in result.results if r.outcome is not Outcome.DONE)
    text = failed.command.wire()
    if failed.kind in (ReplyKind.REJECTED, ReplyKind.NOT_ACCEPTED):
        what = "'>@' (command error, §10 ER)" if failed.kind is ReplyKind.REJECTED else "'?'"
        raise ConflictError(f"controller {ref.id} refused {text!r}: {what}", field="command")
    if failed.kind is ReplyKind.SKIPPED and not any(
        r.outcome is Outcome.UNKNOWN for r in result.results
    ):
        # Not sent because the motor could not be selected: F is refused while a motor moves
        # (§10 F); nothing acted, so it is a conflict with the motion, not a device failure.
        raise ConflictError(
            f"controller {ref.id}: {text!r} was not sent ({failed.note}); a motor is moving "
            "(§10 F: the motor cannot be selected while one moves)",
            field="command",
        )
    raise DeviceError(
        f"controller {ref.id}: {text!r} {failed.kind.value} ({failed.note or 'no reply'}); "
        f"outcome {failed.outcome.value}",
        outcome=failed.outcome.value,
        timeout=failed.kind is ReplyKind.TIMEOUT,
    )
