"""The simulator's control surface: JSON lines over TCP, and the Python API behind it.

Tests and demos drive the simulated loop from outside the serial line: they inject faults,
press EMS, force sensors, switch controllers off and on, turn body switches. ``Controls`` is
the Python API (in-process tests call it directly); ``serve_control`` offers the same over TCP,
one JSON object per line each way::

    -> {"op": "ems", "body": "1", "pressed": true}
    <- {"ok": true}
    -> {"op": "nope"}
    <- {"ok": false, "error": "unknown op 'nope'"}

``body`` names a controller by its body switch, or else by the body number it was started
with (a unit keeps that name when its switch is turned). Times are simulated seconds.

Ops (``Controls`` method of the same name in brackets where it differs):

=================  ==============================================================  =========
op                 fields                                                          effect
=================  ==============================================================  =========
``state``          -                                                               line and
                                                                                   controllers
``trace``          ``since`` (record number, default 0)                            records
``baud``           ``baud`` (bit/s)                                                line rate
``cut``            ``cut`` (default true), ``hold`` (s, optional)                  line cut
``power``          ``body``, ``on``                                                off / on
``power_cycle``    ``body``, ``off_for`` (s, default 0)                            off + on
``switch``         ``body``, ``to`` (0-9, A-F): read at the next power-on          body
``ems``            ``body``, ``pressed``                                           EMS
``sensor``         ``body``, ``motor``, ``sensor``, ``on`` (true/false/null)       force
``slip``           ``body``, ``motor``, ``pulses``                                 step-out
``preset``         ``body``, ``motor``, ``position``: the counter reads it there   preset
``input``          ``body``, ``bit`` (0-7; 8, 9: INP1, INP2), ``on``               input
``inp``            ``body``, ``motor``, ``on`` (true/false/null)                   servo INP
``fault``          ``kind`` and ``faults.FaultRule`` fields; neither               arm rule
                   ``probability`` nor ``shots``: one shot
``clear_faults``   ``kind``, ``body`` (both optional)                              disarm
=================  ==============================================================  =========

``fault`` kinds: nak, drop, garble, late (on the next replies) and power, ems, sensor, slip,
cut (after the next replies); see ``gateway.sim.faults``.

``slip`` is what step-out detection sees (§10 QS: the dog in modes 0 and 2, the encoder in
mode 1 and with QSE). ``inp`` drives mode 2's servo driver (§10 CI, §10 DS ③): ``true`` gives
INP, ``false`` holds it OFF (a motion then ends in a limit error 3 s after its last pulse),
``null`` lets the driver report INP by itself, ``inp_delay`` seconds (the scene) after the last
pulse. ``input`` bits 8 and 9 are INP used as general inputs (modes 0, 1: §10 C).
"""

from __future__ import annotations

import asyncio
import json
import logging
import socket
from collections.abc import Callable
from typing import Any

from gateway.protocol.framing import BODY_NUMBERS
from gateway.sim.clock import RecordKind
from gateway.sim.controller import Controller
from gateway.sim.faults import FaultKind, FaultRule
from gateway.sim.loop import INSPECTION, SimLoop, Unit

__all__ = ["UART_RATES", "ControlError", "Controls", "serve_control"]

log = logging.getLogger("gateway.sim")

#: Rates a host UART can be set to (the RC-233 itself knows 9600, 1200 and 300, §10 ES).
UART_RATES = frozenset({300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200})
_RULE_FIELDS = {"body", "probability", "shots", "delay", "hold", "motor", "sensor", "on", "pulses"}


class ControlError(ValueError):
    """A control request that cannot be carried out (the reply's ``error``)."""


