"""The API process's side of a worker process: start it, watch it, start it again.

``WorkerSupervisor(client, specs)`` starts ``python -m gateway.engine.process`` (or the
``program`` given: its module, and the descriptors it inherits) with two fresh socketpairs,
sends it the loops to run and attaches ``client`` to the channels. When the process ends
without being asked to, the worker's loops are down with the cause (how it ended, when it comes
back: ``LoopDown`` and its ``retry_after`` for every request meanwhile, a ``LinkDown`` event, a
log line) and a new process is started after a back-off that doubles up to ``BACKOFF[-1]`` and
starts over once a worker has lived ``STEADY_SECONDS``. The other workers and the API process
go on.

``close()`` closes the channels: the worker lets the transaction in flight finish, closes
its lines and exits; one that does not within ``drain`` seconds is killed.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import socket
import sys
import time
from collections.abc import Sequence

from gateway.engine.proxy import WorkerClient
from gateway.engine.wire import Channel, Kind, encode
from gateway.engine.worker_spec import LoopSpec, WorkerProgram

__all__ = ["BACKOFF", "WorkerSupervisor", "exit_cause"]

log = logging.getLogger("gateway.engine")

#: Real seconds before each new start of a worker that died, the last one repeated.
BACKOFF = (0.5, 1.0, 2.0, 4.0, 8.0, 15.0)
#: A worker that lived this long (real seconds) died of something new: back-off starts over.
STEADY_SECONDS = 60.0


def exit_cause(code: int) -> str:
    """How a worker process ended, in words (a negative code is the signal that ended it)."""
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"was killed by {signal.Signals(-code).name}"
        return f"was killed by signal {-code}"
    return f"exited with code {code}"


class WorkerSupervisor:
    """One worker process, kept running for its loops."""

    def __init__(
        self,
        client: WorkerClient,
        specs: Sequence[LoopSpec],
        *,
        backoff: Sequence[float] = BACKOFF,
        program: WorkerProgram | None = None,
    ) -> None:
        self.client = client
        #: what the process runs (a new process, after a death, the same)
        self.program = program if program is not None else WorkerProgram()
        self.specs = list(specs)
        self.backoff = tuple(backoff)
        #: how many times the worker died and was started again
        self.restarts = 0
        #: the running worker's process (None between a death and the next start)
        self.process: asyncio.subprocess.Process | None = None
        self._closed = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._failures = 0

    @property
    def name(self) -> str:
        """The worker's name (its client's)."""
        return self.client.name

    @property
    def up(self) -> bool:
        """True while the worker's process runs and its channels are attached."""
        process = self.process
        return process is not None and process.returncode is None and self.client.attached

    async def start(self) -> None:
        """Start the worker and watch it; returns once its first snapshot is in, or it died
        before (its loops are down with the cause, and it is started again after the
        back-off)."""
        await self._spawn()
        assert self.process is not None
        died = asyncio.ensure_future(self.process.wait())
        synced = asyncio.ensure_future(self.client.synced.wait())
        self._task = asyncio.create_task(self._watch())
        await asyncio.wait([synced, died], return_when=asyncio.FIRST_COMPLETED)
        synced.cancel()
        died.cancel()

    async def close(self, *, drain: float = 5.0) -> None:
        """Let the worker finish and exit (killed after ``drain`` + 2 real seconds)."""
        self._closed.set()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        await self.client.detach(f"line worker {self.name} was stopped")
        process, self.process = self.process, None
        if process is not None and process.returncode is None:
            try:
                await asyncio.wait_for(process.wait(), drain + 2.0)
            except TimeoutError:
                log.error("line worker %s did not exit: killed", self.name)
                process.kill()
                await process.wait()

    async def _spawn(self) -> None:
        pairs = [socket.socketpair() for _ in range(2)]
        theirs = [pair[1] for pair in pairs]
        try:
            self.process = await asyncio.create_subprocess_exec(
                sys.executable, "-m", self.program.module,
                *(str(s.fileno()) for s in theirs),
                pass_fds=[*(s.fileno() for s in theirs), *self.program.pass_fds],
            )  # fmt: skip
        finally:
            for sock in theirs:
                sock.close()
        channels: list[Channel] = [await asyncio.open_connection(sock=p[0]) for p in pairs]
        channels[0][1].write(encode((Kind.START, self.specs)))
        await self.client.attach(channels[0], channels[1])
        log.info(
            "line worker %s started (pid %d) for the loops %s",
            self.name,
            self.process.pid,
            ", ".join(s.name for s in self.specs),
        )

    async def _watch(self) -> None:
        while True:
            process = self.process
            assert process is not None
            started = time.monotonic()
            code = await process.wait()
            if time.monotonic() - started >= STEADY_SECONDS:
                self._failures = 0
            delay = self.backoff[min(self._failures, len(self.backoff) - 1)]
            self._failures += 1
            self.restarts += 1
            cause = f"line worker {self.name} {exit_cause(code)}; restarting in {delay:g} s"
            log.error("%s (loops %s)", cause, ", ".join(s.name for s in self.specs))
            self.process = None
            await self.client.detach(cause, retry_after=delay)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._closed.wait(), delay)  # the back-off, or close()
            if self._closed.is_set():
                return
            await self._spawn()
