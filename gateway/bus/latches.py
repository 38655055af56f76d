"""Latched errors: which axes show one, and how reads add to and clients clear the latches.

``""`` and ``9`` report errors of the controller, not of a motor, and clear them after the
reply (§10 "" 注意点, §10 9 ①), so the cache latches them per controller until a client
acknowledges them; each ``Latch`` carries the axes that show it (docs/manual-notes.md,
"Latched errors and axes"). Pure functions of the controller's record: the cache stores and
publishes what they return.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import replace

from gateway.bus.state_types import AXIS_ERRORS, MOTORS, ControllerState, ErrorKind, Latch

__all__ = ["axes_for", "error_motor", "latch_errors", "unlatch"]


def error_motor(ctl: ControllerState) -> int | None:
    """The motor a controller-wide limit or step-out error belongs to; None = unknown.

    While a motor moves it is the selected one (F cannot change during a move, §10 F); after
    a move the one that moved last; else the selected motor.
    """
    if ctl.moving and ctl.selected_motor is not None:
        return ctl.selected_motor
    return ctl.last_moved or ctl.selected_motor


def axes_for(kind: ErrorKind, ctl: ControllerState) -> frozenset[int]:
    """The axes that show a newly read error of ``kind`` (none for controller-only kinds)."""
    if kind is ErrorKind.LIMIT:
        motor = error_motor(ctl)
        return frozenset(MOTORS) if motor is None else frozenset({motor})
    if kind in AXIS_ERRORS:  # EMS is common to both motors (§10 EA); a command error names none
        return frozenset(MOTORS)
    return frozenset()


def latch_errors(
    ctl: ControllerState, kinds: Iterable[ErrorKind], now: float, source: str
) -> dict[ErrorKind, Latch]:
    """``ctl``'s latches after a read (the reply to ``source``) reported ``kinds`` at ``now``."""
    latched = dict(ctl.latched)
    for kind in kinds:
        axes = axes_for(kind, ctl)
        old = latched.get(kind)
        if old is None:
            latched[kind] = Latch(kind, axes, now, now, 1, source)
        else:
            latched[kind] = replace(
                old, axes=old.axes | axes, last=now, count=old.count + 1, source=source
            )
    return latched


def unlatch(
    latched: Mapping[ErrorKind, Latch],
    *,
    motor: int | None,
    kinds: Iterable[ErrorKind] | None,
) -> tuple[dict[ErrorKind, Latch], list[ErrorKind]]:
    """The latches left after an acknowledge, and the kinds no longer latched.

    ``kinds`` None: all. With ``motor`` only that axis stops showing them; an error clears
    when no axis shows it any more, so controller-only kinds need ``motor`` None.
    """
    wanted = set(ErrorKind) if kinds is None else set(kinds)
    left_over = dict(latched)
    cleared: list[ErrorKind] = []
    for kind in [k for k in left_over if k in wanted]:
        if motor is None:
            cleared.append(kind)
            del left_over[kind]
        elif motor in left_over[kind].axes:
            left = left_over[kind].axes - {motor}
            if left:
                left_over[kind] = replace(left_over[kind], axes=left)
            else:
                cleared.append(kind)
                del left_over[kind]
    return left_over, cleared
