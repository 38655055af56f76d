"""The speed settings of an axis: read with the query forms, set with the manual's rules.

``OH``, ``OL``, ``OS`` and ``OC`` are per motor, ``OX`` is shared by both motors of a
controller (§10 F list, §10 OX). Answers carry what chapter 7 derives from them: fH and fL in
pps, the acceleration α in pps/s, the acceleration time tacc and the S parts' length ts
(``gateway.protocol.speeds.SpeedSettings``).

Setting refuses, before anything is sent, values outside the manual's ranges and the S-curve
inequality of §7-1 (the controller would answer '>' and ignore the value with a command error,
§10 OC/OH/OL). The controller checks that inequality whenever OH, OL or OC is set, against the
values it holds then, so a change that is valid in the end can be refused half-way (new OH
with the old OL and OC). When OH or OL change and an S-curve is in use, OC is therefore set to
0 first and to its new value last (X = 0 whenever OC = 0); the set commands and the queries that
read the result back form one transaction, so nothing else runs between them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from pydantic import BaseModel, Field

from gateway.bus.requests import ReplyKind, TransactionResult
from gateway.errors import ConflictError, DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.speeds import (
    SpeedSettings,
    speed_constraint_violation,
)

__all__ = [
    "QUERIES",
    "QUERIES_WHILE_MOVING",
    "SpeedView",
    "settings_from",
    "speed_view",
    "update_commands",
]

#: The reads of a speed view, in the order of ``SpeedSettings`` (§10 OH, OL, OS, OC, OX).
QUERIES: tuple[cmd.SpeedName, ...] = ("OH", "OL", "OS", "OC", "OX")
#: ``OC`` (the query too) is refused while a motor moves (§10 OC: 動作中 ×).
QUERIES_WHILE_MOVING: tuple[cmd.SpeedName, ...] = ("OH", "OL", "OS", "OX")


class SpeedView(BaseModel):
    """The speed data of one axis and what chapter 7 derives from them."""

    axis: str
    oh: int = Field(description="High speed data (§10 OH), 1-16,383")
    ol: int = Field(description="Low speed data (§10 OL), 1-16,383")
    os: int = Field(description="acceleration data (§10 OS), 1-32,767")
    oc: int = Field(description="S-curve rate in % (§10 OC), 0-100")
    ox: int = Field(description="frequency multiplier data (§10 OX), shared by both motors")
    ox_internal: int = Field(description="OX as the controller uses it: a multiple of 4 (§7-1)")
    multiplier: float = Field(description="300 / OX' (§7-1)")
    high_speed_pps: float = Field(description="fH = OH x 300 / OX' (§7-1)")
    low_speed_pps: float = Field(description="fL = OL x 300 / OX' (§7-1)")
    acceleration_pps2: float = Field(description="α = 1,474,560,000 / (OX' x OS) pps/s (§7-1)")
    acceleration_time_s: float = Field(
        description="tacc = |OH - OL| / (24,576 x (200 - OC)) x OS (§7-1)"
    )
    s_curve_time_s: float = Field(description="ts = OC / 200 x tacc (§7-1)")
    oc_cached: bool = Field(
        default=False, description="OC was not read now (refused while moving): the last read"
    )
    frames: list[str] = Field(
        default_factory=list, description="the setting frames a PUT sent (without the CR)"
    )


def speed_view(axis: str, s: SpeedSettings, *, oc_cached: bool = False) -> SpeedView:
    """The view of ``s``."""
    return SpeedView(
        axis=axis,
        oh=s.oh,
        ol=s.ol,
        os=s.os,
        oc=s.oc,
        ox=s.ox,
        ox_internal=s.ox_internal,
        multiplier=round(s.multiplier, 9),
        high_speed_pps=round(s.fh, 6),
        low_speed_pps=round(s.fl, 6),
        acceleration_pps2=round(s.acceleration, 6),
        acceleration_time_s=round(s.tacc, 9),
        s_curve_time_s=round(s.ts, 9),
        oc_cached=oc_cached,
    )


def settings_from(
    result: TransactionResult, names: Sequence[str], known_oc: int | None = None
) -> SpeedSettings:
    """The settings the query replies of ``result`` (for ``names``, in order) hold."""
    values: dict[str, int] = {}
    replies = result.results[-len(names) :]
    for name, reply in zip(names, replies, strict=True):
        if reply.kind is ReplyKind.SKIPPED:
            # Not sent: the motor could not be selected, a motor moves (§10 F). A conflict
            # with the motion, not a device fault (the cache saw the motion start late).
            raise ConflictError(
                f"{name} was not read ({reply.note or 'skipped'}): a motor of the controller "
                "moves and the motor cannot be selected then (§10 F)",
                field="axis",
            )
        if not isinstance(reply.value, int) or isinstance(reply.value, bool):
            raise DeviceError(
                f"{name} was not read ({reply.kind.value})",
                outcome="not_done",
                timeout=reply.kind.value == "timeout",
            )
        values[name.lower()] = reply.value
    if "oc" not in values and known_oc is not None:
        values["oc"] = known_oc
    try:
        return SpeedSettings(**values)
    except ValueError as exc:  # a value outside the manual's ranges: not from an RC-233
        raise DeviceError(f"the controller reported {values}: {exc}", outcome="unknown") from None


def update_commands(
    current: SpeedSettings, given: Mapping[str, int]
) -> tuple[SpeedSettings, list[Command]]:
    """The settings after the ``given`` speed data (``oh``, ``ol``, ``os``, ``oc``, ``ox``;
    the others keep their value) and the set commands that get there, in a safe order.

    ``InvalidInputError`` naming the field and the rule when the result breaks the S-curve
    inequality (§7-1, §10 OC/OH/OL).
    """
    if not given:
        raise InvalidInputError(
            "no speed data given", field="change", rule="give at least one of oh, ol, os, oc, ox"
        )
    new = SpeedSettings(**{**_as_dict(current), **given})
    violation = speed_constraint_violation(new.oh, new.ol, new.oc)
    if violation is not None:
        field = next((f for f in ("oc", "oh", "ol") if f in given), "oc")
        raise InvalidInputError(violation, field=field, rule=violation)
    commands: list[Command] = []
    # With OC = 0 the inequality holds whatever OH and OL are: clear an S-curve in use first.
    reset = current.oc > 0 and ("oh" in given or "ol" in given)
    if reset:
        commands.append(cmd.set_speed("OC", 0))
    for name in ("oh", "ol", "os", "ox"):
        if name in given:
            commands.append(cmd.set_speed(_SPEED_NAMES[name], given[name]))
    if ("oc" in given or reset) and not (reset and new.oc == 0):
        commands.append(cmd.set_speed("OC", new.oc))
    return new, commands


_SPEED_NAMES: dict[str, cmd.SpeedName] = {"oh": "OH", "ol": "OL", "os": "OS", "ox": "OX"}


def _as_dict(s: SpeedSettings) -> dict[str, int]:
    return {"oh": s.oh, "ol": s.ol, "os": s.os, "oc": s.oc, "ox": s.ox}