class Controls:
    """Operations on a running ``SimLoop``; each acts at the loop's current simulated time."""

    def __init__(self, loop: SimLoop) -> None:
        self.loop = loop

    def _unit(self, body: str) -> Unit:
        try:
            return self.loop.unit(str(body))
        except KeyError as exc:
            raise ControlError(exc.args[0]) from None

    def state(self) -> dict[str, Any]:
        """The line and every controller (``Controller.snapshot``)."""
        return self.loop.state()

    def trace(self, since: int = 0) -> list[dict[str, Any]]:
        """The line records from number ``since`` on (bytes as latin-1 text)."""
        return [
            {
                "seq": r.seq,
                "time": r.time,
                "kind": r.kind.value,
                "data": r.data.decode("latin-1"),
                "body": r.body,
                "ref": r.ref,
                "note": r.note,
                "late": r.late,
            }
            for r in self.loop.log.since(since)
        ]

    def baud(self, baud: int) -> None:
        """Set the line's rate (the host's); controllers at another rate hear noise."""
        if baud not in UART_RATES:
            raise ControlError(f"baud must be one of {sorted(UART_RATES)}")

        def change(now: float) -> None:
            self.loop.baud = baud
            self.loop.log.add(now, RecordKind.BAUD, note=str(baud))

        self.loop.act(change)

    def cut(self, cut: bool = True, hold: float | None = None) -> None:
        """Cut the line (``hold``: for that long) or restore it."""
        if hold is not None and cut:
            self.loop.act(lambda now: self.loop.cut_for(hold, now))
        else:
            self.loop.act(lambda now: self.loop.set_cut(cut, now))

    def power(self, body: str, on: bool) -> None:
        """Switch a controller off or on (on: a power-on with its body switch)."""
        unit = self._unit(body)
        self.loop.act(lambda now: self.loop.power(unit, on, now))

    def power_cycle(self, body: str, off_for: float = 0.0) -> None:
        """Switch a controller off, and on again ``off_for`` seconds later."""
        unit = self._unit(body)
        self.loop.act(lambda now: self.loop.power_cycle(unit, now, off_for))

    def switch(self, body: str, to: str) -> None:
        """Turn a body switch; the controller reads it at its next power-on (§3-III, §10 ES)."""
        unit = self._unit(body)
        if len(to) != 1 or to not in BODY_NUMBERS + INSPECTION:
            raise ControlError(f"a body switch is one of 0-9, A-F, not {to!r}")
        if to != INSPECTION and any(u.switch == to for u in self.loop.units if u is not unit):
            raise ControlError(f"another controller's switch is already at {to}")
        unit.switch = to

    def ems(self, body: str, pressed: bool) -> None:
        """Press or release a controller's emergency stop."""
        self._on_device(body, lambda u, now: u.device.set_ems(now, pressed))

    def sensor(self, body: str, motor: int, sensor: str, on: bool | None) -> None:
        """Force a sensor ON or OFF, or give it back to the scene (None)."""
        self._check_motor(motor)
        self._on_device(body, lambda u, now: u.device.force_sensor(now, motor, sensor, on))

    def slip(self, body: str, motor: int, pulses: int) -> None:
        """Make a motor lose ``pulses`` (step-out)."""
        self._check_motor(motor)
        self._on_device(body, lambda u, now: u.device.slip(now, motor, pulses))

    def preset(self, body: str, motor: int, position: int) -> None:
        """Set a motor's position counter without motion, as an ``R`` the gateway did not send
        does (a user program's, a second host's during commissioning); refused while that
        motor moves, as ``R`` is (§10 R)."""
        self._check_motor(motor)

        def act(unit: Unit, now: float) -> None:
            try:
                unit.device.preset(now, motor, position)
            except ValueError as exc:
                raise ControlError(f"controller {body}: {exc}") from None

        self._on_device(body, act)

    def input(self, body: str, bit: int, on: bool) -> None:
        """Drive general input ``bit`` (0-7), or INP1/INP2 as bits 8 and 9 (§10 C)."""
        if bit not in range(10):
            raise ControlError("bit must be 0-7, or 8/9 for INP1/INP2")
        self._on_device(body, lambda u, now: u.device.set_input(now, bit, on))

    def inp(self, body: str, motor: int, on: bool | None) -> None:
        """Mode 2: give a motor's servo INP (True), hold it OFF (False), or let it be (None)."""
        self._check_motor(motor)

        def act(unit: Unit, now: float) -> None:
            device = unit.device
            if not isinstance(device, Controller):  # pragma: no cover - only Controllers exist
                raise ControlError("this device has no servo INP")
            device.set_inp(now, motor, on)

        self._on_device(body, act)

    def fault(self, kind: str, **fields: Any) -> dict[str, Any]:
        """Arm a fault rule; without ``probability`` and ``shots`` it is a one-shot."""
        unknown = set(fields) - _RULE_FIELDS
        if unknown:
            raise ControlError(f"unknown fault fields {sorted(unknown)}")
        if "probability" not in fields and "shots" not in fields:
            fields["shots"] = 1
        if fields.get("body") is not None:
            fields["body"] = str(fields["body"])
        try:
            rule = FaultRule(FaultKind(kind), **fields)
        except (ValueError, TypeError) as exc:
            raise ControlError(str(exc)) from None
        self.loop.act(lambda now: self.loop.faults.add(rule))
        return {"rules": len(self.loop.faults.rules)}

    def clear_faults(self, kind: str | None = None, body: str | None = None) -> dict[str, Any]:
        """Disarm rules (all, or of one kind and/or controller); how many were removed."""
        try:
            fault = FaultKind(kind) if kind is not None else None
        except ValueError as exc:
            raise ControlError(str(exc)) from None
        return {"removed": self.loop.faults.clear(fault, None if body is None else str(body))}

    @staticmethod
    def _check_motor(motor: int) -> None:
        if motor not in (1, 2):
            raise ControlError("motor must be 1 or 2")

    def _on_device(self, body: str, action: Callable[[Unit, float], None]) -> None:
        unit = self._unit(body)
        if not unit.on or unit.inspecting:
            raise ControlError(f"controller {body} is off or in inspection mode")
        self.loop.act(lambda now: action(unit, now))

    # ------------------------------------------------------------------ JSON

    def handle(self, request: dict[str, Any]) -> dict[str, Any]:
        """Carry out one JSON request; the reply always has ``ok``."""
        params = dict(request)
        op = params.pop("op", None)
        method = _OPS.get(op) if isinstance(op, str) else None
        if method is None:
            return {"ok": False, "error": f"unknown op {op!r}"}
        try:
            result = method(self, **params)
        except ControlError as exc:
            return {"ok": False, "error": str(exc)}
        except TypeError as exc:  # missing or unexpected fields
            return {"ok": False, "error": f"{op}: {exc}"}
        if result is None:
            return {"ok": True}
        if op in ("state", "trace"):
            return {"ok": True, op: result}
        return {"ok": True, **result}


