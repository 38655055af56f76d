"""What a line worker is asked to run: its loops, each as the bus configures it, and the
program that runs them.

The API process builds these from its configuration (service/ knows the settings; the worker
knows only the bus) and sends them as the first message of the request channel.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from gateway.bus.config import LoopConfig
from gateway.bus.poll_plan import PollConfig

__all__ = ["ENGINE_WORKER", "LoopSpec", "WorkerLines", "WorkerProgram"]

#: The worker program of a real line: it opens each loop's ``url`` at its ``baud``.
ENGINE_WORKER = "gateway.engine.process"


@dataclass(frozen=True)
class LoopSpec:
    """One loop of a worker: the scheduler's and the poller's configuration, the controllers
    to poll, and the line (``url`` at ``baud``, opened by the worker)."""

    config: LoopConfig
    poll: PollConfig
    bodies: tuple[str, ...]
    url: str
    baud: int
    #: what the worker program builds the loop's line from instead of ``url`` (picklable,
    #: read by that program alone: ``serve --simulate``'s simulated loop); None: ``url``
    line: object = None

    @property
    def name(self) -> str:
        """The loop's name."""
        return self.config.name


@dataclass(frozen=True)
class WorkerProgram:
    """The program a worker process runs: ``python -m module REQUESTS_FD STOPS_FD``, and the
    descriptors it inherits besides the two channels (a listening socket the API process
    bound once, so that every worker started again serves on the same port)."""

    module: str = ENGINE_WORKER
    pass_fds: tuple[int, ...] = ()


@dataclass(frozen=True)
class WorkerLines:
    """Lines the workers build themselves instead of opening the loops' URLs: the program
    that builds them, and per loop what it builds its line from (``LoopSpec.line``)."""

    program: WorkerProgram
    lines: Mapping[str, object] = field(default_factory=dict)
