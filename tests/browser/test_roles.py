"""Log-in and roles in the browser, against a gateway that asks for tokens.

``serve --simulate`` runs open on loopback, so this gateway is the path a real site takes:
``rc233-gateway sim --tcp`` as the serial device server and ``serve --config`` with tokens,
its loop on ``socket://``. A viewer sees the cell and no motion control; an operator sees
the stops and jogs but no admin control; a wrong token is a message, never a broken page.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Page, WebSocket, expect

from tests.support.browser_rig import GATEWAY, Gateway, Process, Session, free_port, shot

TOKENS = {"watcher": ("viewer", "view-token-1"), "shift": ("operator", "op-token-1")}


def _config(tmp: Path, sim_port: int) -> Path:
    lines = []
    for name, (role, token) in TOKENS.items():
        digest = hashlib.sha256(token.encode()).hexdigest()
        lines += ["[[security.tokens]]", f'name = "{name}"', f'role = "{role}"']
        lines += [f'sha256 = "{digest}"', ""]
    lines += [
        "[[loops]]",
        'name = "line1"',
        f'port = "socket://127.0.0.1:{sim_port}"',
        "[[loops.controllers]]",
        'body = "1"',
        'name = "gantry"',
        "[[loops.controllers.axes]]",
        "motor = 1",
        'name = "x"',
        'unit = "mm"',
        "units_per_pulse = 0.01",
    ]
    path = tmp / "cell.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def secured(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Gateway]:
    tmp = tmp_path_factory.mktemp("secured")
    sim_port, port = free_port(), free_port()
    sim = Process(
        [str(GATEWAY), "sim", "--tcp", f"127.0.0.1:{sim_port}", "--eeprom-dir", str(tmp)],
        tmp / "sim.log",
        env={"XDG_DATA_HOME": str(tmp)},
    )
    try:
        sim.wait_for(r"listening on")
        serve = Process(
            [str(GATEWAY), "serve", "--config", str(_config(tmp, sim_port)), "--port", str(port)],
            tmp / "serve.log",
        )
        running = Gateway(f"http://127.0.0.1:{port}", None, serve, [sim])
        try:
            serve.wait_for(r"Uvicorn running on")
            yield running
        finally:
            running.process.stop()  # the one a test restarted, if it did
    finally:
        sim.stop()


def _log_in(page: Page, url: str, token: str) -> None:
    page.goto(url + "/")
    form = page.get_by_test_id("login")
    form.get_by_test_id("token").fill(token)
    form.get_by_role("button", name="Log in").click()


def test_a_wrong_token_is_a_message_not_a_broken_page(secured: Gateway, session: Session) -> None:
    _log_in(session.page, secured.url, "not-a-token")
    form = session.page.get_by_test_id("login")
    expect(form.get_by_role("alert")).to_contain_text("401")
    expect(form.get_by_test_id("token")).to_be_visible()  # try again


def test_a_viewer_sees_the_cell_and_no_motion_controls(secured: Gateway, session: Session) -> None:
    page = session.page
    _log_in(page, secured.url, TOKENS["watcher"][1])
    expect(page.get_by_test_id("role")).to_have_text("watcher · viewer")
    card = page.get_by_test_id("axis-x")
    expect(card.get_by_test_id("position")).to_have_text(re.compile(r"\d"))
    expect(page.get_by_test_id("connection")).to_have_text("live")
    for control in ("stop", "jog-cw", "jog-ccw", "stop-all", "stop-loop-line1"):
        expect(page.get_by_test_id(control)).to_have_count(0)
    expect(page.get_by_role("button", name=re.compile("STOP|jog|Move|Acknowledge"))).to_have_count(
        0
    )
    page.goto(secured.url + "/#/axis/x")
    expect(page.get_by_test_id("axis-page")).to_contain_text("motion controls are for operators")
    expect(page.get_by_test_id("move-form")).to_have_count(0)
    expect(page.get_by_test_id("axis-page").locator(".plot canvas")).to_be_visible()
    # the token is kept for the browser session: a reload does not ask again
    page.reload()
    expect(page.get_by_test_id("role")).to_have_text("watcher · viewer")
    expect(page.get_by_test_id("axis-page").locator(".plot canvas")).to_be_visible()
    shot(page, "viewer")


def test_an_operator_gets_motion_but_no_admin_controls(secured: Gateway, session: Session) -> None:
    page = session.page
    _log_in(page, secured.url, TOKENS["shift"][1])
    expect(page.get_by_test_id("role")).to_have_text("shift · operator")
    expect(page.get_by_test_id("axis-x").get_by_test_id("stop")).to_be_visible()
    expect(page.get_by_test_id("stop-loop-line1")).to_be_visible()
    expect(page.get_by_role("link", name="Line trace")).to_have_count(0)
    page.goto(secured.url + "/#/program/line1.1")
    expect(page.get_by_role("button", name="Run")).to_be_visible()
    expect(page.get_by_role("button", name="Upload")).to_have_count(0)
    page.get_by_role("button", name="log out").click()
    expect(page.get_by_test_id("login")).to_be_visible()


def test_a_lost_connection_is_a_banner_and_grey_values_then_it_resumes(
    secured: Gateway, session: Session
) -> None:
    page = session.page
    subscribes: list[dict[str, object]] = []

    def watch(ws: WebSocket) -> None:
        ws.on("framesent", lambda payload: subscribes.append(json.loads(payload)))

    page.on("websocket", watch)
    _log_in(page, secured.url, TOKENS["watcher"][1])
    card = page.get_by_test_id("axis-x")
    expect(card.get_by_test_id("position")).to_have_text(re.compile(r"\d"))
    expect(page.get_by_test_id("banner")).to_have_count(0)
    # the gateway goes away: a banner, and every value greyed (never silently old)
    argv = [str(a) for a in secured.process.proc.args]
    secured.process.stop()
    expect(page.get_by_test_id("banner")).to_contain_text("Disconnected")
    expect(page.get_by_test_id("loop-line1")).to_contain_text("UNKNOWN")  # not "UP" any more
    opacity = card.get_by_test_id("position").evaluate("e => getComputedStyle(e).opacity")
    assert float(opacity) < 0.5
    shot(page, "disconnected")
    # back: the page reconnects by itself, says where it was (since, stream), shows live values
    secured.process = Process(argv, secured.process.log.with_name("serve-again.log"))
    secured.process.wait_for(r"Uvicorn running on")
    expect(page.get_by_test_id("connection")).to_have_text("live", timeout=20_000)
    expect(page.get_by_test_id("banner")).to_have_count(0)
    first, again = subscribes[0], subscribes[-1]
    assert first["type"] == again["type"] == "subscribe" and "since" not in first
    assert isinstance(again["since"], int) and again["since"] > 0 and again["stream"]
    opacity = card.get_by_test_id("position").evaluate("e => getComputedStyle(e).opacity")
    assert float(opacity) == 1
