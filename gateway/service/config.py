"""The gateway's configuration: a TOML file read into pydantic models.

One file describes a cell: its loops (port URL, baud, time-outs, poll periods, SUM at
connect), the controllers on each (body number, name) and their axes (name, user units, soft
limits), the security section (API tokens stored as SHA-256 hashes, each with a role and a
name; CORS origins), the audit log, the state directory and the WebSocket limits.
``deploy/cell.example.toml`` is the annotated example.

Every key is checked before anything starts: an unknown key, a bad value or a broken rule
raises ``ConfigError``, whose message names the key (``loops[0].controllers[1].body``) and the
problem. Environment variables ``RC233_<KEY>`` override top-level keys (pydantic-settings),
e.g. ``RC233_AUDIT_LOG``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Any, Literal, Self

from pydantic import (
    Field,
    ValidationError,
    model_validator,
)
from pydantic_settings import BaseSettings, SettingsConfigDict

from gateway.bus.config import LoopConfig
from gateway.bus.poll_plan import PollConfig
from gateway.protocol.framing import BAUD_RATES, BODY_NUMBERS
from gateway.service.config_base import NAME_PATTERN, ConfigError, Name, Strict
from gateway.service.config_bounds import UnreadableConfig, listed, read_toml
from gateway.service.config_engine import EngineSettings, check_groups
from gateway.service.config_faces import MqttSettings, OpcUaSettings
from gateway.service.roles import Role

__all__ = [
    "NAME_PATTERN",
    "AxisSettings",
    "ConfigError",
    "ConnectionSettings",
    "ControllerSettings",
    "GatewayConfig",
    "LocalInputSettings",
    "LoopSettings",
    "MqttSettings",
    "OpcUaSettings",
    "PollSettings",
    "SecuritySettings",
    "TimeoutSettings",
    "TokenSettings",
    "WsSettings",
    "load_config",
    "schema_problems",
]


class AxisSettings(Strict):
    """One motor of a controller as users see it."""

    motor: Literal[1, 2]
    name: Name | None = None
    #: the user unit's name (``mm``, ``deg``); ``pulse`` when the axis has none
    unit: str = Field("pulse", min_length=1, max_length=16)
    #: user units per pulse (0.01 mm a pulse: 0.01)
    units_per_pulse: float = Field(1.0, gt=0)
    #: soft limits in user units; a move that would end outside is refused before it is sent
    soft_min: float | None = None
    soft_max: float | None = None

    @model_validator(mode="after")
    def _limits_in_order(self) -> Self:
        low, high = self.soft_min, self.soft_max
        if low is not None and high is not None and low >= high:
            raise ValueError(f"soft_min {low} must be below soft_max {high}")
        return self


class LocalInputSettings(Strict):
    """A key switch wired to a general input: while it is active the controller is in local
    control (motion and settings from the network refused, stops accepted). Read with ``C``
    (§10 C form I: the general input port, bit 0-7 = pins 13-20, 1 = ON)."""

    bit: int = Field(ge=0, le=7, description="general input bit 0-7 (§10 C)")
    #: the input level that means local: "on" (the switch closes the input) or "off"
    active: Literal["on", "off"] = "on"


class ControllerSettings(Strict):
    """One RC-233 on a loop."""

    body: str = Field(pattern=f"^[{BODY_NUMBERS}]$", description="body number 0-E (§9-1)")
    name: Name | None = None
    series: Literal["$", "#"] = "$"
    axes: list[AxisSettings] = Field(default_factory=list, max_length=2)
    #: a key switch for local control, read every poll period (``poll.idle_period``)
    local_input: LocalInputSettings | None = None

    @model_validator(mode="after")
    def _motors_once(self) -> Self:
        motors = [a.motor for a in self.axes]
        if len(set(motors)) != len(motors):
            raise ValueError(f"axes: each motor (1, 2) at most once, got {motors}")
        return self


def _default(config: type[Any], name: str) -> Any:
    """The default of field ``name`` of the bus's dataclass ``config``: defined there once."""
    return next(f.default for f in dataclasses.fields(config) if f.name == name)


class TimeoutSettings(Strict):
    """The scheduler's timing and retry knobs: the fields of ``gateway.bus.config.LoopConfig``
    of the same names, with its defaults; the file may set them within these bounds."""

    turnaround: float = Field(_default(LoopConfig, "turnaround"), ge=0, le=1)
    host_latency: float = Field(_default(LoopConfig, "host_latency"), ge=0, le=5)
    nak_retries: int = Field(_default(LoopConfig, "nak_retries"), ge=0, le=10)
    resend_retries: int = Field(_default(LoopConfig, "resend_retries"), ge=0, le=10)
    timeouts_to_down: int = Field(_default(LoopConfig, "timeouts_to_down"), ge=1, le=100)
    eeprom_write_hold: float = Field(_default(LoopConfig, "eeprom_write_hold"), gt=0, le=60)


