"""Local and remote control (the idea of SEMI E30's control state) of controllers and loops.

A technician at a machine locks out remote motion by putting its controller in ``local``:

* an admin does it through the API, for one controller or for every controller of a loop
  (``PUT /controllers/{id}/control``, ``PUT /loops/{loop}/control``);
* or a key switch wired to a general input of the controller does it (``local_input`` in the
  configuration, read with ``C`` by ``gateway.service.runtime.key_switch``).

A controller is ``local`` while any of these holds (its ``sources`` say which, by whom and
since when); ``remote`` when none does. A configured key switch not read yet counts as local:
the gateway cannot know where the switch stands, and the safe guess for a lock-out is "on".
In ``local``, ``check`` refuses (409) every motion and setting from the network; stops are
never checked (``AxisService.stop``, ``StopAll`` and the stop forms of ``CommandRunner``).

Every change of a controller's state is a ``control`` service event (the WebSocket feed turns
it into a change of the controller's and axes' views, then the event) and goes to the
listeners (the audit log, for the key switch; an admin's change is its request's entry).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from types import MappingProxyType
from typing import Literal

from pydantic import BaseModel, Field

from gateway.bus.events import EventBus
from gateway.errors import ConflictError
from gateway.service.config import LocalInputSettings
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.topology import ControllerRef, Topology

__all__ = [
    "ControlChange",
    "ControlSourceView",
    "ControlState",
    "ControlStates",
    "ControlView",
    "KeySwitchView",
    "local_input_of",
]


class ControlState(StrEnum):
    """Who may act on a controller: the network (remote) or only the people at it (local)."""

    LOCAL = "local"
    REMOTE = "remote"


SourceKind = Literal["controller", "loop", "key_switch"]


class ControlSourceView(BaseModel):
    """One reason a controller is local."""

    kind: SourceKind = Field(
        description="controller: an admin set this controller local; loop: an admin set its "
        "loop local; key_switch: the configured general input is active (or not read yet)"
    )
    by: str = Field(description="the admin token's name, or the input (`input bit 3 on`)")
    since: float = Field(description="seconds since the epoch")


class KeySwitchView(BaseModel):
    """The configured key-switch input of a controller and where it stands."""

    bit: int = Field(description="general input bit 0-7 (§10 C)")
    active: Literal["on", "off"] = Field(description="the input level that means local")
    input_on: bool | None = Field(description="the input as last read; null: not read yet")
    read: float | None = Field(description="seconds since the epoch of the last read")


class ControlView(BaseModel):
    """A controller's control state and why."""

    state: ControlState
    sources: list[ControlSourceView] = Field(description="why it is local; empty when remote")
    key_switch: KeySwitchView | None = Field(description="null: no key switch configured")


@dataclass(frozen=True)
class ControlChange:
    """A controller's state moved: from, to, and what moved it."""

    controller: ControllerRef
    previous: ControlState
    view: ControlView
    cause: str
    source: SourceKind  # what made the change: an admin (controller, loop) or the key switch


_Seen = tuple[ControlState, list[ControlSourceView]]


@dataclass
class _Admin:
    by: str
    since: float


@dataclass
class _Switch:
    settings: LocalInputSettings
    input_on: bool | None = None
    read: float | None = None
    since: float = 0.0  # when it became active (or was first counted unknown)

    @property
    def local(self) -> bool:
        return self.input_on is None or self.input_on is (self.settings.active == "on")


def local_input_of(topology: Topology, ref: ControllerRef) -> LocalInputSettings | None:
    """The configured key-switch input of ``ref`` (None when it has none)."""
    for ctl in topology.loop(ref.loop).settings.controllers:
        if ctl.body == ref.body:
            return ctl.local_input
    return None


