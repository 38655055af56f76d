"""What the proxy's record of bench/line_outside.py says: exchanges, gaps, stops, poll rates.

A row is ``(monotonic time, line name, "h2d" | "d2h", bytes as latin-1)``. The gateway writes
a frame in one piece, so an ``h2d`` row is one frame; the ``d2h`` rows up to the next frame
are its reply (the simulator may deliver it in several pieces: the last one counts).
"""

from __future__ import annotations

import itertools
import re
import statistics
from dataclasses import dataclass

CHAR = 10 / 9600  # seconds a character at 9600 bps, 8N1
TURNAROUND = 0.001  # the simulator's reply delay (sim --turnaround-ms 1)
STOP = re.compile(r"^\$1SS?\r$")
POSITION = re.compile(r"^\$1(6\d?)\r$")
STATUS = re.compile(r"^\$1\r$")

Row = tuple[float, str, str, str]


@dataclass
class Exchange:
    """A frame and its reply as the proxy saw them pass."""

    sent: float
    frame: str
    reply: str = ""
    reply_end: float = 0.0

    @property
    def ideal(self) -> float:
        """Seconds an ideal line is busy with it: both wire times and the turnaround."""
        busy = (len(self.frame) + len(self.reply)) * CHAR
        return busy + (TURNAROUND if self.reply else 0.0)


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return (
        ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))] if ordered else float("nan")
    )


def exchanges(rows: list[Row], line: str) -> list[Exchange]:
    found: list[Exchange] = []
    for when, name, way, data in rows:
        if name != line:
            continue
        if way == "h2d":
            found.append(Exchange(when, data))
        elif found:
            found[-1].reply += data
            found[-1].reply_end = when
    return found


def _ms(value: float) -> float:
    return round(value * 1000, 3)


def analyse_line(
    rows: list[Row],
    line: str,
    start: float,
    end: float,
    stops_sent: list[float],
    stops_queued: list[float] | None = None,
) -> dict[str, object]:
    """Line efficiency, simulator lateness, gateway gap and stop latency in [start, end].

    A stop's in-flight remainder is what the exchange on the wire when its request was sent
    still had to run (0 when it was sent in a gap between two exchanges: then every frame
    before the stop is one too many). ``stops_queued``: when the gateway queued each stop
    (its line trace, on this machine's monotonic clock), to split the latency into the
    HTTP side (request sent -> queued) and the line side (queued -> on the wire, over what
    the exchange on the wire then still had to run: the scheduler's own part).
    """
    every = exchanges(rows, line)
    window = [x for x in every if start <= x.sent <= end]
    answered = [x for x in window if x.reply]
    late = [x.reply_end - (x.sent + x.ideal) for x in answered]
    following = {id(a): b for a, b in itertools.pairwise(every)}
    gaps = [following[id(x)].sent - x.reply_end for x in answered if id(x) in following]
    latencies, excess, behind, in_gap = [], [], 0, 0
    enqueue, to_wire, queued_excess, behind_after_queued = [], [], [], 0
    overtaken: list[dict[str, object]] = []
    queued = sorted(stops_queued or [])
    for sent in stops_sent:
        after = [x for x in every if x.sent >= sent]
        stop = next((i for i, x in enumerate(after) if STOP.match(x.frame)), None)
        if stop is None:
            continue
        wire = after[stop].sent
        latencies.append(wire - sent)
        behind += stop > 0
        flight = [x for x in every if x.sent < sent <= x.reply_end]
        in_gap += not flight
        remainder = flight[-1].reply_end - sent if flight else 0.0
        excess.append(wire - sent - remainder)
        mark = next((q for q in queued if sent <= q <= wire), None)
        if mark is not None:
            enqueue.append(mark - sent)
            to_wire.append(wire - mark)
            busy = [x for x in every if x.sent < mark <= x.reply_end]
            queued_excess.append(wire - mark - (busy[-1].reply_end - mark if busy else 0.0))
            ahead = [x for x in after[:stop] if mark < x.sent < wire]
            behind_after_queued += bool(ahead)
            if ahead:  # what went out between the queueing and the stop (ms after queued)
                overtaken.append(
                    {
                        "http_to_queued_ms": _ms(mark - sent),
                        "ahead": [(x.frame, _ms(x.sent - mark)) for x in ahead],
                        "stop_ms": _ms(wire - mark),
                    }
                )
    figures: dict[str, object] = {
        "exchanges": len(window),
        "line_efficiency": round(sum(x.ideal for x in window) / (end - start), 4),
        "line_efficiency_target": ">= 0.97",
        "sim_late_ms_mean": _ms(statistics.mean(late)) if late else None,
        "sim_late_ms_p99": _ms(percentile(late, 0.99)),
        "sim_late_target_ms": "<= 0.05",
        "gateway_gap_ms_p50": _ms(percentile(gaps, 0.5)),
        "gateway_gap_ms_p99": _ms(percentile(gaps, 0.99)),
        "gateway_gap_target_ms": "<= 0.3 / 1.0",
        "stops": len(latencies),
        "stop_latency_ms_p50": _ms(percentile(latencies, 0.5)),
        "stop_latency_ms_p99": _ms(percentile(latencies, 0.99)),
        "stop_over_in_flight_ms_p50": _ms(percentile(excess, 0.5)),
        "stop_over_in_flight_ms_p99": _ms(percentile(excess, 0.99)),
        "stops_sent_in_a_gap": in_gap,
        "stops_behind_another_exchange": behind,
        "stop_target": "p99 <= 15 ms (in flight + 3 ms), never behind another exchange",
    }
    if stops_queued is not None:
        figures |= {
            "stops_seen_queued": len(enqueue),
            "stop_http_to_queued_ms_p50": _ms(percentile(enqueue, 0.5)),
            "stop_http_to_queued_ms_p99": _ms(percentile(enqueue, 0.99)),
            "stop_queued_to_wire_ms_p50": _ms(percentile(to_wire, 0.5)),
            "stop_queued_to_wire_ms_p99": _ms(percentile(to_wire, 0.99)),
            "stop_queued_over_in_flight_ms_p50": _ms(percentile(queued_excess, 0.5)),
            "stop_queued_over_in_flight_ms_p99": _ms(percentile(queued_excess, 0.99)),
            "stops_behind_another_exchange_once_queued": behind_after_queued,
            "stops_overtaken_once_queued": overtaken,
        }
    return figures


def analyse_watch(rows: list[Row], line: str, start: float, end: float) -> dict[str, float]:
    """Position and status reads of body 1 a second in [start, end], answered ones only."""
    window = [x for x in exchanges(rows, line) if start <= x.sent <= end and x.reply]
    seconds = end - start
    positions = sum(1 for x in window if POSITION.match(x.frame))
    status = sum(1 for x in window if STATUS.match(x.frame))
    return {
        "position_reads_per_s": round(positions / seconds, 1),
        "status_reads_per_s": round(status / seconds, 1),
        "frames_per_s": round(len(window) / seconds, 1),
    }
