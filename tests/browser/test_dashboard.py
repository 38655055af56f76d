"""The dashboard in a real Chromium against ``rc233-gateway serve --simulate`` as a process.

Each test acts as a user would (types, presses, holds, releases) and checks what reached the
simulated line (its line log, through the control surface) and what the page shows. The
simulated cell: controller 1 (gantry) x, y; 2 (head) z, theta; 3 (handler) gripper, conveyor;
x is 0.01 mm a pulse. The tests share one gateway; the line cut comes last.
"""

from __future__ import annotations

import re
import urllib.request

import pytest
from playwright.sync_api import Error as PlaywrightError
from playwright.sync_api import expect

from tests.support.browser_rig import Gateway, Session, open_page, page_event_when, shot

AXES = ("x", "y", "z", "theta", "gripper", "conveyor")


def sim_position(gw: Gateway, body: str, motor: int) -> int:
    assert gw.line is not None
    state = gw.line.call("state")["state"]
    unit = next(u for u in state["units"] if u["name"] == body)
    return int(unit["controller"]["axes"][str(motor)]["position"])


def test_the_page_comes_from_the_gateway_alone_and_shows_every_axis(
    gateway: Gateway, session: Session, browser
) -> None:
    page = session.page
    response = page.goto(gateway.url + "/")
    assert response is not None and response.status == 200
    csp = response.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "script-src 'self'" in csp and "http" not in csp
    assert response.headers["cache-control"] == "no-cache"
    for name in AXES:
        expect(page.get_by_test_id(f"axis-{name}")).to_be_visible()
    expect(page.get_by_test_id("connection")).to_have_text("live")
    expect(page.get_by_test_id("loop-sim")).to_contain_text("UP")
    # every stop is in reach without scrolling: the stop-all and each loop's stop
    for stop in ("stop-all", "stop-loop-sim"):
        box = page.get_by_test_id(stop).bounding_box()
        assert box is not None and box["y"] + box["height"] <= 800
    expect(page.get_by_test_id("axis-x").get_by_test_id("position")).to_have_text(re.compile(r"\d"))
    shot(page, "overview")
    # the API docs come from the vendored Swagger UI, from the gateway too
    page.goto(gateway.url + "/api/v1/docs")
    expect(page.locator(".swagger-ui .info .title")).to_contain_text("rc233-gateway")
    expect(
        page.locator(".opblock-summary-path", has_text="/api/v1/loops/{loop}/stop")
    ).to_be_visible()
    assert session.errors == [], session.errors
    # a phone: one column, the digits still large
    phone = open_page(browser, 390, 844)
    try:
        phone.page.goto(gateway.url + "/")
        x, y = phone.page.get_by_test_id("axis-x"), phone.page.get_by_test_id("axis-y")
        expect(y).to_be_visible()
        bx, by = x.bounding_box(), y.bounding_box()
        assert bx and by and by["y"] >= bx["y"] + bx["height"]  # stacked
        size = x.get_by_test_id("position").evaluate(
            "e => parseFloat(getComputedStyle(e).fontSize)"
        )
        assert size >= 30
        shot(phone.page, "phone")
        assert phone.foreign == []
    finally:
        phone.context.close()


#: What ReDoc tries that its page's policy refuses, and only that: its search's probe of
#: ``Function`` for a worker (it then searches in the page) and its logo from its CDN.
REDOC_REFUSED = [
    ["img-src", "https://cdn.redoc.ly/redoc/logo-mini-full.svg"],
    ["script-src", "eval"],
]


