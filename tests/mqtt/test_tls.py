"""TLS to the broker from the configuration: the node trusts the CA file it is given, and
refuses a broker whose certificate another CA signed."""

from __future__ import annotations

import asyncio
import logging
import ssl
from pathlib import Path

import trustme

from tests.mqtt.in_process import edge_node
from tests.support.mqtt_broker import Broker, Central
from tests.support.mqtt_refusals import Refusals


async def test_the_node_speaks_tls_to_a_broker_its_ca_signed(tmp_path: Path) -> None:
    ca, other = trustme.CA(), trustme.CA()
    server = ca.issue_cert("127.0.0.1")
    server.cert_chain_pems[0].write_to_path(str(tmp_path / "server.pem"))
    server.private_key_pem.write_to_path(str(tmp_path / "server.key"))
    ca.cert_pem.write_to_path(str(tmp_path / "ca.pem"))
    other.cert_pem.write_to_path(str(tmp_path / "other-ca.pem"))
    listener = f"certfile {tmp_path}/server.pem\nkeyfile {tmp_path}/server.key\n"
    broker = Broker(tmp_path, tls=listener)
    await broker.start()
    trust = ssl.create_default_context()
    ca.configure_trust(trust)
    logger = logging.getLogger("gateway.mqtt")
    handler = Refusals()
    logger.addHandler(handler)
    try:
        async with Central(broker.port, tls=trust) as central:
            async with edge_node(broker.port, tls=True, ca_file=tmp_path / "ca.pem"):
                birth = await central.wait_for("NBIRTH", node="fed")
                assert birth.values["bdSeq"] == 0
            assert not handler.refused.is_set()
            async with edge_node(
                broker.port, connected=False, tls=True, ca_file=tmp_path / "other-ca.pem"
            ) as (_, node):
                await asyncio.wait_for(handler.refused.wait(), 20)
                assert not node.connected.is_set()
        assert any("CERTIFICATE_VERIFY_FAILED" in t or "certificate" in t for t in handler.texts)
    finally:
        logger.removeHandler(handler)
        await broker.stop()
