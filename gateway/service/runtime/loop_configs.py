"""A configured loop as the bus configures it: its scheduler's and its poller's settings."""

from __future__ import annotations

from types import MappingProxyType

from gateway.bus.config import LoopConfig
from gateway.bus.poll_plan import PollConfig
from gateway.protocol.framing import Series
from gateway.service.config import LoopSettings
from gateway.service.topology import LoopRef

__all__ = ["loop_config", "poll_config"]


def loop_config(settings: LoopSettings, ref: LoopRef, time_scale: float) -> LoopConfig:
    """The scheduler's configuration of one loop."""
    return LoopConfig(
        name=settings.name,
        baud=settings.baud,
        time_scale=time_scale,
        **settings.timeouts.model_dump(),  # TimeoutSettings' fields are LoopConfig's
        sum_at_connect=settings.sum_at_connect,
        series=MappingProxyType(
            {c.body: c.series for c in ref.controllers if c.series is not Series.DOLLAR}
        ),
    )


def poll_config(settings: LoopSettings) -> PollConfig:
    """The poller's periods of one loop."""
    return PollConfig(**settings.poll.model_dump())  # PollSettings' fields are PollConfig's