def test_redoc_runs_from_vendored_files_under_the_pages_policy(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    page.add_init_script(
        "window.__refused = [];"
        "document.addEventListener('securitypolicyviolation',"
        " e => window.__refused.push([e.effectiveDirective, e.blockedURI]));"
    )
    response = page.goto(gateway.url + "/api/v1/redoc")
    assert response is not None and response.status == 200
    policy = response.headers["content-security-policy"]
    assert "script-src 'self';" in policy and "unsafe" not in policy
    expect(page.locator("h1")).to_contain_text("rc233-gateway")
    expect(page.get_by_text("loops", exact=True).first).to_be_visible()  # the tags
    # the search works (in the page: the worker it would make needs eval)
    page.get_by_text("Search Ctrl+K").first.click()
    page.get_by_placeholder("Search docs...").fill("stop")
    expect(page.get_by_text("/api/v1/loops/{loop}/stop")).to_be_visible()
    refused = page.evaluate("window.__refused")
    assert sorted(refused) == sorted(REDOC_REFUSED), refused
    shot(page, "redoc")


def test_the_guard_aborts_what_would_leave_127_0_0_1(gateway: Gateway, session: Session) -> None:
    """The check the other tests rely on: a request elsewhere is aborted and recorded (a
    navigation: the page's own fetches to other hosts are already refused by its CSP)."""
    session.page.goto(gateway.url + "/")
    refused = session.page.evaluate(
        "() => fetch('http://192.0.2.1/probe').then(() => false, () => true)"
    )
    assert refused  # the CSP: connect-src 'self'
    with pytest.raises(PlaywrightError):
        session.page.goto("http://192.0.2.1/probe")
    assert session.foreign == ["http://192.0.2.1/probe"]
    session.foreign.clear()


def test_a_move_typed_in_mm_ends_at_the_right_pulses(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/#/axis/x")
    form = page.get_by_test_id("move-form")
    expect(form.get_by_test_id("move-unit")).to_have_value("user")
    expect(form).to_contain_text("mm")
    mark = gateway.line.mark()
    form.get_by_test_id("move-value").fill("12.5")
    form.get_by_test_id("move-go").click()
    # 12.5 mm at 0.01 mm a pulse: position data 1250, then the absolute move (§10 2, 3)
    gateway.line.wait_heard(mark, lambda h: "21250" in h and "3" in h[h.index("21250") :])
    op = page.get_by_test_id("axis-page").get_by_test_id("op")
    expect(op).to_contain_text("done", timeout=30_000)
    expect(op).to_contain_text("12.500 mm")
    assert sim_position(gateway, "1", 1) == 1250
    expect(page.get_by_test_id("axis-page").get_by_test_id("pulses")).to_have_text("1,250")
    # the speed profile in the data of chapter 7 and in pps (OH 5000 at OX 300: 5,000 pps)
    expect(page.locator("form.speed")).to_contain_text("5,000 pps")
    shot(page, "axis")


def test_holding_jog_jogs_and_releasing_stops_within_200_ms(
    gateway: Gateway, session: Session
) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/")
    expect(page.get_by_test_id("connection")).to_have_text("live")
    expect(page.get_by_test_id("axis-y").locator("canvas")).to_be_visible()  # laid out
    button = page.get_by_test_id("axis-y").get_by_test_id("jog-cw")
    button.hover()
    mark = gateway.line.mark()
    page.mouse.down()
    # y is motor 2 of controller 1 and has soft limits: its jog is a move to the soft limit at
    # the jog speed (OH set to OL, 2{limit}, then 3; docs/api-notes.md "A jog toward a soft
    # limit is a move to it")
    gateway.line.wait_heard(mark, lambda h: "3" in h or "32" in h)
    expect(page.get_by_test_id("axis-y")).to_contain_text("MOVING")
    shot(page, "overview-live")  # the README's picture: x where the move left it, y jogging
    after_jog = gateway.line.mark()
    page.mouse.up()
    gateway.line.wait_heard(after_jog, lambda h: "S" in h or "SS" in h, timeout=5)
    # from the page's pointerup to the moment the controller heard the stop (the simulator's
    # record time: the test's own reads of the line log do not count)
    took = gateway.line.heard_when(after_jog, ("S", "SS")) - page_event_when(page, "pointerup")
    print(f"release to stop on the line: {took * 1000:.0f} ms")
    assert 0 < took < 0.2, f"the stop reached the line {took * 1000:.0f} ms after the release"
    expect(page.get_by_test_id("axis-y")).to_contain_text("STOPPED")


def test_the_stop_button_stops_a_long_move(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/#/axis/z")
    axis = page.get_by_test_id("axis-page")
    axis.get_by_test_id("move-value").fill("900")
    axis.get_by_test_id("move-go").click()
    expect(axis).to_contain_text("MOVING")
    mark = gateway.line.mark()
    axis.get_by_test_id("stop").click()  # no confirmation asked
    gateway.line.wait_heard(mark, lambda h: "SS" in h)
    expect(axis.get_by_test_id("op")).to_contain_text("failed")
    expect(axis).to_contain_text("STOPPED")
    assert 0 < sim_position(gateway, "2", 1) < 90_000


def test_escape_stops_the_axis_in_focus(gateway: Gateway, session: Session) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/#/axis/theta")
    axis = page.get_by_test_id("axis-page")
    value = axis.get_by_test_id("move-value")
    value.fill("800")
    value.press("Enter")
    expect(axis).to_contain_text("MOVING")
    mark = gateway.line.mark()
    value.press("Escape")  # the focus is in theta's page: theta stops, nothing else
    gateway.line.wait_heard(mark, lambda h: "SS" in h)
    assert "SS" in gateway.line.heard(mark, body="2")
    assert [
        t for b in ("1", "3") for t in gateway.line.heard(mark, body=b) if t in ("S", "SS")
    ] == []
    expect(axis).to_contain_text("STOPPED")


def test_ems_shows_as_a_latched_error_that_acknowledge_clears(
    gateway: Gateway, session: Session
) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/")
    card = page.get_by_test_id("axis-gripper")
    expect(card).to_be_visible()
    gateway.line.call("ems", body="3", pressed=True)
    expect(card.get_by_test_id("error-emergency")).to_be_visible()
    gateway.line.call("ems", body="3", pressed=False)
    # latched: still shown after the button is released, until someone acknowledges
    expect(card.get_by_test_id("error-emergency")).to_be_visible()
    page.once("dialog", lambda dialog: dialog.accept())
    card.get_by_role("button", name="Acknowledge").click()
    expect(card.get_by_test_id("error-emergency")).to_have_count(0)


def test_the_program_editor_shows_the_step_of_an_error(gateway: Gateway, session: Session) -> None:
    page = session.page
    page.goto(gateway.url + "/#/program/sim.1")
    editor = page.get_by_test_id("program-text")
    check = page.get_by_test_id("program-check")
    expect(check).to_contain_text("✓")
    editor.fill("/D00\n/J+5\n/END")  # a jump past the end (§12)
    expect(check).to_contain_text("step 2")
    expect(page.locator(".gutter .bad")).to_have_text("2")
    shot(page, "program")
    # upload, then read back from the controller's RAM (IR) into the editor
    editor.fill("/D00\n/0\n/END")
    expect(check).to_contain_text("✓ 3 steps")
    page.get_by_role("button", name="Upload").click()
    expect(page.get_by_text("Upload: done")).to_be_visible()
    editor.fill("")
    page.get_by_role("button", name="Read back").click()
    expect(editor).to_have_value("/D00\n/0\n/END")


def test_the_line_trace_shows_the_frames_for_admins(gateway: Gateway, session: Session) -> None:
    page = session.page
    page.goto(gateway.url + "/#/trace/sim")
    page.get_by_label("trace on").check()
    trace = page.get_by_role("log")
    # the poller's status reads of controller 1 and their replies, with timestamps
    expect(trace.locator(".tl.tx", has_text="$1").first).to_be_visible()
    expect(trace.locator(".tl.rx").first).to_contain_text(re.compile(r"\d\d:\d\d:\d\d\.\d{3}"))
    page.get_by_label("hex").check()
    expect(trace.locator(".tl.tx").last).to_contain_text(re.compile(r"24 3[0-9]"))  # '$' '1'..
    page.get_by_label("hex").uncheck()
    expect(page.get_by_label("hex")).not_to_be_checked()
    page.get_by_label("trace on").uncheck()


def test_killing_the_line_shows_the_loop_down_and_greys_the_values(
    gateway: Gateway, session: Session
) -> None:
    assert gateway.line is not None
    page = session.page
    page.goto(gateway.url + "/")
    card = page.get_by_test_id("axis-x")
    expect(card).not_to_have_class(re.compile(r"\bgrey\b"))
    gateway.line.call("cut", cut=True)
    try:
        loop = page.get_by_test_id("loop-sim")
        expect(loop).to_contain_text("DOWN", timeout=30_000)
        expect(loop.get_by_test_id("loop-cause")).not_to_be_empty()
        shot(page, "loop-down")
        for name in AXES:
            expect(page.get_by_test_id(f"axis-{name}")).to_have_class(re.compile(r"\bgrey\b"))
        opacity = card.get_by_test_id("position").evaluate("e => getComputedStyle(e).opacity")
        assert float(opacity) < 0.5
    finally:
        gateway.line.call("cut", cut=False)
    expect(page.get_by_test_id("loop-sim")).to_contain_text("UP", timeout=30_000)


def test_static_files_carry_cache_and_security_headers(gateway: Gateway) -> None:
    with urllib.request.urlopen(gateway.url + "/static/vendor/uplot/uPlot.esm.js") as r:
        assert r.headers["cache-control"].startswith("public, max-age=")
        assert r.headers["x-content-type-options"] == "nosniff"
        assert "default-src 'self'" in r.headers["content-security-policy"]
    with urllib.request.urlopen(gateway.url + "/static/js/app.js") as r:
        assert r.headers["cache-control"] == "no-cache" and r.headers["etag"]
