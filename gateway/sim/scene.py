"""Where the sensors of each simulated axis sit, and how they read (§3-V, §4-4, §10 CL, EA, Q).

Positions are mechanical pulses along the axis, CW positive: the position counter counts up when
the motor turns CW (§10 3: an absolute move goes CW to a larger position; §10 4 is the CW
incremental move; §10 R: after ``R8000`` the origin lies 8,000 pulses CCW). The counter and the
mechanical position differ by an offset (homing, ``R``, lost pulses); sensors see the latter.

Scene file (TOML, read with ``load_scene``)::

    # Every key is optional. [default] applies to every axis; [body.B.motor.M] to motor M
    # (1 or 2) of the controller with body number B (one character 0-9, A-E), over [default].
    [default]
    ccw_limit = -5000        # CCW limit sensor actuated at positions <= this
    cw_limit = 95000         # CW limit sensor actuated at positions >= this
    org_start = 0            # ORG sensor actuated from org_start ...
    org_end = 499            # ... to org_end (inclusive); must lie between the limits
    start = 30000            # mechanical position at power-on
    ez = "dog"               # what is wired to the EZ input: "dog" (step-out dog, §10 Q)
                             # or "z" (encoder Z phase, §10 0Z)
    dog_period = 400         # dog: ON for the first half of every period (§10 Q: s1)
    dog_offset = 0           #   ON where (position - dog_offset) mod dog_period < period / 2
    z_period = 1000          # Z phase: ON for z_width pulses of every z_period
    z_width = 10
    z_offset = 0             #   ON where (position - z_offset) mod z_period < z_width
    connected = ["cw_limit", "ccw_limit", "org", "ez"]   # inputs with a sensor wired
    normally_closed = []     # wired sensors that are B contacts (closed when not actuated)
    inp_delay = 0.0          # mode 2: seconds from the end of pulse output to INP ON

    [body.1.motor.2]
    org_start = 40000
    org_end = 40300

Unknown keys and bad values raise ``SceneError`` naming the key (``body.1.motor.2.org_end``).

How an input reads (§10 EA, §4-4): a wired sensor closes its input when actuated (A contact) or
when not actuated (B contact); an input with no sensor is open. The EA logic then says which
level is ON: A logic = closed is ON, B logic = open is ON. So an unconnected input read with B
logic is always ON, as §10 EA warns.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from enum import IntEnum, StrEnum
from pathlib import Path
from typing import Any

from gateway.protocol.framing import BODY_NUMBERS
from gateway.protocol.reply_values import Contact, SensorLogic

__all__ = [
    "AxisScene",
    "Direction",
    "EzWiring",
    "Scene",
    "SceneError",
    "SensorName",
    "SensorReader",
    "load_scene",
    "parse_scene",
]


class Direction(IntEnum):
    """Direction of rotation, as the sign it gives the position counter (module docstring)."""

    CW = 1
    CCW = -1


class SensorName(StrEnum):
    """The per-motor sensor inputs of §4-4 (EMS is one input for both motors, not here)."""

    CW_LIMIT = "cw_limit"  # CWLS
    CCW_LIMIT = "ccw_limit"  # CCWLS
    ORG = "org"
    EZ = "ez"  # step-out detection sensor (modes 0, 2) or encoder Z phase


class EzWiring(StrEnum):
    """What drives the EZ input (§4-4): the step-out dog's sensor or the encoder's Z phase."""

    DOG = "dog"
    Z = "z"


class SceneError(ValueError):
    """A scene file or value that cannot describe an axis; the message names the key."""


ALL_SENSORS = frozenset(SensorName)


@dataclass(frozen=True)
class AxisScene:
    """Sensor layout of one axis; defaults: a stroke of 100,000 pulses with ORG near its CCW end."""

    ccw_limit: int = -5_000
    cw_limit: int = 95_000
    org_start: int = 0
    org_end: int = 499
    start: int = 30_000
    ez: EzWiring = EzWiring.DOG
    dog_period: int = 400  # §10 Q default s1
    dog_offset: int = 0
    z_period: int = 1_000
    z_width: int = 10
    z_offset: int = 0
    connected: frozenset[SensorName] = ALL_SENSORS
    normally_closed: frozenset[SensorName] = frozenset()
    inp_delay: float = 0.0

    def __post_init__(self) -> None:
        if not self.ccw_limit < self.org_start <= self.org_end < self.cw_limit:
            raise SceneError(
                "need ccw_limit < org_start <= org_end < cw_limit, got "
                f"{self.ccw_limit}, {self.org_start}, {self.org_end}, {self.cw_limit}"
            )
        if self.dog_period < 2:
            raise SceneError(f"dog_period must be at least 2, got {self.dog_period}")
        if self.z_period < 2:
            raise SceneError(f"z_period must be at least 2, got {self.z_period}")
        if not 0 < self.z_width < self.z_period:
            raise SceneError(f"z_width must be 1 to z_period - 1, got {self.z_width}")
        if self.inp_delay < 0:
            raise SceneError(f"inp_delay must be >= 0 s, got {self.inp_delay}")

    def actuated(self, sensor: SensorName, position: int) -> bool:
        """Whether the sensor is physically actuated with the axis at ``position``."""
        if sensor is SensorName.CW_LIMIT:
            return position >= self.cw_limit
        if sensor is SensorName.CCW_LIMIT:
            return position <= self.ccw_limit
        if sensor is SensorName.ORG:
            return self.org_start <= position <= self.org_end
        period, width, offset = self._ez_pattern
        return (position - offset) % period < width

    @property
    def _ez_pattern(self) -> tuple[int, int, int]:
        if self.ez is EzWiring.DOG:
            return self.dog_period, self.dog_period // 2, self.dog_offset
        return self.z_period, self.z_width, self.z_offset

    def next_change(self, sensor: SensorName, position: int, direction: int) -> int | None:
        """The nearest position beyond ``position`` in ``direction`` where ``actuated`` differs.

        None when the sensor never changes that way (past a limit, beyond the ORG window).
        """
        edges: tuple[int, ...]
        if sensor is SensorName.CW_LIMIT:
            edges = (self.cw_limit,)
        elif sensor is SensorName.CCW_LIMIT:
            edges = (self.ccw_limit + 1,)
        elif sensor is SensorName.ORG:
            edges = (self.org_start, self.org_end + 1)
        else:
            period, width, offset = self._ez_pattern
            phase = (position - offset) % period
            if direction > 0:
                return position + (width - phase if phase < width else period - phase)
            return position - (phase + 1 if phase < width else phase - width + 1)
        # An edge e separates e - 1 from e: going CW it is crossed at e, going CCW at e - 1.
        if direction > 0:
            ahead = [e for e in edges if e > position]
            return min(ahead) if ahead else None
        behind = [e - 1 for e in edges if e - 1 < position]
        return max(behind) if behind else None


class SensorReader:
    """How the inputs of one axis read: scene, wiring, EA logic, and injected faults (§10 EA)."""

    def __init__(self, scene: AxisScene) -> None:
        self.scene = scene
        self.logic = SensorLogic()
        self.forced: dict[SensorName, bool] = {}

    def _contact(self, sensor: SensorName) -> Contact:
        if sensor is SensorName.ORG:
            return self.logic.org
        if sensor is SensorName.EZ:
            return self.logic.step_out_sensor
        return self.logic.limit  # §10 EA bit 2: one setting for CWLS and CCWLS

    def reads(self, sensor: SensorName, position: int) -> bool:
        """The sensor as CL reports it (ON = True) with the axis at ``position``."""
        if sensor in self.forced:
            return self.forced[sensor]
        closed = sensor in self.scene.connected and (
            self.scene.actuated(sensor, position) != (sensor in self.scene.normally_closed)
        )
        return closed if self._contact(sensor) is Contact.A else not closed

    def next_change(self, sensor: SensorName, position: int, direction: int) -> int | None:
        """The nearest position in ``direction`` where ``reads`` differs; None if it never does."""
        if sensor in self.forced or sensor not in self.scene.connected:
            return None
        return self.scene.next_change(sensor, position, direction)


@dataclass(frozen=True)
class Scene:
    """The axes of every simulated controller: ``default`` unless ``axes`` names the axis."""

    default: AxisScene = AxisScene()
    axes: Mapping[tuple[str, int], AxisScene] = field(default_factory=dict, hash=False)

    def axis(self, body: str, motor: int) -> AxisScene:
        """The scene of motor 1 or 2 of the controller with body number ``body``."""
        return self.axes.get((body.upper(), motor), self.default)


_KEYS = {f.name: f.type for f in fields(AxisScene)}


def _value(key: str, name: str, raw: Any) -> Any:
    """Check and convert one TOML value for field ``name``; ``key`` is its path for messages."""
    if name in ("connected", "normally_closed"):
        if not isinstance(raw, list) or not all(isinstance(s, str) for s in raw):
            raise SceneError(f"{key}: expected a list of sensor names, got {raw!r}")
        unknown = [s for s in raw if s not in ALL_SENSORS]
        if unknown:
            raise SceneError(f"{key}: unknown sensor(s) {unknown}; known: {sorted(ALL_SENSORS)}")
        return frozenset(SensorName(s) for s in raw)
    if name == "ez":
        if raw not in tuple(EzWiring):
            raise SceneError(f"{key}: expected 'dog' or 'z', got {raw!r}")
        return EzWiring(raw)
    if name == "inp_delay":
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise SceneError(f"{key}: expected seconds (a number), got {raw!r}")
        return float(raw)
    if isinstance(raw, bool) or not isinstance(raw, int):
        raise SceneError(f"{key}: expected an integer (pulses), got {raw!r}")
    return raw


def _axis(base: AxisScene, table: Any, path: str) -> AxisScene:
    if not isinstance(table, dict):
        raise SceneError(f"{path}: expected a table of settings")
    changes: dict[str, Any] = {}
    for name, raw in table.items():
        key = f"{path}.{name}"
        if name not in _KEYS:
            raise SceneError(f"{key}: unknown key; known: {', '.join(_KEYS)}")
        changes[name] = _value(key, name, raw)
    try:
        return replace(base, **changes)
    except SceneError as error:
        raise SceneError(f"{path}: {error}") from None


def parse_scene(text: str) -> Scene:
    """The scene described by TOML ``text`` (format in the module docstring)."""
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"not valid TOML: {error}") from None
    unknown = set(document) - {"default", "body"}
    if unknown:
        raise SceneError(f"{sorted(unknown)[0]}: unknown key; known: default, body")
    default = _axis(AxisScene(), document.get("default", {}), "default")
    axes: dict[tuple[str, int], AxisScene] = {}
    bodies = document.get("body", {})
    if not isinstance(bodies, dict):
        raise SceneError("body: expected tables [body.B.motor.M]")
    for body, body_table in bodies.items():
        if len(body) != 1 or body.upper() not in BODY_NUMBERS:
            raise SceneError(f"body.{body}: body numbers are one character 0-9, A-E")
        if not isinstance(body_table, dict) or set(body_table) - {"motor"}:
            raise SceneError(f"body.{body}: expected only [body.{body}.motor.M] tables")
        for motor, table in body_table.get("motor", {}).items():
            if motor not in ("1", "2"):
                raise SceneError(f"body.{body}.motor.{motor}: motors are 1 and 2")
            path = f"body.{body}.motor.{motor}"
            axes[body.upper(), int(motor)] = _axis(default, table, path)
    return Scene(default, axes)


def load_scene(path: str | Path) -> Scene:
    """The scene in the TOML file at ``path`` (format in the module docstring)."""
    return parse_scene(Path(path).read_text(encoding="utf-8"))