class ControlStates:
    """The control state of every controller of ``topology``."""

    def __init__(
        self,
        topology: Topology,
        events: ServiceEvents | None = None,
        *,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.topology, self.events, self._clock = topology, events, clock
        self._controllers: dict[str, _Admin] = {}
        self._loops: dict[str, _Admin] = {}
        self._holds: dict[str, str] = {}
        now = clock()
        self._switches: dict[str, _Switch] = {}
        for ref in topology.controllers():
            settings = local_input_of(topology, ref)
            if settings is not None:
                self._switches[ref.id] = _Switch(settings, since=now)
        #: every change of a controller's state (a failing subscriber is logged, never raised)
        self.changes: EventBus[ControlChange] = EventBus()

    # ------------------------------------------------------------------ reading

    def state(self, ref: ControllerRef) -> ControlState:
        """``local`` or ``remote`` now."""
        return ControlState.LOCAL if self._sources(ref) else ControlState.REMOTE

    def view(self, ref: ControllerRef) -> ControlView:
        """The state of ``ref`` and why."""
        sources = self._sources(ref)
        switch = self._switches.get(ref.id)
        return ControlView(
            state=ControlState.LOCAL if sources else ControlState.REMOTE,
            sources=sources,
            key_switch=None
            if switch is None
            else KeySwitchView(
                bit=switch.settings.bit,
                active=switch.settings.active,
                input_on=switch.input_on,
                read=switch.read,
            ),
        )

    def switches(self) -> list[tuple[ControllerRef, LocalInputSettings]]:
        """The controllers with a key switch, and its input."""
        return [
            (self.topology.controller(ident), switch.settings)
            for ident, switch in self._switches.items()
        ]

    def check(self, ref: ControllerRef, what: str) -> None:
        """409 when ``ref`` is local: ``what`` (``move sim.1.1``, ``send '2100'``) is refused.
        Also while its loop is held by a maintenance operation (``hold``)."""
        held = self._holds.get(ref.loop)
        if held is not None:
            raise ConflictError(
                f"cannot {what}: loop {ref.loop} is held ({held}); stops are accepted",
                field="loop",
            )
        sources = self._sources(ref)
        if not sources:
            return
        how = "; ".join(_describe(s) for s in sources)
        raise ConflictError(
            f"cannot {what}: controller {ref.id} is in local control ({how}); motion and "
            "settings from the network are refused until it is remote again, stops are "
            "accepted",
            field="control",
        )

    def hold(self, loop: str, why: str) -> None:
        """Refuse motion and settings on every controller of ``loop`` until ``release``
        (a rate change in progress); not a control state: the views do not change."""
        self._holds[loop] = why

    def release(self, loop: str) -> None:
        """End ``hold``."""
        self._holds.pop(loop, None)

    # ------------------------------------------------------------------ changing

    def set_controller(self, ref: ControllerRef, state: ControlState, by: str) -> ControlView:
        """An admin sets one controller local or remote (remote lifts only this setting)."""
        before = self._states([ref])
        if state is ControlState.LOCAL:
            self._controllers.setdefault(ref.id, _Admin(by, self._clock()))
        else:
            self._controllers.pop(ref.id, None)
        self._publish(before, f"{state.value} set by {by} on controller {ref.id}", "controller")
        return self.view(ref)

    def set_loop(self, loop: str, state: ControlState, by: str) -> list[ControlView]:
        """An admin sets every controller of ``loop`` local, or lifts the loop's setting."""
        refs = list(self.topology.loop(loop).controllers)
        before = self._states(refs)
        if state is ControlState.LOCAL:
            self._loops.setdefault(loop, _Admin(by, self._clock()))
        else:
            self._loops.pop(loop, None)
        self._publish(before, f"{state.value} set by {by} on loop {loop}", "loop")
        return [self.view(ref) for ref in refs]

    def loop_local(self, loop: str) -> ControlSourceView | None:
        """The admin's loop-wide setting of ``loop``, if any."""
        admin = self._loops.get(loop)
        return (
            None
            if admin is None
            else ControlSourceView(kind="loop", by=admin.by, since=admin.since)
        )

    def set_input(self, ref: ControllerRef, input_on: bool) -> None:
        """The key-switch input of ``ref`` as just read."""
        switch = self._switches[ref.id]
        before = self._states([ref])
        was_local = switch.local
        now = self._clock()
        switch.input_on, switch.read = input_on, now
        if switch.local and not was_local:
            switch.since = now
        level = "on" if input_on else "off"
        self._publish(before, f"key switch: input bit {switch.settings.bit} {level}", "key_switch")

    # ------------------------------------------------------------------ helpers

    def _sources(self, ref: ControllerRef) -> list[ControlSourceView]:
        sources = []
        admin = self._controllers.get(ref.id)
        if admin is not None:
            sources.append(ControlSourceView(kind="controller", by=admin.by, since=admin.since))
        loop = self.loop_local(ref.loop)
        if loop is not None:
            sources.append(loop)
        switch = self._switches.get(ref.id)
        if switch is not None and switch.local:
            bit = switch.settings.bit
            by = (
                f"input bit {bit} not read yet"
                if switch.input_on is None
                else f"input bit {bit} {'on' if switch.input_on else 'off'}"
            )
            sources.append(ControlSourceView(kind="key_switch", by=by, since=switch.since))
        return sources

    def _states(self, refs: list[ControllerRef]) -> dict[str, tuple[ControllerRef, _Seen]]:
        return {ref.id: (ref, (self.state(ref), self._sources(ref))) for ref in refs}

    def _publish(
        self, before: dict[str, tuple[ControllerRef, _Seen]], cause: str, source: SourceKind
    ) -> None:
        """A change for each controller whose state or reasons moved (not a mere re-read)."""
        for ref, (previous, sources) in before.values():
            view = self.view(ref)
            if view.state is previous and view.sources == sources:
                continue
            change = ControlChange(ref, previous, view, cause, source)
            self.changes.publish(change)
            if self.events is not None:
                data = {
                    "controller": ref.id,
                    "axes": [a.id for a in ref.axes],
                    "state": view.state.value,
                    "previous": previous.value,
                    "cause": cause,
                    "sources": [s.model_dump(mode="json") for s in view.sources],
                }
                self.events.publish(
                    ServiceEvent(
                        EventKind.CONTROL,
                        f"controller:{ref.id}",
                        self._clock(),
                        MappingProxyType(data),
                    )
                )


def _describe(source: ControlSourceView) -> str:
    when = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(source.since))
    if source.kind == "controller":
        return f"set local by {source.by} on the controller since {when}"
    if source.kind == "loop":
        return f"set local by {source.by} on its loop since {when}"
    return f"key switch: {source.by}"
