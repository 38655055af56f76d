"""Username and password from the configuration, on a mosquitto that wants them; the
password never in the log."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

from tests.mqtt.in_process import edge_node
from tests.support.mqtt_broker import Broker, Central
from tests.support.mqtt_refusals import Refusals

PASSWORD = "pw-7f3a9c"


async def test_the_node_logs_in_and_a_wrong_password_is_refused_without_showing_it(
    tmp_path: Path,
) -> None:
    broker = Broker(tmp_path, users={"cell": PASSWORD, "host": "host-pw"})
    await broker.start()
    logger = logging.getLogger("gateway.mqtt")
    handler = Refusals()
    logger.addHandler(handler)
    level, logger.level = logger.level, logging.DEBUG
    try:
        async with Central(broker.port, login=("host", "host-pw")) as central:
            async with edge_node(broker.port, username="cell", password=PASSWORD):
                await central.wait_for("NBIRTH", node="fed")
            assert not handler.refused.is_set()
            async with edge_node(
                broker.port, connected=False, username="cell", password=PASSWORD + "x"
            ) as (_, node):
                await asyncio.wait_for(handler.refused.wait(), 20)
                assert not node.connected.is_set()
        text = "\n".join(handler.texts)
        assert "again in" in text  # the refusal is said (the login before it: its NBIRTH)
        assert PASSWORD not in text
    finally:
        logger.removeHandler(handler)
        logger.level = level
        await broker.stop()