class PollSettings(Strict):
    """Poll periods in seconds: the fields of ``gateway.bus.poll_plan.PollConfig`` of the same
    names, with its defaults; the file may set them within these bounds."""

    moving_period: float = Field(_default(PollConfig, "moving_period"), gt=0, le=10)
    idle_period: float = Field(_default(PollConfig, "idle_period"), gt=0, le=600)
    sensor_period: float = Field(_default(PollConfig, "sensor_period"), gt=0, le=3600)
    condition_period: float = Field(_default(PollConfig, "condition_period"), gt=0, le=3600)
    #: while an axis is watched: an idle controller's status (1 s by default, as when nothing
    #: moves: an EMS or a program's motion on it is seen as soon; longer gives the watched
    #: axis more reads, and the state cache caps it at two thirds of its stale time)
    watched_idle_period: float = Field(_default(PollConfig, "watched_idle_period"), gt=0, le=600)
    #: while an axis is watched: the sensors, conditions and positions this many times apart
    watched_slow_factor: float = Field(_default(PollConfig, "watched_slow_factor"), ge=1, le=100)

    @model_validator(mode="after")
    def _spaced_not_closer(self) -> Self:
        # Left out, it follows idle_period (never closer: PollPlan.idle_step); set, it must say
        # something that can be done.
        if "watched_idle_period" in self.model_fields_set and (
            self.watched_idle_period < self.idle_period
        ):
            raise ValueError(
                f"watched_idle_period {self.watched_idle_period}: at least idle_period "
                f"({self.idle_period}); it spaces the idle reads while an axis is watched"
            )
        return self


class LoopSettings(Strict):
    """One serial loop (one RC-002 link master)."""

    name: Name
    #: a device path (/dev/ttyUSB0), socket://host:port or rfc2217://host:port
    port: str = Field(min_length=1)
    baud: int = 9600
    sum_at_connect: bool = False
    timeouts: TimeoutSettings = TimeoutSettings()
    poll: PollSettings = PollSettings()
    controllers: list[ControllerSettings] = Field(min_length=1, max_length=20)

    @model_validator(mode="after")
    def _checks(self) -> Self:
        if self.baud not in BAUD_RATES:
            raise ValueError(f"baud {self.baud}: one of {', '.join(map(str, BAUD_RATES))} (§10 ES)")
        bodies = [(c.series, c.body) for c in self.controllers]
        if len(set(bodies)) != len(bodies):
            raise ValueError("controllers: each body number once per series on a loop (§9-1)")
        if len({c.body for c in self.controllers}) != len(self.controllers):
            raise ValueError("controllers: the gateway addresses one controller per body number")
        return self


class TokenSettings(Strict):
    """One API token: stored as the SHA-256 hex digest of the token, never the token itself."""

    name: Name
    role: Role
    sha256: str = Field(pattern=r"^[0-9a-f]{64}$", description="hashlib.sha256(token).hexdigest()")


class SecuritySettings(Strict):
    """Tokens, CORS, and which read-only pages need no token."""

    tokens: list[TokenSettings] = Field(default_factory=list)
    cors_origins: list[str] = Field(default_factory=list)
    #: ``/metrics`` without a token (scrapers); False: any token (viewer or above)
    open_metrics: bool = True
    #: ``/api/v1/docs`` and ``/api/v1/openapi.json`` without a token; False: any token
    open_docs: bool = True
    #: names (or addresses) the ``Host`` header may give besides loopback ones (``localhost``,
    #: ``127.0.0.1``, ``[::1]``): what clients type to reach the gateway (``gw.plant.example``).
    #: Any other is refused (421), so a hostile page cannot reach the API through a name of
    #: its own (DNS rebinding). ``"*"`` accepts any name (not advised).
    allowed_hosts: list[
        Annotated[str, Field(pattern=r"^(\*|[A-Za-z0-9_.-]{1,253}|\[[0-9A-Fa-f:.]{2,45}\])$")]
    ] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique(self) -> Self:
        names = [t.name for t in self.tokens]
        if len(set(names)) != len(names):
            raise ValueError("tokens: each name once (the audit log names the token)")
        if len({t.sha256 for t in self.tokens}) != len(self.tokens):
            raise ValueError("tokens: the same token twice")
        return self


class WsSettings(Strict):
    """WebSocket limits."""

    replay: int = Field(10_000, ge=100, le=1_000_000, description="messages kept for replay")
    backlog: int = Field(1_000, ge=10, le=100_000, description="unsent messages per client")
    ping_interval: float = Field(20.0, gt=0, le=600)


