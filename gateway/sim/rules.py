"""The manual's rules a command must pass before its handler runs (§9-1 注意, §10, §11-3).

A command that breaks one is ignored with the command-error flag: a host command refused while
a user program runs (§11-3 5.), a form not usable in the mode (§10 E, the E0/E1/E2 columns), a
form not usable while a motor moves (the 動作中 column; every motion command, because the two
motors never move together, §2, §3-II).
"""

from __future__ import annotations

from gateway.protocol.command_text import REGISTRY
from gateway.protocol.models import Command
from gateway.protocol.spec import Effect, Form
from gateway.sim.controller_view import ControllerView
from gateway.sim.dispatch import Refused

__all__ = ["check_rules"]

#: Forms the catalog keeps the gateway from sending while moving, which the device still takes:
#: §10 2 注意点, form II while moving stores the start point of the move (manual-notes.md,
#: "While moving: the △ rows").
_TAKEN_WHILE_MOVING: frozenset[Form] = frozenset({REGISTRY.form("2")})


def check_rules(ctl: ControllerView, command: Command, now: float, *, host: bool = True) -> None:
    """``Refused`` when ``command`` breaks a rule; ``host`` False for a program statement."""
    spec, form = command.spec, command.form
    if host and not spec.while_program and ctl.rt.program_running:
        raise Refused("not usable while a user program runs (§11-3 5.)")
    if ctl.settings.shared.mode not in spec.form_modes(form):
        raise Refused(f"not usable in mode {ctl.settings.shared.mode} (§10 E)")
    restricted = form.effect is Effect.MOTION or not spec.form_while_moving(form)
    moving = ctl.moving_motor(now) is not None
    if restricted and moving and command.form not in _TAKEN_WHILE_MOVING:
        raise Refused("not usable while a motor moves (§2, §9-1 注意)")
