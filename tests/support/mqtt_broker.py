"""A real mosquitto, a central Sparkplug subscriber and gateways as processes, for the tests.

``Broker``: Debian's mosquitto on a free loopback port with a generated configuration (the
test FAILS with the install command when it is missing); ``stop``/``start`` restart it on the
same port. ``Central``: an MQTT client on ``spBv1.0/#`` that decodes every payload with the
tests' own decoder (tests/mqtt/sparkplug_decoder.py), resolves aliases from the births, and
lets a test wait for a message matching a condition (woken by each message, no sleeping).
``Cell``: ``rc233-gateway serve --simulate`` as a process, with its ``[mqtt]`` section given
through the environment (``RC233_MQTT``, the configuration's override of a top-level key) and
the simulator's control surface to press EMS or cut the line.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import pwd
import shutil
import signal
import socket
import ssl
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

from tests.mqtt.sparkplug_decoder import Metric, Payload, decode
from tests.support.ws_events import sim_control

GATEWAY = Path(sys.executable).parent / "rc233-gateway"
#: Real seconds a test waits for something it expects from a broker or a gateway.
WAIT = 20.0


def free_port() -> int:
    """A TCP port free on loopback now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _access(workdir: Path, users: dict[str, str] | None) -> str:
    # run as root, mosquitto becomes user "mosquitto", who cannot read the test's directory
    user = f"user {pwd.getpwuid(os.getuid()).pw_name}\n"
    if not users:
        return "allow_anonymous true\n" + user
    passwords = workdir / "passwords"
    passwords.touch()
    for name, password in users.items():
        subprocess.run(["mosquitto_passwd", "-b", str(passwords), name, password], check=True)
    return f"allow_anonymous false\npassword_file {passwords}\n" + user


class Broker:
    """mosquitto on 127.0.0.1:``port``."""

    def __init__(self, workdir: Path, users: dict[str, str] | None = None, tls: str = "") -> None:
        """``users``: name -> password; then nobody else may connect. ``tls``: the
        listener's ``cafile``/``certfile``/``keyfile`` lines."""
        binary = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
        if not Path(binary).exists():
            pytest.fail("mosquitto is not installed: apt-get install -y mosquitto (make test does)")
        self.binary = binary
        self.port = free_port()
        self.conf = workdir / "mosquitto.conf"
        self.conf.write_text(
            f"listener {self.port} 127.0.0.1\n{tls}persistence false\n"
            + _access(workdir, users)
            + "log_dest stderr\nlog_type error\nlog_type warning\nlog_type notice\n"
            "log_type information\n"
        )
        self.process: asyncio.subprocess.Process | None = None

    async def start(self) -> None:
        """Start it and wait for its "running" line."""
        self.process = await asyncio.create_subprocess_exec(
            self.binary, "-c", str(self.conf), stderr=asyncio.subprocess.PIPE
        )
        assert self.process.stderr is not None
        seen = []
        try:
            async with asyncio.timeout(WAIT):
                while True:
                    line = (await self.process.stderr.readline()).decode()
                    seen.append(line)
                    assert line, f"mosquitto ended: {''.join(seen)}"
                    if " running" in line:
                        break
        except BaseException:
            await self.stop()  # leave no broker behind
            raise
        asyncio.get_running_loop().create_task(self._drain(self.process))

    @staticmethod
    async def _drain(process: asyncio.subprocess.Process) -> None:
        assert process.stderr is not None
        while await process.stderr.readline():
            pass

    async def stop(self) -> None:
        """SIGTERM and wait."""
        if self.process is not None and self.process.returncode is None:
            self.process.terminate()
            await asyncio.wait_for(self.process.wait(), WAIT)
        self.process = None


@dataclass
class Received:
    """One message the central subscriber got."""

    topic: str
    kind: str  # NBIRTH, DDATA ...
    node: str
    device: str | None
    payload: Payload
    at: float  # wall clock when it arrived
    payload_bytes: bytes = b""
    #: metric name -> value (None: null)
    values: dict[str, Any] = field(default_factory=dict)


