"""What the dashboard says is what the gateway and the device hold, in a real Chromium.

Against the ``serve --simulate`` process the other browser tests share: the position table
shows what the controller holds after a write, the age of a reading is the gateway's, the
program's state follows the program to its end and a refused program says what is wrong, the
soft-limit bar starts where the controller can really go, sensors in their normal state are
not shown as alarms, inputs are indicators, and every time on the page is 24-hour.
(These tests write entry 5 of controller 2's position table and run a program on
controller 2, which nothing else here reads.)
"""

from __future__ import annotations

import json
import re
import time
import urllib.request
from typing import Any

from playwright.sync_api import Page, expect

from tests.support.browser_rig import WAIT, Gateway, Session, shot

#: Colours of style.css the tests tell apart: an alarm badge, an ON output.
ALARM = "rgb(255, 179, 71)"  # --warn


def api_get(gateway: Gateway, path: str) -> Any:
    with urllib.request.urlopen(gateway.url + "/api/v1" + path) as answer:
        return json.load(answer)


def api_post(gateway: Gateway, path: str, body: str = "{}") -> Any:
    request = urllib.request.Request(
        gateway.url + "/api/v1" + path,
        data=body.encode(),
        headers={"Content-Type": "application/json"},
        method="POST",
    )
    with urllib.request.urlopen(request) as answer:
        return json.load(answer)


def _live(gateway: Gateway, page: Page, where: str = "/") -> None:
    page.goto(gateway.url + where)
    expect(page.get_by_test_id("connection")).to_have_text("live")


def _page_time_passes(page: Page, seconds: float) -> None:
    """Wait until the page's own clock says ``seconds`` have passed: the page redraws every
    second, so this many redraws have happened (the condition is the page's clock)."""
    until = page.evaluate("() => Date.now()") + seconds * 1000
    page.wait_for_function("t => Date.now() > t", arg=until, timeout=(seconds + WAIT) * 1000)


def test_a_written_position_table_entry_stays_in_its_field(
    gateway: Gateway, session: Session
) -> None:
    assert gateway.line is not None
    page = session.page
    _live(gateway, page, "/#/controller/sim.2")
    page.get_by_role("button", name="Read 10 entries").click()
    entry = page.get_by_label(re.compile(r"^position 5\b"))
    expect(entry).to_be_visible()
    mark = gateway.line.mark()
    entry.fill("1234")
    _page_time_passes(page, 1.5)  # redraws while the field holds what was typed
    expect(entry).to_have_value("1234")
    entry.press("Tab")
    gateway.line.wait_heard(mark, lambda h: "A0051234" in h)  # §10 A: A{pn}{pp}
    expect(page.get_by_text("Position 5 written")).to_be_visible()
    # several redraws later the field still shows what the controller holds
    _page_time_passes(page, 2.5)
    expect(entry).to_have_value("1234")
    assert api_get(gateway, "/controllers/sim.2/positions/5")["position"] == 1234


def test_the_age_of_an_idle_reading_is_the_gateways(gateway: Gateway, session: Session) -> None:
    page = session.page
    _live(gateway, page)
    card = page.get_by_test_id("axis-theta")  # nothing here moves theta
    expect(card).to_be_visible()
    # long enough for the feed's last change of theta to be old
    _page_time_passes(page, 8)
    server = api_get(gateway, "/axes/theta")
    assert not server["moving"] and time.time() - server["updated"] < 3, server
    expect(card.locator(".age")).to_have_text(re.compile(r"^(now|[0-4] s ago)$"))


