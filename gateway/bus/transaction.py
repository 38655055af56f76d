"""Running one transaction: its commands in order, with the frames the scheduler adds.

For each command of the caller:

1. a framing in doubt is read back first (``detect``);
2. a per-motor command gets ``F{m}`` first when the cached selection is not m (``selection``);
3. a motion command gets a position read ``6{mt}`` right before it, a non-idempotent setting a
   read of its value (``verify``);
4. the command is sent: '?' -> sent again, up to ``nak_retries`` (§9-2: not taken); a lost,
   garbled or bad-checksum reply -> sent again only when idempotent and starting no motion,
   otherwise read back and reported DONE / NOT_DONE / UNKNOWN (DESIGN invariant 6);
5. EEPROM writes hold the line until their ``$B#*`` (§10 AW, DW, IW, EE///), serving stops.

A stop queued meanwhile goes out before the transaction's next frame (``LineExchange.send``); once
a stop to its own controller has gone, the transaction sends no more commands that act (only
reads): the stop must not be undone by the move queued behind it.

The first command that is not DONE ends the transaction; the rest are reported SKIPPED.
Each command's result carries its frame as it was written (``CommandResult.frame``, checksum
included), which is what clients and the audit are shown as sent.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from gateway.bus.detect import ensure_framing
from gateway.bus.eeprom_hold import hold_for_write
from gateway.bus.exchange import DOUBT, LineExchange, Sent
from gateway.bus.position_presets import presets_positions, read_backs
from gateway.bus.read_back import (
    ValueCheck,
    is_motion,
    motion_outcome,
    position_query,
    resendable,
    status_query,
    value_check,
    value_outcome,
)
from gateway.bus.requests import CommandResult, Outcome, ReplyKind
from gateway.bus.retries import Retries
from gateway.bus.selection import confirm_command, needs_selection, select_command
from gateway.bus.upload import upload
from gateway.protocol import commands as cmd
from gateway.protocol.framing import Framing, framing_switch
from gateway.protocol.models import Command
from gateway.protocol.program import Program
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_values import StatusFlags
from gateway.protocol.spec import Effect, ReplyFormat

__all__ = ["TransactionRunner"]

#: The error bits ``""`` and ``9`` (form I) clear live in two stores, one per read (§10 9 ③):
#: after a lost reply to one, the other still reports them.
_OTHER_STORE = {cmd.STATUS: cmd.condition(), cmd.CONDITION: cmd.status()}


class TransactionRunner:
    """One transaction to one controller; ``run`` sends it."""

    def __init__(
        self,
        core: LineExchange,
        body: str,
        commands: tuple[Command, ...],
        motor: int | None,
        program: Program | None = None,
    ) -> None:
        self.core = core
        self.body = body
        self.commands = commands
        self.motor = motor
        self.program = program
        #: stops sent to the controller before the transaction started
        self._stops = core.stops.sent_to(body)

    async def run(self) -> tuple[list[CommandResult], int]:
        """Every command's result, and the number of frames sent."""
        first = self.core.counters.exchanges
        results: list[CommandResult] = []
        failed: CommandResult | None = None
        for command in self.commands:
            if failed is not None:
                note = f"not sent: {failed.command.wire()!r} ended {failed.outcome.value}"
                results.append(
                    CommandResult(
                        command, ReplyKind.SKIPPED, Outcome.NOT_DONE, attempts=0, note=note
                    )
                )
                continue
            if self.program is not None and command.form is cmd.OPEN_PROGRAM:
                result = await upload(self.core, self.body, command, self.program, self._query)
            else:
                result = await self._step(command)
            results.append(result)
            if result.outcome is not Outcome.DONE:
                failed = result
        if self.core.link.programs.may_run(self.body):
            # A running program may select the other motor between two transactions: what
            # this one read of the selection is not trusted by the next (DESIGN invariant 5).
            self.core.doubt(self.body)
        return results, self.core.counters.exchanges - first

    # ------------------------------------------------------------------ helpers

    def _axis(self, command: Command) -> int | None:
        if command.motor is not None:
            return command.motor
        return self.motor if self.motor is not None else self.core.selected(self.body)

    async def _send_retrying(self, command: Command, motor: int | None) -> Sent:
        """Send with the retries the form allows: '?' always, a lost reply if resendable."""
        retries = Retries(self.core.config, self.core.counters)
        while True:
            sent = await self.core.send(self.body, command, motor)
            if sent.kind is ReplyKind.NOT_ACCEPTED and retries.after_nak():
                continue
            if sent.kind in DOUBT and retries.after_doubt(command):
                continue
            return sent

    async def _query(self, command: Command) -> ReplyValue | None:
        """A read the scheduler makes for itself; its value, None when none came."""
        sent = await self._send_retrying(command, self.motor)
        return sent.value if sent.kind is ReplyKind.DATA else None

    async def _position(self, motor: int | None) -> int | None:
        """The position read twice (three times when they differ): without a checksum a
        reply bent on the line can still decode, and every verdict on the motion rests on
        this pre-read. None when no two reads agree."""
        query = position_query(motor)
        first, second = await self._query(query), await self._query(query)
        if first != second:
            third = await self._query(query)
            first = third if third in (first, second) else None
        return first if isinstance(first, int) and not isinstance(first, bool) else None

    async def _confirm(self, motor: int) -> bool:
        """After '>' to F{m}: is m selected? (F is refused while a motor moves, §10 F)."""
        core = self.core
        if core.framing.get(self.body).error_mark or not core.config.confirm_selection:
            core.set_selection(self.body, motor)  # with ER1 a refused F would be '>@'
            return True
        core.set_selection(self.body, None)
        await self._query(confirm_command())  # the reply sets the selection it shows
        return core.selected(self.body) == motor

    async def _selected(self, command: Command) -> bool:
        """The motor ``command`` needs is selected (F sent first when the cache differs)."""
        motor = self.motor
        if motor is None or not needs_selection(command):
            return True
        return self.core.selected(self.body) == motor or await self._select(motor)

    async def _select(self, motor: int) -> bool:
        """Send F{motor} and confirm it."""
        sent = await self._send_retrying(select_command(motor), motor)
        return sent.kind is ReplyKind.ACCEPTED and await self._confirm(motor)

    # ------------------------------------------------------------------ one command

    async def _step(self, command: Command) -> CommandResult:
        core, body, config = self.core, self.body, self.core.config
        st = _Step(command, value_check(command), Retries(config, core.counters))
        while True:
            await ensure_framing(core, body)
            st.framing = core.framing.get(body)
            refused = await self._prepare(st)
            if self._framing_doubted(st):
                if st.redetected:
                    note = "the framing is still in doubt after reading it back: not sent"
                    return st.result(ReplyKind.SKIPPED, Outcome.NOT_DONE, note)
                st.redetected = True
                continue  # read the framing back, then the pre-reads again
            if refused is not None:
                return refused
            if core.stops.waiting():
                await core.stops.send_queued()
            if self._overtaken(command):
                note = "a stop to this controller went out first: not sent"
                return st.result(ReplyKind.SKIPPED, Outcome.NOT_DONE, note)
            st.mark = core.eeprom_done.get(body, 0)
            sent = await core.send(body, command, self.motor)
            st.attempts += 1
            st.frame = sent.frame
            if sent.kind is ReplyKind.NOT_ACCEPTED:
                if is_motion(command):
                    # On a noisy line a '>' one bit off reads '?' (0x3E, 0x3F): a motion is
                    # sent again only once a read-back shows it did not run (invariant 6).
                    checked = await self._verify(st, sent.kind, "'?'")
                    if checked.outcome is not Outcome.NOT_DONE:
                        return checked
                if self._again_after_nak(st):
                    continue
                return st.result(sent.kind, Outcome.NOT_DONE, sent.note)
            if sent.kind in DOUBT:
                if st.retries.after_doubt(command):
                    continue
                if resendable(command):
                    await self._positions_after(command)
                    return st.result(sent.kind, Outcome.UNKNOWN, sent.note)
                return await self._verify(st, sent.kind)
            return await self._finish(st, sent)

    def _framing_doubted(self, st: _Step) -> bool:
        """A reply since the framing was settled (a pre-read, the F confirmation) showed
        another framing, and ``st``'s command acts: it is not sent in a framing in doubt. A
        controller that lost SUM1 reads the checksum digits as part of the command
        (``$1210018`` CR is position data 10018, §10 SUM); a stop is never held back."""
        if st.command.form.effect in (Effect.QUERY, Effect.STOP):
            return False
        return self.core.framing.suspicion(self.body) is not None

    def _overtaken(self, command: Command) -> bool:
        """A stop to this controller went out during the transaction, and ``command`` acts."""
        if self.core.stops.sent_to(self.body) == self._stops:
            return False
        return command.form.effect not in (Effect.QUERY, Effect.STOP)

    async def _prepare(self, st: _Step) -> CommandResult | None:
        """F first when needed; the pre-reads of motion and non-idempotent settings."""
        command, motor = st.command, self.motor
        if not await self._selected(command):
            note = f"F{motor} was not taken (a motor moving? §10 F): not sent"
            return st.result(ReplyKind.SKIPPED, Outcome.NOT_DONE, note)
        if command.form in cmd.CLEARS_ERRORS and not st.seen.get("status_before"):
            # §10 K: forms I, II and IV clear the limit and EMS bits of "" without a read.
            # Read them first, so the state cache latches what the device is about to forget
            # (DESIGN invariant 4).
            st.seen["status_before"] = await self._query(status_query())
        if is_motion(command):  # right before every send of the move
            st.before_pos = await self._position(self._axis(command))
            st.seen["position_before"] = st.before_pos
        if st.check is not None and st.before_value is None:
            st.before_value = await self._query(st.check.query)
            st.seen["value_before"] = st.before_value
        # A pre-read that timed out or was answered '?' dropped the selection (the controller
        # may have restarted with motor 1 selected, §16): select again, right before the send
        # (DESIGN invariant 5).
        if not await self._selected(command):
            note = f"F{motor} was not taken after a pre-read in doubt (§10 F): not sent"
            return st.result(ReplyKind.SKIPPED, Outcome.NOT_DONE, note)
        return None

    def _again_after_nak(self, st: _Step) -> bool:
        """'?': the controller did not take the frame (§9-2); whether to send it again."""
        core = self.core
        if st.retries.after_nak():
            return True
        if not (st.framing.checksum or st.reframed or core.framing.confirmed(self.body)):
            # A controller with SUM1 answers every frame without a checksum '?' (§10 SUM):
            # read the framing back (it is not known yet), then try once more.
            st.reframed = True
            st.retries.naks = 0
            core.framing.suspect(self.body, "every frame answered '?' (SUM1?)")
            return True
        return False

    async def _finish(self, st: _Step, sent: Sent) -> CommandResult:
        """A reply came: '>@', a refused query's bare '>', a confirmed F, an EEPROM hold."""
        command = st.command
        if sent.kind is ReplyKind.REJECTED or (
            sent.kind is ReplyKind.ACCEPTED and command.reply_format.has_data
        ):
            return st.result(sent.kind, Outcome.NOT_DONE, sent.note)
        outcome, note = Outcome.DONE, sent.note
        selected = command.motor if command.form is cmd.SELECT_MOTOR else None
        if selected is not None and not await self._confirm(selected):
            outcome, note = Outcome.NOT_DONE, "F answered '>' but the selection stayed"
        if command.reply_format is ReplyFormat.ACK_THEN_DONE:
            outcome = await hold_for_write(self.core, self.body, command, st.mark, st.seen)
        await self._positions_after(command)
        return st.result(sent.kind, outcome, note, value=sent.value, late=sent.late)

    async def _positions_after(self, command: Command) -> None:
        """A command that may have set a position without motion (R, E, DL, EP): the
        positions it may have changed are read back now, before anything else is sent (the
        state cache marked them stale at its '>')."""
        if presets_positions(command):
            for query in read_backs(command, self._axis(command)):
                await self._query(query)

    async def _verify(self, st: _Step, kind: ReplyKind, why: str = "reply lost") -> CommandResult:
        """The reply of a command that must not be sent again was lost (or bent): read back."""
        core, command, seen = self.core, st.command, st.seen
        core.counters.verifications += 1
        if is_motion(command):
            status = await self._query(status_query())
            after = await self._query(position_query(self._axis(command)))
            flags = status if isinstance(status, StatusFlags) else None
            after_pos = after if isinstance(after, int) else None
            seen.update(status=flags, position_after=after_pos)
            outcome = motion_outcome(flags, st.before_pos, after_pos)
            how = "read back the status and the position"
        elif st.check is not None:
            after_value = await self._query(st.check.query)
            seen["value_after"] = after_value
            outcome = value_outcome(st.before_value, after_value, st.check)
            how = f"read back {st.check.query.wire()}"
        elif command.form.switches_framing:
            expected = framing_switch(st.framing, command.wire()).after
            await ensure_framing(core, self.body)
            now = core.framing.get(self.body)
            seen["framing"] = now
            if not core.framing.confirmed(self.body):
                outcome = Outcome.UNKNOWN
            else:
                outcome = Outcome.DONE if now == expected else Outcome.NOT_DONE
            how = "read the framing back"
        elif command.reply_format is ReplyFormat.ACK_THEN_DONE:
            outcome = await hold_for_write(core, self.body, command, st.mark, seen)
            how = "waited for $B#*"
        elif command.form in _OTHER_STORE:
            # The lost reply cleared error bits nobody saw (an EMS, a limit). The controller
            # keeps them in a second store too (§10 "" and §10 9 ③): read that one now, so
            # the state cache latches them at once rather than never.
            other = _OTHER_STORE[command.form]
            seen["errors_read"] = await self._query(other)
            shown = other.wire() or '""'
            outcome, how = Outcome.UNKNOWN, f"read {shown} for the errors it cleared"
        else:
            outcome, how = Outcome.UNKNOWN, "nothing reads it back"
        return st.result(kind, outcome, f"{why}; {how}")


@dataclass
class _Step:
    """One caller's command on its way: attempts so far and what the pre-reads saw."""

    command: Command
    check: ValueCheck | None
    retries: Retries
    attempts: int = 0
    reframed: bool = False
    redetected: bool = False  # the framing was read back again before the send
    framing: Framing = field(default_factory=Framing)
    mark: int = 0  # $B#* seen before the send (EEPROM writes)
    before_pos: int | None = None
    before_value: ReplyValue | None = None
    seen: dict[str, Any] = field(default_factory=dict)
    frame: bytes = b""  # as its last attempt was written (the result's ``frame``)

    def result(
        self,
        kind: ReplyKind,
        outcome: Outcome,
        note: str = "",
        *,
        value: ReplyValue | None = None,
        late: bool = False,
    ) -> CommandResult:
        """The command's result so far."""
        return CommandResult(
            self.command, kind, outcome, value, self.attempts, late, dict(self.seen), note,
            self.frame,
        )  # fmt: skip
