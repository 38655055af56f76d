"""Every host form of the catalog reaches a handler, and every valid command gets a valid reply.

The replies are checked with the gateway's own decoders: a query handler that returned the
wrong kind of value, or a setting the simulator could not store, would show here as an
exception or a reply the gateway cannot read.
"""

from __future__ import annotations

import re
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gateway.protocol.command_text import REGISTRY, Entry
from gateway.protocol.params import Position, PositionFormat
from gateway.protocol.replies import decode_reply
from gateway.sim.dispatch import missing_handlers
from tests.sim.direct import Direct
from tests.support.strategies import form_values

HOST_ENTRIES = [e for e in REGISTRY.entries if not e.spec.program_only]
#: Forms after which the harness would stop answering for a while or change the line.
SPECIAL = {"EE///", "I", "ES{bp}", "EE1", "EL1", "SUM1"}
DATA_REPLY = re.compile(rb">\$1(?P<data>[^\r]*)\r")


def test_every_host_form_has_a_handler() -> None:
    assert missing_handlers() == []


def _build(entry: Entry, values: dict[str, Any], fmt: PositionFormat) -> str:
    signed = fmt is PositionFormat.SIGNED
    if entry.form.has_positions:
        low, high = fmt.bounds
        for p in entry.form.params:
            if isinstance(p, Position):
                values[p.name] = min(max(values[p.name], low), high)
        values["signed"] = signed
    model = entry.model.model_validate(values, context={"positions": fmt})
    return model.wire()


@pytest.mark.parametrize("entry", HOST_ENTRIES, ids=lambda e: e.key)
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_a_valid_command_gets_a_reply_the_gateway_can_read(entry: Entry, data: Any) -> None:
    if entry.key in SPECIAL:
        return  # their own tests cover them: they change what the next frame must look like
    direct = Direct()
    mode = data.draw(st.sampled_from(sorted(entry.spec.form_modes(entry.form))))
    fmt = data.draw(st.sampled_from(list(PositionFormat)))
    direct.cmd(f"E{mode}")
    direct.cmd("EP1" if fmt is PositionFormat.SIGNED else "EP0")
    direct.cmd("")  # clears the flags
    fmt = PositionFormat.SIGNED if mode == 1 else fmt
    text = _build(entry, data.draw(form_values(entry)), fmt)
    reply = direct.cmd(text)
    if entry.form.reply.has_data:
        match = DATA_REPLY.fullmatch(reply)
        assert match, f"{text!r} -> {reply!r}"
        decode_reply(entry.form.reply, match["data"].decode("latin-1"))
    else:
        assert reply == b">", f"{text!r} -> {reply!r}"
