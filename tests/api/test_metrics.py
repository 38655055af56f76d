"""/metrics, /healthz and /readyz: the text parses, and counts what happened."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import httpx
import pytest
from fastapi import APIRouter, FastAPI

from gateway.api.metrics.collector import CONTENT_TYPE, Metrics, WsStats
from gateway.api.problems import install_problem_handlers
from gateway.api.routes.health import install_health_and_metrics
from gateway.api.security import AuthConfig, install_security
from gateway.bus.config import LoopConfig
from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import EventBus, TransactionDone, TransactionsTallied, TransactionTally
from gateway.bus.lifecycle import LinkState
from gateway.bus.requests import Outcome, Priority
from gateway.protocol.command_text import parse
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport
from tests.support.exposition import parse_exposition, value


def test_the_parser_refuses_what_prometheus_would():
    with pytest.raises(AssertionError):
        parse_exposition('x{a="1"} 1\n')  # no TYPE
    with pytest.raises(AssertionError):
        parse_exposition("# HELP x h\n# TYPE x gauge\nx{a=1} 1\n")  # unquoted label
    with pytest.raises(ValueError):
        parse_exposition("# HELP x h\n# TYPE x gauge\nx one\n")
    fams = parse_exposition('# HELP x h\n# TYPE x gauge\nx{a="q\\"\\\\\\n"} +Inf\n')
    assert value(fams, "x", a='q"\\\n') == float("inf")


# ---------------------------------------------------------------------- fakes


@dataclass
class FakeLoop:
    events: EventBus
    config: LoopConfig
    clock: Callable[[], float]
    state: LinkState = LinkState.UP
    queue_depth: int = 0
    cause: str = ""


@dataclass
class FakeGateway:
    schedulers: dict[str, FakeLoop]
    counters: dict[str, CountersSnapshot]

    def ready(self) -> bool:
        return all(s.state is LinkState.UP for s in self.schedulers.values())

    def loop_counters(self, name: str) -> CountersSnapshot:
        return self.counters[name]


class Clock:
    def __init__(self, now: float) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


def done(loop: str, duration: float, priority: Priority, outcome: Outcome) -> TransactionDone:
    return TransactionDone(
        loop=loop, body="1", commands=(parse("Q"),), outcome=outcome, priority=priority,
        duration=duration, exchanges=1, counters=CountersSnapshot(),
    )  # fmt: skip


def fake_gateway() -> tuple[FakeGateway, Clock]:
    clock = Clock(100.0)
    main = FakeLoop(EventBus(), LoopConfig(name="main", time_scale=10.0), clock, queue_depth=4)
    aux = FakeLoop(EventBus(), LoopConfig(name="aux"), clock, state=LinkState.DOWN,
                   cause="port gone")  # fmt: skip
    counters = {"main": CountersSnapshot(busy_time=1.0), "aux": CountersSnapshot()}
    return FakeGateway({"main": main, "aux": aux}, counters), clock


def test_loop_counters_gauges_and_the_latency_histogram():
    gateway, clock = fake_gateway()
    metrics = Metrics(gateway)  # begins watching at t=100 s with 1.0 s of wire time
    bus = gateway.schedulers["main"].events
    for seconds in (0.004, 0.03, 0.03, 3.0):
        bus.publish(done("main", seconds, Priority.OPERATOR, Outcome.DONE))
    bus.publish(done("main", 0.3, Priority.POLL, Outcome.UNKNOWN))
    gateway.counters["main"] = CountersSnapshot(
        transactions=5, exchanges=9, retries=2, naks=1, timeouts=3, garbled=1, late_replies=1,
        link_downs=1, busy_time=4.0,
    )  # fmt: skip
    clock.now = 110.0  # 10 host seconds at time scale 10: 100 device seconds
    fams = parse_exposition(metrics.render())

    expected = {"exchanges": 9, "retries": 2, "naks": 1, "timeouts": 3,
                "garbled": 1, "late_replies": 1, "link_downs": 1}  # fmt: skip
    for name, count in expected.items():
        metric = f"rc233_loop_{name}_total"
        assert fams[metric].kind == "counter"
        assert value(fams, metric, loop="main") == count
        assert value(fams, metric, loop="aux") == 0
    assert value(fams, "rc233_loop_wire_seconds_total", loop="main") == 4.0
    # measured: the transactions held the line 3.364 s of the 10 host seconds watched
    assert value(fams, "rc233_loop_busy_seconds_total", loop="main") == pytest.approx(3.364)
    ratio = value(fams, "rc233_loop_line_utilisation_ratio", loop="main")
    assert ratio == pytest.approx(0.3364)
    assert value(fams, "rc233_loop_queue_depth", loop="main") == 4
    assert value(fams, "rc233_loop_up", loop="main") == 1
    assert value(fams, "rc233_loop_up", loop="aux") == 0
    assert value(fams, "rc233_gateway_ready") == 0

    hist = "rc233_loop_transaction_duration_seconds"
    assert fams[hist].kind == "histogram"
    op = {"loop": "main", "priority": "operator"}
    cumulative = {le: value(fams, f"{hist}_bucket", **op, le=le)
                  for le in ("0.005", "0.01", "0.05", "2.0", "5.0", "+Inf")}  # fmt: skip
    assert cumulative == {"0.005": 1, "0.01": 1, "0.05": 3, "2.0": 3, "5.0": 4, "+Inf": 4}
    assert value(fams, f"{hist}_count", **op) == 4
    assert value(fams, f"{hist}_sum", **op) == pytest.approx(3.064)
    assert value(fams, f"{hist}_count", loop="main", priority="poll") == 1
    completed = "rc233_loop_transactions_total"
    assert "rc233_loop_transactions_completed_total" not in fams  # one family per concept
    assert value(fams, completed, loop="main", outcome="done") == 4
    assert value(fams, completed, loop="main", outcome="unknown") == 1


def test_websocket_clients_and_drops():
    stats = WsStats()
    for _ in range(3):
        stats.connected()
    stats.disconnected()
    stats.dropped()
    stats.disconnected()
    stats.dropped("ping")
    fams = parse_exposition(Metrics(None, ws=stats).render())
    assert value(fams, "rc233_ws_clients") == 1
    assert value(fams, "rc233_ws_connections_total") == 3
    assert value(fams, "rc233_ws_dropped_clients_total", reason="backlog") == 1
    assert value(fams, "rc233_ws_dropped_clients_total", reason="ping") == 1


# ---------------------------------------------------------------------- through an app


def build_app(gateway: Any) -> FastAPI:
    app = FastAPI()
    install_problem_handlers(app)
    install_security(app, AuthConfig())  # tokens required, none known: probes stay open
    install_health_and_metrics(app, gateway)
    api = APIRouter()

    @api.get("/axes/{ident}")
    async def axis(ident: str) -> dict[str, str]:
        return {"id": ident}

    @api.post("/axes/{ident}/fail")
    async def fail(ident: str) -> None:
        raise RuntimeError("defect")

    app.include_router(api, prefix="/api/v1")
    return app


async def test_http_requests_are_counted_by_route_template_method_and_status():
    gateway, _ = fake_gateway()
    transport = httpx.ASGITransport(app=build_app(gateway))
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as client:
        for ident in ("main.1.1", "main.1.2", "x"):
            assert (await client.get(f"/api/v1/axes/{ident}")).status_code == 200
        assert (await client.post("/api/v1/axes/x/fail")).status_code == 500
        assert (await client.get("/wp-login.php")).status_code == 404
        r = await client.get("/metrics")
    assert r.status_code == 200
    assert r.headers["content-type"] == CONTENT_TYPE
    fams = parse_exposition(r.text)
    requests = "rc233_http_requests_total"
    route = "/api/v1/axes/{ident}"
    assert value(fams, requests, route=route, method="GET", status="200") == 3
    assert value(fams, requests, route=route + "/fail", method="POST", status="500") == 1
    assert value(fams, requests, route="<unmatched>", method="GET", status="404") == 1
    duration = "rc233_http_request_duration_seconds"
    assert value(fams, f"{duration}_count", route=route, method="GET") == 3
    # no series per concrete id or scanned path
    routes = {dict(labels)["route"] for (_, labels) in fams[requests].samples}
    assert routes == {route, route + "/fail", "<unmatched>"}


async def test_healthz_and_readyz_need_no_token_and_name_the_loops_down():
    gateway, _ = fake_gateway()
    transport = httpx.ASGITransport(app=build_app(gateway))
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as client:
        assert (await client.get("/healthz")).json() == {"status": "ok"}
        r = await client.get("/readyz")
        assert r.status_code == 503
        assert r.headers["content-type"] == "application/problem+json"
        body = r.json()
        assert body["loops_down"] == ["aux"]
        assert "aux (down: port gone)" in body["detail"]
        gateway.schedulers["aux"].state = LinkState.UP
        r = await client.get("/readyz")
        assert r.status_code == 200
        assert r.json() == {"status": "ready", "loops": {"aux": "up", "main": "up"}}
        assert (await client.get("/metrics")).status_code == 200


# ---------------------------------------------------------------------- a real loop


async def test_a_simulated_loop_counts_every_transaction():
    sim = build_loop(["1"], clock=SimClock(50.0))
    gateway = Runtime(
        simulated_config(("1",)),
        transports={SIM_LOOP: PipeTransport(lambda: SimPort(sim))},
        time_scale=50.0,
    )
    app = build_app(gateway)
    metrics: Metrics = app.state.metrics
    try:
        await gateway.start()
        scheduler = gateway.schedulers[SIM_LOOP]
        for _ in range(3):
            result = await scheduler.submit("1", parse("V"))
            assert result.ok
        text = metrics.render()
        snapshot = scheduler.snapshot()  # no await since render: the same moment
    finally:
        await gateway.close()
        sim.close()
    fams = parse_exposition(text)
    hist = "rc233_loop_transaction_duration_seconds"
    counts = {dict(k[1])["priority"]: v for k, v in fams[hist].samples.items()
              if k[0] == f"{hist}_count"}  # fmt: skip
    assert counts["operator"] == 3  # ours; the poller's are at poll priority
    by_outcome = {dict(k[1])["outcome"]: v for k, v in fams["rc233_loop_transactions_total"]
                  .samples.items() if dict(k[1])["loop"] == SIM_LOOP}  # fmt: skip
    assert sum(by_outcome.values()) == snapshot.transactions
    assert sum(counts.values()) == snapshot.transactions
    assert value(fams, "rc233_loop_exchanges_total", loop=SIM_LOOP) == snapshot.exchanges
    assert value(fams, "rc233_loop_bytes_sent_total", loop=SIM_LOOP) == snapshot.bytes_out > 0
    utilisation = value(fams, "rc233_loop_line_utilisation_ratio", loop=SIM_LOOP)
    assert 0 < utilisation <= 1
    assert value(fams, "rc233_loop_up", loop=SIM_LOOP) == 1


def test_a_tally_of_polls_counts_as_the_transactions_it_stands_for():
    # A line worker sends an idle loop's polls as one TransactionsTallied a second.
    figures = [(0.004, Priority.POLL, Outcome.DONE), (0.03, Priority.POLL, Outcome.DONE),
               (0.3, Priority.POLL, Outcome.UNKNOWN)]  # fmt: skip
    one_by_one, clock = fake_gateway()
    metrics_one = Metrics(one_by_one)
    for seconds, priority, outcome in figures:
        one_by_one.schedulers["main"].events.publish(done("main", seconds, priority, outcome))
    tallied, _ = fake_gateway()
    metrics_tallied = Metrics(tallied)
    rows = tuple(
        TransactionTally("1", priority, outcome, seconds, 1, 0, 0)
        for seconds, priority, outcome in figures
    )
    tallied.schedulers["main"].events.publish(
        TransactionsTallied(loop="main", tallies=rows, counters=CountersSnapshot())
    )
    clock.now = 110.0
    watched = ("rc233_loop_transaction_duration_seconds", "rc233_loop_transactions_total",
               "rc233_loop_busy_seconds_total")  # fmt: skip
    one = parse_exposition(metrics_one.render())
    many = parse_exposition(metrics_tallied.render())
    for name in watched:
        assert many[name].samples == one[name].samples, name
    assert value(many, "rc233_loop_transactions_total", loop="main", outcome="done") == 2
    poll = {"loop": "main", "priority": "poll"}
    assert value(many, "rc233_loop_transaction_duration_seconds_count", **poll) == 3