class Central:
    """The plant's view: one subscriber on every Sparkplug topic of the broker."""

    def __init__(self, port: int, identifier: str = "central",
                 login: tuple[str, str] | None = None,
                 tls: ssl.SSLContext | None = None) -> None:  # fmt: skip
        self.port, self.identifier, self.login, self.tls = port, identifier, login, tls
        self.messages: list[Received] = []
        self.aliases: dict[tuple[str, int], str] = {}  # (node, alias) -> metric name
        self._new = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self.client: aiomqtt.Client | None = None

    async def __aenter__(self) -> Central:
        await self.connect()
        return self

    async def connect(self) -> None:
        """Connect (again) and subscribe."""
        user, password = self.login or (None, None)
        self.client = aiomqtt.Client(
            "127.0.0.1", self.port, identifier=self.identifier, username=user, password=password,
            tls_context=self.tls,
        )  # fmt: skip
        await self.client.__aenter__()
        await self.client.subscribe("spBv1.0/#", qos=1)
        self._task = asyncio.create_task(self._read(self.client))

    async def __aexit__(self, *exc: object) -> None:
        await self.disconnect()

    async def disconnect(self) -> None:
        """Stop reading and close the connection (the broker may be gone already)."""
        assert self._task is not None and self.client is not None
        self._task.cancel()
        with contextlib.suppress(BaseException):
            await self._task
        with contextlib.suppress(aiomqtt.MqttError):
            await self.client.__aexit__(None, None, None)

    async def _read(self, client: aiomqtt.Client) -> None:
        async for message in client.messages:
            parts = str(message.topic).split("/")
            assert isinstance(message.payload, bytes)
            if parts[1] == "STATE":  # a host application's JSON, not a Sparkplug payload
                continue
            payload = decode(message.payload)
            kind, node = parts[2], parts[3]
            device = parts[4] if len(parts) > 4 else None
            values = {}
            for m in payload.metrics:
                if m.name is not None and m.alias is not None:
                    self.aliases[node, m.alias] = m.name
                name = m.name or self.aliases.get((node, m.alias or -1), f"?{m.alias}")
                values[name] = None if m.is_null else m.value
            received = Received(
                str(message.topic), kind, node, device, payload, time.time(),
                message.payload, values,
            )  # fmt: skip
            self.messages.append(received)
            self._new.set()

    async def publish(self, topic: str, payload: bytes) -> None:
        """Publish (an NCMD or DCMD)."""
        assert self.client is not None
        await self.client.publish(topic, payload, qos=0)

    async def wait_for(
        self, kind: str, *, node: str | None = None, device: str | None = None,
        since: int = 0, where: Any = None, timeout: float = WAIT,
    ) -> Received:  # fmt: skip
        """The first message from index ``since`` on of ``kind`` (node, device) for which
        ``where(message)`` holds; fails after ``timeout`` real seconds."""
        i = since
        async with asyncio.timeout(timeout):
            while True:
                while i < len(self.messages):
                    m = self.messages[i]
                    i += 1
                    if m.kind != kind or (node and m.node != node):
                        continue
                    if device is not None and m.device != device:
                        continue
                    if where is None or where(m):
                        return m
                self._new.clear()
                await self._new.wait()

    async def identified(self, node: str, device: str) -> None:
        """Until the controller ``device`` of ``node`` is identified (its mode read): in its
        birth when it was read before, else in a DDATA after the birth (a line worker may
        read it either side of the birth)."""
        birth = await self.wait_for("DBIRTH", node=node, device=device)
        if birth.values.get("Mode") is None:
            await self.wait_for(
                "DDATA", node=node, device=device,
                where=lambda m: m.values.get("Mode") is not None,
            )  # fmt: skip

    def mark(self) -> int:
        """The index of the next message (for ``since``)."""
        return len(self.messages)

    def of(self, node: str, since: int = 0) -> list[Received]:
        """The messages of ``node`` from ``since``."""
        return [m for m in self.messages[since:] if m.node == node]


