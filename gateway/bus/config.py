"""The settings of one loop's scheduler, with the defaults and where they come from."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from gateway.bus.requests import Priority
from gateway.protocol.framing import POWER_ON, Framing, Series

__all__ = ["LoopConfig"]

_DEADLINES: Mapping[Priority, float | None] = MappingProxyType(
    {Priority.STOP: None, Priority.OPERATOR: 30.0, Priority.POLL: 5.0}
)


@dataclass(frozen=True)
class LoopConfig:
    """How one loop's scheduler behaves. Device seconds unless the name says ``real``.

    ``time_scale``: device seconds per host second (1 on a real line; the simulator's speed-up
    in tests). ``turnaround``/``host_latency``/``quiet_chars``: see ``timing.Timing``.
    """

    name: str = "loop"
    baud: int | None = None  # None: the transport's rate
    time_scale: float = 1.0
    turnaround: float = 0.010
    host_latency: float = 0.020  # real seconds
    quiet_chars: float = 3.0
    #: '?' means the controller did not take the frame (§9-2): send it again this many times
    nak_retries: int = 3
    #: an idempotent command whose reply was lost or garbled is sent again this many times
    resend_retries: int = 2
    #: AW, DW, IW: how long the line is held for ``$B#*`` (the manual gives no time)
    eeprom_write_hold: float = 5.0
    #: EE///: "10-20 s" (§10 EE/// 注意点), "about 20 s" (§15); 1 s margin on the upper bound
    erase_hold: float = 21.0
    #: this many time-outs in a row with no byte received at all: the line is taken as gone
    timeouts_to_down: int = 8
    #: while down with the port open: every controller that answered before is asked this
    #: often (device seconds) whether it answers again (``LoopLifecycle._answered``)
    probe_period: float = 0.25
    reconnect_initial_real: float = 0.1
    reconnect_max_real: float = 1.0  # a line back is ready within about this (plus a probe)
    #: real seconds after which a waiting poll goes with the operator requests, in its place
    #: (a stream of operator requests must not starve the status polls)
    poll_aging_real: float | None = 1.0
    #: real seconds a request may wait to start, per priority (None: no limit; stops)
    deadlines_real: Mapping[Priority, float | None] = field(default_factory=lambda: _DEADLINES)
    #: SUM1 at the first contact after the link comes up, for lines with noise (§10 SUM)
    sum_at_connect: bool = False
    #: what the scheduler assumes of a controller it has not talked to (DW may store others)
    initial_framing: Framing = POWER_ON
    #: start mark per body number; missing bodies are '$' controllers (§9-1 注意)
    series: Mapping[str, Series] = field(default_factory=lambda: MappingProxyType({}))
    #: program text is written in pieces of at most this many bytes (§10 I; §13-2 example)
    upload_chunk: int = 64
    #: confirm a selection change with ``97`` (F is refused while a motor moves, §10 F)
    confirm_selection: bool = True
    trace_size: int = 5000

    def __post_init__(self) -> None:
        if self.nak_retries < 0 or self.resend_retries < 0:
            raise ValueError("retry counts must be >= 0")
        if self.timeouts_to_down < 1:
            raise ValueError("timeouts_to_down must be >= 1")
        if not self.time_scale > 0:
            raise ValueError("time_scale must be > 0")
        if self.upload_chunk < 1:
            raise ValueError("upload_chunk must be >= 1")

    def series_of(self, body: str) -> Series:
        """The start mark of ``body``."""
        return self.series.get(body, Series.DOLLAR)

    def deadline_for(self, priority: Priority) -> float | None:
        """Real seconds a request of ``priority`` may wait to start by default."""
        return self.deadlines_real.get(priority)
