"""The dashboard's program console, jog guards and settings pages in a real Chromium.

Against ``rc233-gateway serve --simulate`` as a process, the one ``test_dashboard.py`` uses
(these tests change z's speed data, entry 3 of controller 1's position table and output 3 of
controller 3, which nothing else here reads). What the
user does in the page must end on the simulated line as the frame the manual gives, read
from the simulator's line log; the console must show what the program printed, in order.
"""

from __future__ import annotations

import json
import re
import time
import urllib.request
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from playwright.sync_api import Page, WebSocketRoute, expect

from tests.support.browser_rig import WAIT, Gateway, Session, page_event_when

#: A stop on the line: ``S`` (at once) or ``SS`` (decelerating), §10 S, SS.
STOPS = ("S", "SS")


@pytest.fixture
def y_stopped_after(gateway: Gateway) -> Iterator[None]:
    """A jog test that fails half-way leaves y stopped for the next one (a jog toward the
    soft limit runs for minutes)."""
    yield
    stop = urllib.request.Request(
        gateway.url + "/api/v1/axes/sim.1.2/stop",
        data=b'{"mode": "immediate"}',
        headers={"Content-Type": "application/json"},
        method="POST",
    )
    with urllib.request.urlopen(stop) as answer:
        assert answer.status == 200


def _until_idle(gateway: Gateway, controller: str) -> None:
    """Read ``controller`` from the device until no motor moves and no program runs: what an
    earlier test started (a jog stopped, a program ended) may still be settling, and the
    controller refuses settings until then (§10 A: not while moving)."""
    deadline = time.monotonic() + WAIT
    while True:
        url = f"{gateway.url}/api/v1/controllers/{controller}?fresh=true"
        with urllib.request.urlopen(url) as answer:  # each read waits on the line
            view = json.load(answer)
        if not view["moving"] and view["program"] != "1":
            return
        assert time.monotonic() < deadline, f"{controller} still busy after {WAIT} s: {view}"


def _overview(gateway: Gateway, page: Page) -> None:
    page.goto(gateway.url + "/")
    expect(page.get_by_test_id("connection")).to_have_text("live")


def _start_jog(gateway: Gateway, page: Page) -> None:
    """Hold jog ▶ on y's card until the jog is on the line and the card says MOVING."""
    assert gateway.line is not None
    card = page.get_by_test_id("axis-y")
    expect(card).to_contain_text("STOPPED")
    card.get_by_test_id("jog-cw").hover()
    mark = gateway.line.mark()
    page.mouse.down()
    # y has soft limits: its jog is a move to the limit at the jog speed (ends with 3, §10 3)
    gateway.line.wait_heard(mark, lambda h: "3" in h)
    expect(card).to_contain_text("MOVING")


def _stops_within_200_ms(
    gateway: Gateway, page: Page, trigger: Callable[[], Any], event: str
) -> None:
    """``trigger()`` while the jog runs: a stop frame reaches the line within 200 ms of the
    page's ``event``."""
    assert gateway.line is not None
    mark = gateway.line.mark()
    trigger()
    heard, _ = gateway.line.wait_heard(mark, lambda h: any(f in STOPS for f in h), timeout=5)
    # from the event in the page to the moment the controller heard the stop (the
    # simulator's record time: the test's own reads of the line log do not count)
    took = gateway.line.heard_when(mark, STOPS) - page_event_when(page, event)
    print(f"trigger to stop on the line: {took * 1000:.0f} ms ({heard})")
    assert 0 < took < 0.2, f"the stop reached the line {took * 1000:.0f} ms after the trigger"
    # and it was the jog's axis that stopped: y is motor 2 of controller 1
    assert [f for f in gateway.line.heard(mark, body="1") if f in STOPS]
    page.mouse.up()


@pytest.mark.usefixtures("y_stopped_after")
def test_the_jog_stops_when_the_page_loses_focus(gateway: Gateway, session: Session) -> None:
    page = session.page
    _overview(gateway, page)
    # Playwright tells every page it has the focus (again after each navigation); without
    # that emulation, bringing another page to the front takes it away as a real window
    # switch does (a real `blur`).
    cdp = session.context.new_cdp_session(page)
    cdp.send("Emulation.setFocusEmulationEnabled", {"enabled": False})
    other = session.context.new_page()
    page.bring_to_front()  # the real focus, to lose
    _start_jog(gateway, page)
    assert page.evaluate("document.hasFocus()")
    _stops_within_200_ms(gateway, page, other.bring_to_front, "blur")
    page.bring_to_front()
    expect(page.get_by_test_id("axis-y")).to_contain_text("STOPPED")


@pytest.mark.usefixtures("y_stopped_after")
def test_the_jog_stops_when_the_page_is_hidden(gateway: Gateway, session: Session) -> None:
    page = session.page
    _overview(gateway, page)
    _start_jog(gateway, page)
    # Headless Chromium never hides a page by itself: the document says it is hidden and the
    # event goes out, as a browser does when the tab goes to the background.
    hide = """() => {
        const say = (name, value) =>
            Object.defineProperty(document, name, { configurable: true, get: () => value });
        say("hidden", true);
        say("visibilityState", "hidden");
        document.dispatchEvent(new Event("visibilitychange"));
    }"""
    _stops_within_200_ms(gateway, page, lambda: page.evaluate(hide), "visibilitychange")
    expect(page.get_by_test_id("axis-y")).to_contain_text("STOPPED")