def test_the_program_state_follows_the_program_to_its_end_in_24_hour_times(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    _live(gateway, page, "/#/program/sim.2")
    editor = page.get_by_test_id("program-text")
    # z (motor 1 of controller 2) moves 2,000 pulses and back: the program runs for a while
    editor.fill("/COSTART\n/22000\n/3\n/\n/20\n/3\n/\n/CODONE\n/END")
    expect(page.get_by_test_id("program-check")).to_contain_text("✓ 9 steps")
    page.get_by_role("button", name="Upload").click()
    expect(page.get_by_text("Upload: done")).to_be_visible()
    page.get_by_role("button", name="Run").click()
    console = page.get_by_test_id("program-console")
    expect(console).to_contain_text("DONE")
    state = page.locator("header .muted", has_text=re.compile("^state "))
    # ended, and no "next step" of a program that has none left to run
    expect(state).to_have_text("state ended")
    lines = console.inner_text().strip().splitlines()
    assert lines and all(re.match(r"^\d\d:\d\d:\d\d  ", line) for line in lines), lines
    assert not re.search(r"\b(AM|PM)\b", console.inner_text())


def test_a_refused_program_names_the_statement_the_target_and_why(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    _live(gateway, page, "/#/program/sim.2")
    page.get_by_test_id("program-text").fill("/D00\n/J+5\n/END")
    check = page.get_by_test_id("program-check")
    expect(check).to_contain_text("step 2: '/J+5' lands on step 8")
    expect(check).to_contain_text("5 on from step 3")
    expect(check).to_contain_text("steps 1-3 only")
    expect(check).to_contain_text("§12 JUMP table")


def test_inputs_are_indicators_and_outputs_are_switches(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    gateway.line.call("input", body="3", bit=2, on=True)
    try:
        _live(gateway, page, "/#/controller/sim.3")
        inputs = page.locator(".bits", has_text="inputs")
        outputs = page.locator(".bits", has_text="outputs")
        expect(outputs.get_by_role("button")).to_have_count(8)
        expect(inputs.get_by_role("button")).to_have_count(0)
        expect(inputs.get_by_role("img", name="input 2 on")).to_be_visible()
        expect(inputs.get_by_role("img", name="input 3 off")).to_be_visible()
        lamp = inputs.get_by_role("img", name="input 3 off")
        look = lamp.evaluate(
            "e => { const s = getComputedStyle(e); return [s.cursor, s.borderRadius] }"
        )
        button = outputs.get_by_role("button", name="output 3").evaluate(
            "e => { const s = getComputedStyle(e); return [s.cursor, s.borderRadius] }"
        )
        assert look[0] != "pointer" and look[1] == "50%" and look != button, (look, button)
        shot(page, "settings")
    finally:
        gateway.line.call("input", body="3", bit=2, on=False)


def test_the_limit_bar_of_an_unsigned_controller_starts_at_0(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    _live(gateway, page)
    view = api_get(gateway, "/controllers/sim.1")
    assert view["mode"] == 0 and view["signed_positions"] in (False, None), view
    assert api_get(gateway, "/axes/x")["soft_min"] == -40.0
    bar = page.get_by_test_id("axis-x").locator(".limitbar")
    # EP0 counts no position below 0 (§10 EP, §7-4): 0 is where x can really go
    expect(bar.locator(".lim.lo")).to_have_text("0")
    expect(bar.locator(".lim.hi")).to_have_text("940")
    assert "unsigned" in (bar.get_attribute("title") or "")
    # a controller that counts signed (EP1) can go below 0: its bar starts at the soft limit
    z_low = page.get_by_test_id("axis-z").locator(".limitbar .lim.lo")
    expect(z_low).to_have_text("0")
    api_post(gateway, "/controllers/sim.2/commands", '{"command": "EP1"}')
    try:
        expect(z_low).to_have_text("-40")
    finally:
        api_post(gateway, "/controllers/sim.2/commands", '{"command": "EP0"}')
    expect(z_low).to_have_text("0")


def test_a_sensor_in_its_normal_state_is_not_an_alarm(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    _live(gateway, page, "/#/axis/x")
    step_out = page.locator(".sensor", has_text=re.compile("step.out sensor"))
    # the step-out sensor is ON at rest in the simulated cell's scene: a normal state, shown
    # ON (and not as an alarm)
    expect(step_out).to_have_class(re.compile(r"\bon\b"))
    expect(step_out).to_have_text("step-out sensor ON")
    assert step_out.evaluate("e => getComputedStyle(e).backgroundColor") != ALARM
    # a limit sensor ON is an alarm (§8: the motor stops, a limit error): conveyor's CW limit
    gateway.line.call("sensor", body="3", motor=2, sensor="cw_limit", on=True)
    try:
        _live(gateway, page, "/#/axis/conveyor")
        limit = page.get_by_test_id("sensor-cw_limit")
        expect(limit).to_have_text("CW limit ON")
        expect(limit).to_have_css("background-color", ALARM)
    finally:
        gateway.line.call("sensor", body="3", motor=2, sensor="cw_limit", on=None)
        api_post(gateway, "/axes/conveyor/errors/ack")
    expect(page.get_by_test_id("sensor-cw_limit")).to_have_text("CW limit off")
