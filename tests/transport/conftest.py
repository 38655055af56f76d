"""The fixture every transport test shares: one simulated controller (body 1)."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from gateway.sim.loop import SimLoop
from tests.transport import make_sim


@pytest.fixture
async def sim() -> AsyncIterator[SimLoop]:
    loop = make_sim("1")
    yield loop
    loop.close()
