"""Adaptive background polling of one loop, at ``Priority.POLL``.

The poller asks; the state cache learns from the scheduler's ``ReplyObserved`` events, so what
the poller reads is latched exactly like what anyone else reads (DESIGN invariant 4). Its plan,
per controller, is a set of jobs with due times (``gateway.bus.poll_plan``: the jobs, their
commands and periods); here they run.

Whether a controller moves or answers is read from the state cache, the one home of that
knowledge; what the poller learns itself (a controller silent, or back) it publishes as a
``ControllerAnswering`` event. It reacts to what the cache learns through the cache's own
changes (a motion ended: its final position; a controller answering again), and to the bus
events only by noting work for its own task, which reads the cache when it runs: whether the
cache or the poller hears an event first never changes what the poller does.

The poller has one transaction of its plan in flight at a time; of the jobs that are due it
runs the most urgent (the order of ``Job``), then the one due longest. Beside the plan, the
loop's ``PositionStream`` reads the moving axes' positions back to back, in turn (the next
read asked for the moment the last is answered), while the plan reads a moving controller's
status every ``moving_period`` (5 Hz and more: the end of the move, limits, EMS) and the idle
controllers at their own periods, spaced while the stream reads (``PollPlan.idle_step``: never
so far that an axis turns stale), between the stream's reads (a due poll waits for one at
most). Operator commands (a higher priority) always go first. Periods are device seconds;
the scheduler's ``time_scale`` maps them to host time for the simulator.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
from collections.abc import Callable, Iterable

from gateway.bus.events import BusEvent, ControllerAnswering, LinkDown, LinkUp, ReplyObserved
from gateway.bus.poll_plan import BodyPlan, Job, PollConfig, PollPlan
from gateway.bus.position_stream import PositionStream, Submitter
from gateway.bus.requests import BusError, LoopDown, Priority, ReplyKind, TransactionResult
from gateway.bus.scheduler import LoopScheduler
from gateway.bus.state import Change, StateCache
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.reply_values import Version
from gateway.protocol.spec import Effect

__all__ = ["Job", "PollConfig", "Poller", "Submitter", "attach"]

log = logging.getLogger("gateway.bus")


# The poll commands, built once: the plan sends them many times a second.
_STATUS = cmd.status()
_VERSION = cmd.version()
_CHECKSUM = cmd.checksum()
_SENSORS = cmd.sensors()
_PROGRAM_STATE = cmd.program_state()
_ECHO_BACK = cmd.echo_back()
_CR_AFTER_ACK = cmd.cr_after_ack()
_ERROR_MARK = cmd.error_mark()
#: ``9{bit}``: 0 communication error, 4 mode, 6 step-out, 7 selected motor (§10 9 form II)
_condition_bit: Callable[[int], Command] = functools.cache(cmd.condition_bit)
#: ``6{mt}``, ``CLM{mt}``
_position: Callable[[int | None], Command] = functools.cache(cmd.position)
_motor_sensors: Callable[[int | None], Command] = functools.cache(cmd.sensors)


class Poller:
    """Polls the controllers of one loop through its scheduler, adapting to what moves."""

    def __init__(
        self,
        scheduler: Submitter,
        state: StateCache,
        bodies: Iterable[str],
        *,
        loop: str,
        config: PollConfig | None = None,
        time_scale: float = 1.0,
        clock: Callable[[], float] | None = None,
        publish: Callable[[BusEvent], None] | None = None,
        programs: Callable[[str], bool] | None = None,
    ) -> None:
        self._scheduler = scheduler
        #: whether a controller's user program may run (it may select a motor any time)
        self._programs = programs or (lambda _body: False)
        self._state = state
        #: where what the poller learns goes (the scheduler's event bus; the cache alone
        #: when there is none)
        self._publish = publish or state.handle
        self.loop = loop
        self._plan = PollPlan(
            bodies, config or PollConfig(), time_scale, stale_after=state.stale_after
        )
        self._clock = clock
        self._wake = asyncio.Event()
        self._stopping = False
        self._link_up = asyncio.Event()
        self._link_up.set()
        self._task: asyncio.Task[None] | None = None
        self._ups = 0  # LinkUp events seen
        self._fragile: tuple[str, asyncio.Future[TransactionResult]] | None = None
        #: controllers whose status read is to be made due at once (a move started, a stop
        #: was sent), and those heard again after the poller found them silent: done by the
        #: poller's task, after every subscriber has taken the event
        self._poll_soon: set[str] = set()
        self._back: set[str] = set()
        self._watch: set[str] = set()  # controllers seen starting to move
        #: polls made, per job (diagnostics)
        self.counts: dict[Job, int] = dict.fromkeys(Job, 0)
        #: the moving axes' positions, read back to back in turn
        self._positions = PositionStream(scheduler, state, loop, on_still=self.poll_now)
        self._plan.restart()
        state.changes.subscribe(self._on_change)

    # ------------------------------------------------------------------ control

    @property
    def config(self) -> PollConfig:
        """The poll plan's periods."""
        return self._plan.config

    @config.setter
    def config(self, config: PollConfig) -> None:
        self._plan.config = config

    def now(self) -> float:
        """Host seconds on the scheduler's clock."""
        return self._clock() if self._clock else asyncio.get_running_loop().time()

    def start(self) -> None:
        """Start polling (in the running event loop)."""
        if self._task is None:
            self._stopping = False
            self._task = asyncio.create_task(self._run(), name=f"poller {self.loop}")

    async def stop(self) -> None:
        """Stop polling; the transaction in flight is abandoned."""
        task, self._task = self._task, None
        if task is not None:
            self._stopping = True
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        await self._positions.stop()

    @property
    def position_reads(self) -> int:
        """Position reads of moving axes answered (diagnostics)."""
        return self._positions.reads

    def poll_now(self, body: str) -> None:
        """Read ``body``'s status at once (a move started or a stop was sent)."""
        if body in self._plan.bodies:
            self._poll_soon.add(body)
            self._wake.set()

    def _online(self, body: str) -> bool | None:
        return self._state.flags(self.loop, body).online

    def _moving(self, body: str) -> bool:
        return bool(self._state.flags(self.loop, body).moving)

    def handle(self, event: BusEvent) -> None:
        """Take one scheduler event (subscribe this to its ``EventBus``, in any order)."""
        if isinstance(event, ReplyObserved):
            effect = event.command.form.effect
            accepted = event.value is None and not event.rejected
            if accepted and effect in (Effect.MOTION, Effect.STOP):
                self.poll_now(event.body)
            fragile = self._fragile
            if accepted and effect is Effect.MOTION and fragile and fragile[0] == event.body:
                fragile[1].cancel()  # it would be refused: a command error
        elif isinstance(event, LinkUp):
            self._ups += 1
            self._plan.restart()
            self._link_up.set()
            self._wake.set()
        elif isinstance(event, LinkDown):
            self._link_up.clear()

    def _on_change(self, change: Change) -> None:
        """What the cache has just learnt of one of this loop's controllers."""
        if change.loop != self.loop or change.body is None or change.motor is not None:
            return
        plan = self._plan.bodies.get(change.body)
        if plan is None:
            return
        if change.values.get("moving") is True:
            self._watch.add(change.body)  # its position stream, from the poller's task
            self._wake.set()
        if change.values.get("moving") is False and self._online(change.body):
            plan.times.set(Job.SETTLE, self.now())  # the move has ended: its final position
            self._wake.set()
        if change.values.get("online") is True and Job.PROBE in plan.due:
            # Found silent, and answering again (to anyone): identify it before anything else.
            self._back.add(change.body)
            self._wake.set()

    def _take_notes(self) -> None:
        """Do what the events asked for, now that every subscriber has taken them."""
        if not (self._back or self._poll_soon or self._watch):
            return  # most polls: nothing was noted
        for body in sorted(self._back):
            self._came_back(self._plan.bodies[body])
        self._back.clear()
        for body in sorted(self._poll_soon):
            self._plan.poll_now(body, self._online(body))
        # A move seen starting: its positions from now on, unless its status is to be read
        # at once (a move or stop sent): that read goes first and starts them when answered.
        for body in sorted(self._watch - self._poll_soon):
            self._stream(body)
        self._poll_soon.clear()
        self._watch.clear()

    def _stream(self, body: str) -> None:
        """Read the position of ``body``'s moving axis back to back (if it moves and the
        link is up; a stream ends by itself when the move ends)."""
        if self._link_up.is_set() and self._task is not None:
            self._positions.watch(body)

    # ------------------------------------------------------------------ the jobs

    async def _run(self) -> None:
        # The flag, not only the cancellation, ends the loop: asyncio.wait_for (3.11) returns
        # the inner result when a cancel meets a wake that has just fired, swallowing the cancel.
        while not self._stopping:
            await self._link_up.wait()
            self._take_notes()
            now = self.now()
            picked = self._plan.pick(now)
            if isinstance(picked, float):
                self._wake.clear()
                wait = None if picked == float("inf") else max(0.0, picked - now)
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(wait):
                        await self._wake.wait()
                continue
            plan, job = picked
            plan.ran_due = plan.times.take(job)
            ups = self._ups
            try:
                await self._run_job(plan, job)
            except LoopDown:
                if self._ups == ups:  # no LinkUp since: wait for it (it restarts the plan)
                    self._link_up.clear()
                if job not in plan.due:
                    plan.times.set(job, 0.0)
            except BusError as exc:  # a deadline passed, a refusal: try again next period
                log.info("loop %s: poll %s of %s failed: %s", self.loop, job.name, plan.body, exc)
                self._schedule(plan, job)
            except Exception:  # a bug must not stop the polling of the whole loop
                log.exception("loop %s: poll %s of %s failed", self.loop, job.name, plan.body)
                self._schedule(plan, job)
            self._state.refresh(self.now())

    def _schedule(self, plan: BodyPlan, job: Job, *, identified: bool = False) -> None:
        """The next due time of ``job``, from what the cache knows of the controller now."""
        ctl = self._state.flags(self.loop, plan.body)
        self._plan.schedule(
            plan,
            job,
            self.now(),
            online=ctl.online,
            moving=bool(ctl.moving),
            identified=identified,
            watching=self._positions.streaming,
        )

    async def _run_job(self, plan: BodyPlan, job: Job) -> None:
        self.counts[job] += 1
        ctl = self._state.flags(self.loop, plan.body)
        motor = ctl.selected_motor or ctl.last_moved or 1
        identified = False
        if job is Job.IDENTIFY:
            identified = await self._identify(plan, ctl.online)
        elif job in (Job.STATUS, Job.STATUS_MOVING, Job.PROBE):
            # While a motor moves it is the selected one (F is refused, §10 F): an unconfirmed
            # selection is read back with 97 right after the status, in the same transaction,
            # so that the motion is shown on the motor that moves (a program's too: it selects
            # with no frame of ours) and the position stream can read 6 without a suffix.
            unsure = ctl.moving or self._programs(plan.body)
            confirm = [] if ctl.selection_confirmed or not unsure else [_condition_bit(7)]
            extra = confirm if job is not Job.PROBE else []
            answered = await self._poll(plan, _STATUS, *extra, was=ctl.online)
            if answered and self._moving(plan.body):
                self._stream(plan.body)  # a move seen (or one whose stream was cut off)
            elif answered and plan.deferred:
                await self._poll(plan, *plan.deferred)
        elif job is Job.SETTLE:  # the move has ended: its final position and sensors
            moved = ctl.last_moved or motor
            if await self._poll(plan, _position(moved), _motor_sensors(moved)) and plan.deferred:
                await self._poll(plan, *plan.deferred)
        elif job is Job.SENSORS:  # CLM is refused while moving (§10 CL); CL reads the moving one
            if ctl.moving:
                await self._poll(plan, _SENSORS)
            else:
                await self._poll(plan, _motor_sensors(1), _motor_sensors(2))
        elif job is Job.CONDITIONS:
            await self._poll(plan, _condition_bit(0), _condition_bit(6), _PROGRAM_STATE)
        elif job is Job.POSITIONS:
            await self._poll(plan, _position(1), _position(2))
        self._schedule(plan, job, identified=identified)

    async def _identify(self, plan: BodyPlan, was: bool | None) -> bool:
        """Version, mode, framing and positions, read from the device (never from cache).

        The mode is read with ``94`` (§10 9 form II: clears nothing, allowed while moving)
        rather than ``E``, which like ``EE``/``EL``/``ER`` is refused while a motor moves
        (動作中 ×) and would raise the command error the gateway then reports; those framing
        reads wait until the controller is seen stopped. True when the controller answered.
        """
        result = await self._poll(plan, _STATUS, _VERSION, _condition_bit(4), _CHECKSUM, was=was)
        if result is None:
            return False
        version = result.results[1].value
        framing = [_ECHO_BACK, _CR_AFTER_ACK]
        if isinstance(version, Version) and version.has_error_display:  # ER: ROM 1.19+
            framing.append(_ERROR_MARK)
        plan.deferred = framing
        selection = await self._poll(plan, _condition_bit(7), _position(1), _position(2))
        if selection and not self._moving(plan.body):
            await self._poll(plan, *plan.deferred)
        return True

    async def _poll(
        self, plan: BodyPlan, *commands: Command, was: bool | None = True
    ) -> TransactionResult | None:
        """One poll transaction; None when nobody answered or a move started meanwhile.
        ``was``: whether the cache had the controller online before (False: found silent).

        A poll with a command that is refused while moving is withdrawn from the queue when
        a motion command for the controller is accepted before it goes out (``handle``).
        """
        fragile = any(not c.spec.form_while_moving(c.form) for c in commands)
        task = asyncio.ensure_future(
            self._scheduler.submit(plan.body, commands, priority=Priority.POLL)
        )
        self._fragile = (plan.body, task) if fragile else None
        try:
            result = await task
        except asyncio.CancelledError:
            current = asyncio.current_task()
            if current is not None and current.cancelling():
                raise  # the poller is being stopped
            return None
        finally:
            self._fragile = None
        if not self._answered(plan, result, was):
            return None
        results = zip(commands, result.results, strict=True)
        done = {c.form for c, r in results if r.value is not None}
        if fragile and {c.form for c in plan.deferred} <= done:
            plan.deferred = []
        return result

    def _answered(self, plan: BodyPlan, result: TransactionResult, was: bool | None) -> bool:
        """Count a poll nobody answered; publish the controller silent, or back."""
        # A lost status reply is followed by a read of the other error store: if that one
        # was answered, the controller answers (one reply lost on the line is not "off").
        silent = all(
            r.kind in (ReplyKind.TIMEOUT, ReplyKind.SKIPPED) and r.seen.get("errors_read") is None
            for r in result.results
        )
        now = self.now()
        if silent:
            plan.misses += 1
            if plan.misses >= self.config.offline_after and self._online(plan.body) is not False:
                plan.probe_delay = self.config.probe_initial
                plan.times.replace({Job.PROBE: now + self._plan.host(plan.probe_delay)})
                # Off, it comes back with the framing DW stored (§10 SUM): probed plain, not with
                # a checksum it would read as part of the command ('$256' CR: '56', an error).
                self._scheduler.forget(plan.body)
                # The cache takes it as not moving any more (nothing it said is current).
                self._publish(
                    ControllerAnswering(loop=self.loop, time=now, body=plan.body, online=False)
                )
            return False
        plan.misses = 0
        if was is False:
            self._back.discard(plan.body)
            self._came_back(plan)
        return True

    def _came_back(self, plan: BodyPlan) -> None:
        """A controller found silent answers again: identify it before anything else.

        A controller that was off came back with RAM lost: its selection is F1 and its
        framing whatever DW stored (§16, §10 DL). Forget what the scheduler assumed.
        """
        now = self.now()
        plan.misses = 0
        self._scheduler.forget(plan.body)
        plan.times.replace({Job.IDENTIFY: now})
        self._publish(ControllerAnswering(loop=self.loop, time=now, body=plan.body, online=True))


def attach(
    scheduler: LoopScheduler,
    state: StateCache,
    bodies: Iterable[str],
    config: PollConfig | None = None,
) -> Poller:
    """Feed ``state`` with the scheduler's events and make a poller for ``bodies`` (the
    controllers configured on the loop); ``start()`` it once the scheduler runs."""
    poller = Poller(
        scheduler,
        state,
        bodies,
        loop=scheduler.name,
        config=config,
        time_scale=scheduler.config.time_scale,
        clock=scheduler.clock,
        publish=scheduler.events.publish,
        programs=scheduler.program_may_run,
    )
    # The state first, whoever subscribes when: the poller (and every other subscriber) reads
    # what the event has just taught it.
    scheduler.use_state(state)
    scheduler.events.subscribe(poller.handle)
    return poller
