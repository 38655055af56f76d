"""``[mqtt]``: checked like every section; the password never shown."""

from __future__ import annotations

import logging
import re
import tomllib
from pathlib import Path

import pytest

from gateway.service.config import ConfigError, parse_config

EXAMPLE = Path(__file__).parents[2] / "deploy" / "cell.example.toml"
LOOP = {"name": "main", "port": "socket://127.0.0.1:5233", "controllers": [{"body": "1"}]}
MQTT = {"host": "broker", "group": "plant-1", "edge_node": "cell-07"}


def test_off_unless_configured_and_the_defaults() -> None:
    assert parse_config({"loops": [LOOP]}).mqtt is None
    mqtt = parse_config({"loops": [LOOP], "mqtt": MQTT}).mqtt
    assert mqtt is not None
    assert (mqtt.port, mqtt.commands, mqtt.tls, mqtt.keepalive) == (1883, False, False, 30)


def test_the_example_section_uncommented_is_valid() -> None:
    text = EXAMPLE.read_text()
    block = text[text.index("# [mqtt]") :].split("\n\n")[0]
    section = "\n".join(re.sub(r"^# ?", "", line) for line in block.splitlines())
    config = parse_config({"loops": [LOOP], **tomllib.loads(section)})
    assert config.mqtt is not None and config.mqtt.tls and config.mqtt.edge_node == "cell-07"


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"group": "plant/1"}, "mqtt.group"),
        ({"edge_node": "cell+"}, "mqtt.edge_node"),
        ({"edge_node": "a#"}, "mqtt.edge_node"),
        ({"port": 0}, "mqtt.port"),
        ({"ca_file": "/ca.pem"}, "mqtt"),
        ({"tls": True, "cert_file": "/c.pem"}, "mqtt"),
        ({"qos": 1}, "mqtt.qos"),
        ({"max_payload": 10}, "mqtt.max_payload"),
        ({"primary_host": "scada/1"}, "mqtt.primary_host"),
    ],
)
def test_bad_values_are_named(change: dict[str, object], key: str) -> None:
    with pytest.raises(ConfigError) as refused:
        parse_config({"loops": [LOOP], "mqtt": MQTT | change})
    assert f"  {key}:" in str(refused.value)


def test_the_password_is_never_shown(caplog: pytest.LogCaptureFixture) -> None:
    config = parse_config({"loops": [LOOP], "mqtt": MQTT | {"password": "s3cret-pw"}})
    assert config.mqtt is not None
    assert config.mqtt.password is not None
    assert config.mqtt.password.get_secret_value() == "s3cret-pw"
    with caplog.at_level(logging.DEBUG):
        logging.getLogger("gateway").info("config %r %s", config, config.mqtt)
    assert "s3cret-pw" not in repr(config) + str(config.mqtt) + caplog.text