def metric(message: Received, name: str) -> Metric:
    """A metric of a birth by name."""
    found = [m for m in message.payload.metrics if m.name == name]
    assert found, f"{name} not in {message.kind} {message.topic}: {sorted(message.values)}"
    return found[0]


class Cell:
    """``rc233-gateway serve --simulate`` with an edge node, as a process."""

    def __init__(self, broker_port: int, node: str, *, group: str = "plant",
                 time_scale: float = 5.0, extra: dict[str, Any] | None = None,
                 env: dict[str, str] | None = None) -> None:  # fmt: skip
        self.node, self.group = node, group
        self.http = free_port()
        self.control_port = free_port()
        self.mqtt = {"host": "127.0.0.1", "port": broker_port, "group": group,
                     "edge_node": node, "reconnect_min": 0.2, "reconnect_max": 1.0,
                     **(extra or {})}  # fmt: skip
        self.time_scale = time_scale
        self.env = env or {}  # more environment (RC233_STATE_DIR: a state kept across starts)
        self.process: asyncio.subprocess.Process | None = None

    async def start(self, workdir: Path) -> None:
        """Start the process; its edge node connects by itself."""
        env = {**os.environ, "RC233_MQTT": json.dumps(self.mqtt), "XDG_DATA_HOME": str(workdir),
               **self.env}  # fmt: skip
        self.process = await asyncio.create_subprocess_exec(
            str(GATEWAY), "serve", "--simulate", "--no-auth", "--port", str(self.http),
            "--time-scale", str(self.time_scale), "--eeprom-dir", str(workdir),
            "--control", f"127.0.0.1:{self.control_port}",
            stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.DEVNULL, env=env,
        )  # fmt: skip

    async def control(self, **request: Any) -> dict[str, Any]:
        """One request to the simulator's control surface."""
        return await sim_control(self.control_port, **request)

    async def move(self, axis: str, position: int) -> None:
        """``POST /api/v1/axes/{axis}/move`` (pulses) through the REST API."""
        body = json.dumps({"position": position, "unit": "pulse"}).encode()
        reader, writer = await asyncio.wait_for(
            asyncio.open_connection("127.0.0.1", self.http), WAIT
        )
        try:
            writer.write(
                f"POST /api/v1/axes/{axis}/move HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                f"Connection: close\r\nContent-Type: application/json\r\n"
                f"Content-Length: {len(body)}\r\n\r\n".encode()
                + body
            )
            answer = await asyncio.wait_for(reader.read(), WAIT)
        finally:
            writer.close()
        assert answer.split(b" ", 2)[1] in (b"200", b"202"), answer

    def kill(self) -> None:
        """SIGKILL: no NDEATH of its own, the broker's will must tell."""
        assert self.process is not None
        self.process.kill()

    async def stop(self) -> None:
        """SIGTERM (a clean NDEATH) and wait for the end."""
        if self.process is not None and self.process.returncode is None:
            self.process.send_signal(signal.SIGTERM)
            await asyncio.wait_for(self.process.wait(), WAIT)


def seqs_in_order(messages: list[Received]) -> list[int]:
    """The ``seq`` of one node's messages from its NBIRTH on; fails on a gap or a repeat."""
    seqs: list[int] = []
    for m in messages:
        if m.kind == "NDEATH":  # the will carries no seq
            continue
        assert m.payload.seq is not None, m.topic
        if m.kind == "NBIRTH":
            assert m.payload.seq == 0
        elif seqs:
            assert m.payload.seq == (seqs[-1] + 1) % 256, (m.topic, seqs[-5:], m.payload.seq)
        seqs.append(m.payload.seq)
    return seqs