class ConnectionSettings(Strict):
    """Limits on the API's HTTP connections (gateway/cli/connection_guard.py): a client
    that sends too much, too slowly or nothing at all is closed before the app sees it."""

    #: request line and headers together, in bytes; more: ``431``
    max_head_bytes: int = Field(16_384, ge=1_024, le=1_048_576)
    #: seconds a new connection may stay silent before it is closed
    idle_timeout: float = Field(10.0, gt=0, le=600)
    #: seconds from a request head's first byte to its end; later: ``408``
    head_timeout: float = Field(10.0, gt=0, le=600)
    #: open connections in all (fewer if the descriptor limit leaves no reserve)
    max_connections: int = Field(1_024, ge=16, le=100_000)
    #: open connections from one client address; more: ``429``
    max_per_client: int = Field(64, ge=1, le=100_000)


class AuditSettings(Strict):
    """The audit file (``audit_log``): forcing entries to the disk, rotation, retries."""

    #: entries ``fsync``-ed before their request acts: ``motion`` (the default), ``acting``
    #: (every request that acts), ``all`` (outcomes too) or ``none`` (flushed to the OS only)
    fsync: Literal["motion", "acting", "all", "none"] = "motion"
    max_bytes: int = Field(
        64 * 1024 * 1024, ge=64 * 1024, le=2**40, description="rotate at this size (bytes)"
    )
    keep: int = Field(10, ge=1, le=1000, description="rotated files kept (FILE.1 ... FILE.n)")
    retry_seconds: float = Field(
        1.0, ge=0.05, le=60, description="while the file fails: seconds between tries"
    )


class GatewayConfig(BaseSettings):
    """The whole configuration (a TOML file, environment ``RC233_*`` over it)."""

    model_config = SettingsConfigDict(
        extra="forbid", frozen=True, env_prefix="RC233_", allow_inf_nan=False
    )

    loops: list[LoopSettings] = Field(min_length=1)
    security: SecuritySettings = SecuritySettings()
    audit_log: Path | None = None
    audit: AuditSettings = AuditSettings()
    #: The state directory (SQLite: operations, idempotency keys, Sparkplug bdSeq); None: the
    #: default of ``gateway.service.store.location`` (docs/operations.md, "The state")
    state_dir: Path | None = None
    ws: WsSettings = WsSettings()
    connections: ConnectionSettings = ConnectionSettings()
    mqtt: MqttSettings | None = None
    opcua: OpcUaSettings | None = None
    #: which loops share a line worker process (``config_engine``)
    engine: EngineSettings = EngineSettings()

    @model_validator(mode="after")
    def _worker_groups(self) -> Self:
        if self.engine.workers is not None:
            check_groups(self.engine.workers, [loop.name for loop in self.loops])
        return self

    @model_validator(mode="after")
    def _names_unique(self) -> Self:
        seen: dict[str, str] = {}
        for i, loop in enumerate(self.loops):
            _claim(seen, loop.name, f"loops[{i}].name")
            for j, ctl in enumerate(loop.controllers):
                if ctl.name:
                    _claim(seen, ctl.name, f"loops[{i}].controllers[{j}].name")
                for k, axis in enumerate(ctl.axes):
                    if axis.name:
                        _claim(seen, axis.name, f"loops[{i}].controllers[{j}].axes[{k}].name")
        return self


def _claim(seen: dict[str, str], name: str, where: str) -> None:
    if name in seen:
        raise ValueError(f"{where}: name {name!r} is already used by {seen[name]}")
    seen[name] = where


def _where(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(file)"


def schema_problems(exc: ValidationError) -> list[str]:
    """Every key at fault in ``exc`` and its problem, one a line (``key: problem``)."""
    problems = []
    for err in exc.errors(include_url=False):
        where = _where(tuple(p for p in err["loc"] if not isinstance(p, str) or p))
        # the value only where it is the point: NaN and inf read as numbers in TOML
        said = (
            f" (NaN and ±inf are refused, got {err['input']})"
            if err["type"] == "finite_number"
            else ""
        )
        problems.append(f"{where}: {err['msg']}{said}")
    return problems


def describe(exc: ValidationError, source: str) -> ConfigError:
    """One ``ConfigError`` naming the keys at fault and their problems (the first
    ``MAX_LISTED``, then how many more)."""
    problems = schema_problems(exc)
    lines = [f"{source}: {len(problems)} problem(s)", *(f"  {p}" for p in listed(problems))]
    return ConfigError("\n".join(lines))


def parse_config(data: dict[str, object], source: str = "configuration") -> GatewayConfig:
    """Validate a configuration given as a dict (what the TOML file holds)."""
    try:
        return GatewayConfig(**data)  # type: ignore[arg-type]
    except ValidationError as exc:
        raise describe(exc, source) from None


def load_config(path: Path) -> GatewayConfig:
    """Read and validate a TOML file; ``ConfigError`` naming the key and the problem."""
    try:
        data = read_toml(path)  # bounded: no file makes the parser run out of memory or time
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the file ({exc.strerror})") from None
    except UnreadableConfig as exc:
        raise ConfigError(f"{path}: {exc}") from None
    return parse_config(data, str(path))
