"""What a line worker is asked to run: its loops, each as the bus configures it.

The API process builds these from its configuration (service/ knows the settings; the worker
knows only the bus) and sends them as the first message of the request channel.
"""

from __future__ import annotations

from dataclasses import dataclass

from gateway.bus.config import LoopConfig
from gateway.bus.poll_plan import PollConfig

__all__ = ["LoopSpec"]


@dataclass(frozen=True)
class LoopSpec:
    """One loop of a worker: the scheduler's and the poller's configuration, the controllers
    to poll, and the line (``url`` at ``baud``, opened by the worker)."""

    config: LoopConfig
    poll: PollConfig
    bodies: tuple[str, ...]
    url: str
    baud: int

    @property
    def name(self) -> str:
        """The loop's name."""
        return self.config.name
