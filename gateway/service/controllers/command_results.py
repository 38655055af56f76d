"""Transaction results as clients read them: the decoded reply as JSON, outcome, wire frames.

``POST /controllers/{id}/commands`` and ``POST /loops/{loop}/raw`` answer with a
``CommandResponse``; the controller resources (position table, I/O, programs ...) carry the
same ``frames`` and ``outcome`` so that the audit log and a client both see what went out.

A reply value is one of the typed values of ``gateway.protocol.reply_values`` (or an int, or
the program text); ``reply_json`` writes it as plain JSON: dataclasses as objects, a port
byte as its value, hex text and the bits that are ON, enums as their manual spelling.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Annotated, Any

from pydantic import BaseModel, Field, WithJsonSchema

from gateway.bus.requests import CommandResult, ReplyKind, TransactionResult
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_values import Contact, ErrorWatch, PortByte, ProgramState
from gateway.service.topology import ControllerRef
from gateway.service.views import wall_time

__all__ = [
    "REPLY_VALUE_SCHEMA",
    "VALUE_DOC",
    "CommandResponse",
    "CommandView",
    "port_json",
    "reply_json",
    "response_of",
]

#: What ``value`` holds for each reply format (OpenAPI description of ``CommandView.value``).
VALUE_DOC = (
    "The decoded reply (null for a '>' reply). Its shape follows `reply_format`: "
    "`status` {moving, limit_error, emergency_stop, command_error}; `condition` "
    "{communication_error, limit_error, emergency_stop, command_error, mode, step_out, "
    "selected_motor}; `position`, `digit`, `dec3`, `dec5`, `condition_bit` an integer; "
    "`inputs`, `outputs`, `buffer` a port byte {value, hex, on}; `inputs_inp` {inp1, inp2, "
    "inputs}; `outputs_clr` {clr1, clr2, outputs}; `sensors` {cw_limit, ccw_limit, org, "
    "emergency_stop, step_out_sensor}; `sensor_logic` {step_out_sensor, limit, org, "
    "emergency_stop, inp} each 'A' or 'B'; `clr_state` {clr1, clr2}; `motor_pair` {motor1, "
    "motor2}; `error_output` {watch, outputs}; `speed_point` {speed, remaining}; "
    "`program_state` '1' running, '0' ended, 'P' paused, 'E' ended by an error; "
    "`program_text` the program text; `version` {version, stamp}."
)


_SCALAR: list[dict[str, Any]] = [{"type": "integer"}, {"type": "string"}, {"type": "boolean"}]
_PORT_BYTE: dict[str, Any] = {
    "type": "object",
    "title": "PortByteValue",
    "properties": {
        "value": {"type": "integer", "minimum": 0, "maximum": 255},
        "hex": {"type": "string", "pattern": "^[0-9A-F]{2}$"},
        "on": {"type": "array", "items": {"type": "integer", "minimum": 0, "maximum": 7}},
    },
    "required": ["value", "hex", "on"],
    "additionalProperties": False,
}
#: The JSON Schema of ``reply_json``'s output (what ``VALUE_DOC`` lists): null, a scalar, a
#: port byte, or an object whose members are scalars or port bytes.
REPLY_VALUE_SCHEMA: dict[str, Any] = {
    "anyOf": [
        {"type": "null"},
        *_SCALAR,
        _PORT_BYTE,
        {
            "type": "object",
            "title": "ReplyFields",
            "additionalProperties": {"anyOf": [{"type": "null"}, *_SCALAR, _PORT_BYTE]},
        },
    ]
}


def port_json(value: PortByte) -> dict[str, Any]:
    """A port byte: its value, the two hex digits DU DL, and the bit numbers that are ON."""
    return {"value": value.value, "hex": f"{value.value:02X}", "on": sorted(value.on)}


def reply_json(value: ReplyValue | PortByte | None) -> Any:
    """``value`` as plain JSON (see the module docstring)."""
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, PortByte):
        return port_json(value)
    if isinstance(value, ErrorWatch):
        return int(value)
    if isinstance(value, Contact):
        return value.name
    if isinstance(value, ProgramState):
        return value.value
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, int):
        return value
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: reply_json(getattr(value, f.name)) for f in dataclasses.fields(value)}
    return str(value)


class CommandView(BaseModel):
    """One command of a transaction and what became of it."""

    command: str = Field(description="the command text as sent (between body number and CR)")
    form: str = Field(description="the catalog form (its syntax), e.g. `OH{hs}`")
    mnemonic: str
    reply: ReplyKind = Field(description="what came back (after any retries)")
    outcome: str = Field(description="done, not_done or unknown (whether it took effect)")
    reply_format: str = Field(description="the shape of the reply's data")
    value: Annotated[Any, WithJsonSchema(REPLY_VALUE_SCHEMA)] = Field(None, description=VALUE_DOC)
    attempts: int
    late: bool = Field(description="the reply came after its time-out")
    note: str = ""


class CommandResponse(BaseModel):
    """The result of a transaction: every command's reply, its outcome and the frames sent."""

    loop: str
    controller: str = Field(description="the controller's id, loop.body")
    outcome: str = Field(description="done when every command is done, else the first other")
    results: list[CommandView]
    frames: list[str] = Field(
        description="the request's frames as written (start mark, body number, text); the "
        "scheduler's own selection (F) and read-backs are on the line trace"
    )
    exchanges: int = Field(description="frames the scheduler sent, its own included")
    started: float | None = Field(description="seconds since the epoch")
    ended: float | None


def _view(result: CommandResult) -> CommandView:
    command = result.command
    return CommandView(
        command=command.wire(),
        form=command.key,
        mnemonic=command.mnemonic,
        reply=result.kind,
        outcome=result.outcome.value,
        reply_format=command.reply_format.value,
        value=reply_json(result.value),
        attempts=result.attempts,
        late=result.late,
        note=result.note,
    )


def response_of(ref: ControllerRef, result: TransactionResult) -> CommandResponse:
    """The client's view of ``result``."""
    return CommandResponse(
        loop=ref.loop,
        controller=ref.id,
        outcome=result.outcome.value,
        results=[_view(r) for r in result.results],
        frames=result.frames,
        exchanges=result.exchanges,
        started=wall_time(result.started),
        ended=wall_time(result.ended),
    )