_OPS: dict[str, Callable[..., Any]] = {
    "state": Controls.state,
    "trace": Controls.trace,
    "baud": Controls.baud,
    "cut": Controls.cut,
    "power": Controls.power,
    "power_cycle": Controls.power_cycle,
    "switch": Controls.switch,
    "ems": Controls.ems,
    "sensor": Controls.sensor,
    "slip": Controls.slip,
    "preset": Controls.preset,
    "input": Controls.input,
    "inp": Controls.inp,
    "fault": Controls.fault,
    "clear_faults": Controls.clear_faults,
}


async def _client(
    controls: Controls, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
) -> None:
    try:
        while line := await reader.readline():
            try:
                request = json.loads(line)
                if not isinstance(request, dict):
                    raise ValueError("a request is a JSON object")
            except ValueError as exc:
                reply: dict[str, Any] = {"ok": False, "error": f"bad request: {exc}"}
            else:
                reply = controls.handle(request)
            writer.write(json.dumps(reply).encode() + b"\n")
            await writer.drain()
    except (ConnectionError, asyncio.IncompleteReadError):
        pass
    finally:
        writer.close()


async def serve_control(controls: Controls, host: str, port: int) -> asyncio.Server:
    """Serve the JSON-lines control surface on ``host:port`` (any number of clients)."""

    async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await _client(controls, reader, writer)

    server = await asyncio.start_server(client, host, port)
    log.info("control surface on %s:%d", host, port)
    return server


async def serve_control_on(controls: Controls, sock: socket.socket) -> asyncio.Server:
    """Serve the control surface on a socket already listening (bound by another process,
    which keeps the port while this one comes and goes)."""

    async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await _client(controls, reader, writer)

    server = await asyncio.start_server(client, sock=sock)
    host, port = sock.getsockname()[:2]
    log.info("control surface on %s:%d", host, port)
    return server
