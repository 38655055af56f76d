"""Sending catalog commands to one controller on a client's behalf: who may, when, and how.

Every controller request of the API (the typed ``/commands``, ``/raw``, the position table,
I/O, sensor logic, mode, EEPROM and program resources) goes through ``CommandRunner``:

* **Role** (``required_role``): sending anything needs the operator role; the forms that
  write or load the EEPROM, change the operating mode or the position range, change the
  framing, or switch program autostart need admin (rule ``ROLE_RULE``). Queries of those
  settings stay operator. ``I`` is never sent this way: it leaves the controller reading
  program text, so the next command would become part of a program (``PUT .../program``).
* **Remote control, leases and the manual's refusals**: ``gateway.service.presend``, the one
  home of the checks made before anything is sent (axis actions use the same).
"""

from __future__ import annotations

from collections.abc import Sequence

from gateway.bus.requests import Outcome, ReplyKind, TransactionResult
from gateway.errors import ConflictError, DeviceError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.spec import Effect
from gateway.service.axes.soft_limits import SoftLimits
from gateway.service.presend import LeaseCheck, PreSendChecks
from gateway.service.roles import Role
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import ControllerRef

__all__ = [
    "ADMIN_MNEMONICS",
    "ROLE_RULE",
    "CommandRunner",
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


#: The mode as the condition bits show it: clears nothing, allowed while moving (§10 9 form II).
_MODE_READ = cmd.condition_bit(4)


def required_role(command: Command) -> Role:
    """The role a client needs to send ``command`` (``ROLE_RULE``)."""
    effect = command.form.effect
    if command.mnemonic in ADMIN_MNEMONICS and effect is not Effect.QUERY:
        return Role.ADMIN
    return Role.OPERATOR


class CommandRunner:
    """Checks and sends commands to controllers of ``gateway``."""

    def __init__(self, runtime: Runtime, leases: LeaseCheck) -> None:
        self.runtime = runtime
        self.checks = PreSendChecks(runtime, leases)
        self.limits = SoftLimits(runtime)

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
        self.checks.commands(ref, cmds, holder)
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
        scheduler = self.runtime.scheduler(ref.loop)
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