@pytest.mark.usefixtures("y_stopped_after")
def test_the_jog_stops_when_the_websocket_drops(gateway: Gateway, session: Session) -> None:
    page = session.page
    sockets: list[WebSocketRoute] = []

    def through(ws: WebSocketRoute) -> None:
        ws.connect_to_server()  # every message passes, until the test closes the page's side
        sockets.append(ws)

    page.route_web_socket(re.compile(r"/api/v1/ws"), through)
    _overview(gateway, page)
    _start_jog(gateway, page)
    assert sockets, "the page's WebSocket did not go through the route"
    # the page's socket closes (the gateway is still there: the stop goes out over REST)
    _stops_within_200_ms(
        gateway, page, lambda: sockets[-1].close(code=1011, reason="dropped"), "websocket-close"
    )
    # the page reconnects by itself and shows the stopped axis
    expect(page.get_by_test_id("connection")).to_have_text("live")
    expect(page.get_by_test_id("axis-y")).to_contain_text("STOPPED")


def test_a_running_program_prints_into_the_console_in_order(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    page.goto(gateway.url + "/#/program/sim.1")
    editor = page.get_by_test_id("program-text")
    editor.fill("/COFIRST1\n/COSECOND2\n/COTHIRD3\n/END")  # §12 /CO: `>text` CR each
    expect(page.get_by_test_id("program-check")).to_contain_text("✓ 4 steps")
    page.get_by_role("button", name="Upload").click()
    expect(page.get_by_text("Upload: done")).to_be_visible()
    page.get_by_role("button", name="Run").click()
    console = page.get_by_test_id("program-console")
    # one line each, in the order printed, on this controller (not as unattributed loop output)
    expect(console).to_contain_text("THIRD3")
    # each line: the time, two spaces, then "(loop) " when no controller was named, the text
    printed = [line.split("  ", 1)[1] for line in console.inner_text().strip().splitlines()]
    assert printed == ["FIRST1", "SECOND2", "THIRD3"], printed
    expect(page.locator(".muted", has_text="state ended")).to_be_visible()


def test_writing_the_speed_profile_sends_oh(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/#/axis/z")  # motor 1 of controller 2
    speed = page.locator("form.speed")
    high = speed.get_by_label("OH High speed")
    expect(high).to_have_value("5000")
    high.fill("3200")
    mark = gateway.line.mark()
    speed.get_by_role("button", name="Write speed data").click()
    # High speed of the selected motor (§10 OH: OH{hs}, 1 pps a unit at OX 300)
    gateway.line.wait_heard(mark, lambda h: "OH3200" in h)
    written = [f for f in gateway.line.heard(mark, body="2") if f.startswith("OH")]
    # one write, of the value typed; the reads of OH before and after it (the read-back) are
    # the query alone
    assert [f for f in written if f != "OH"] == ["OH3200"], written
    expect(speed).to_contain_text("3,200 pps")
    expect(high).to_have_value("3200")


def test_a_position_table_entry_written_in_settings(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    _until_idle(gateway, "sim.1")
    page = session.page
    page.goto(gateway.url + "/#/controller/sim.1")
    page.get_by_role("button", name="Read 10 entries").click()
    entry = page.get_by_label("position 3 in pulses", exact=True)
    expect(entry).to_be_visible()
    mark = gateway.line.mark()
    entry.fill("1234")
    entry.press("Tab")  # the change is committed when the field is left
    # entry 003 := 1234 pulses (§10 A: A{pn}{pp}, pn exactly 3 digits)
    gateway.line.wait_heard(mark, lambda h: "A0031234" in h)
    expect(page.get_by_text("Position 3 written")).to_be_visible()
    page.get_by_role("button", name="Read 10 entries").click()
    expect(page.get_by_label("position 3 in pulses", exact=True)).to_have_value("1234")


def test_switching_an_output_sends_d_bit_value_b(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/#/controller/sim.3")
    outputs = page.locator(".bits", has_text="outputs")
    bit = outputs.get_by_role("button", name="output 3", exact=True)
    expect(bit).to_have_attribute("aria-pressed", "false")
    mark = gateway.line.mark()
    bit.click()
    # one output bit ON (§10 D form II: D{bit}{value}B), to controller 3 only
    gateway.line.wait_heard(mark, lambda h: "D31B" in h)
    assert "D31B" in gateway.line.heard(mark, body="3")
    expect(bit).to_have_attribute("aria-pressed", "true")  # read back from the controller
    mark = gateway.line.mark()
    bit.click()
    gateway.line.wait_heard(mark, lambda h: "D30B" in h)
    expect(bit).to_have_attribute("aria-pressed", "false")


def _set_control(gateway: Gateway, state: str) -> None:
    request = urllib.request.Request(
        gateway.url + "/api/v1/controllers/sim.3/control",
        data=f'{{"state": "{state}"}}'.encode(),
        headers={"Content-Type": "application/json"},
        method="PUT",
    )
    with urllib.request.urlopen(request) as answer:
        assert answer.status == 200


def test_a_controller_in_local_control_says_so(gateway: Gateway, session: Session) -> None:
    """An admin puts controller 3 in local (a technician at the machine): its card says LOCAL
    and why, from the WebSocket, and the badge goes when it is remote again."""
    page = session.page
    _overview(gateway, page)
    badge = page.get_by_test_id("local-sim.3")
    expect(badge).to_have_count(0)
    _set_control(gateway, "local")
    try:
        expect(badge).to_have_text("LOCAL")
        assert "controller: anonymous" in (badge.locator(".badge").get_attribute("title") or "")
    finally:
        _set_control(gateway, "remote")
    expect(badge).to_have_count(0)
