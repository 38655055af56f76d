"""Fixtures of the MQTT tests: a real mosquitto on a free loopback port, a central subscriber."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from tests.support.mqtt_broker import Broker, Central


@pytest.fixture
async def broker(tmp_path: Path) -> AsyncIterator[Broker]:
    """mosquitto, started; stopped after the test."""
    b = Broker(tmp_path)
    await b.start()
    try:
        yield b
    finally:
        await b.stop()


@pytest.fixture
async def central(broker: Broker) -> AsyncIterator[Central]:
    """A subscriber on ``spBv1.0/#`` of ``broker``."""
    async with Central(broker.port) as c:
        yield c
