"""The dashboard says what the gateway knows of origins, motion and positions, never more.

A gateway of this module's own (``serve --simulate --config``, ten times real speed), since
these tests power-cycle a controller and run an axis into its limit: controller 1 (``gantry``:
x, y in mm with soft limits) and controller 2 (``free``: u, v in mm without soft limits). A
second gateway whose one loop never comes up holds axes that were never read. Through a real
Chromium: the origin unknown, lost (with the cause of the feed's ``origin`` event, and the
moves the gateway would refuse disabled with the reason) and homed again; a counter wrapped
below 0; positions and motion never read; latched errors by name; the speed profile not read
while a motor of the controller moves.
"""

from __future__ import annotations

import json
import re
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser, Page, expect

from tests.support.browser_rig import (
    GATEWAY,
    Gateway,
    Process,
    Session,
    free_port,
    open_page,
    shot,
    start_simulated,
)

AXES = """
[[loops.controllers.axes]]
motor = 1
name = "{one}"
unit = "mm"
units_per_pulse = 0.01
{limits}
[[loops.controllers.axes]]
motor = 2
name = "{two}"
unit = "mm"
units_per_pulse = 0.01
{limits}
"""
LIMITS = "soft_min = -40.0\nsoft_max = 940.0\n"


def cell_file(tmp: Path, port: str) -> Path:
    """Controller 1 with soft limits, controller 2 without, on one loop at ``port``."""
    text = f'[[loops]]\nname = "sim"\nport = "{port}"\n'
    text += '[[loops.controllers]]\nbody = "1"\nname = "gantry"\n'
    text += AXES.format(one="x", two="y", limits=LIMITS)
    text += '[[loops.controllers]]\nbody = "2"\nname = "free"\n'
    text += AXES.format(one="u", two="v", limits="")
    path = tmp / f"cell-{abs(hash(port))}.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Gateway]:
    tmp = tmp_path_factory.mktemp("origin")
    # The port is replaced by the simulated line.
    config = cell_file(tmp, "/dev/ttyUSB-simulated")
    running = start_simulated(tmp, "--config", str(config), "--time-scale", "10")
    yield running
    assert running.line is not None
    running.line.close()
    running.process.stop()


@pytest.fixture(scope="module")
def unread(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Gateway]:
    """A gateway whose loop is on a TCP port nobody listens at: nothing is ever read."""
    tmp = tmp_path_factory.mktemp("unread")
    config = cell_file(tmp, f"socket://127.0.0.1:{free_port()}")
    port = free_port()
    process = Process(
        [str(GATEWAY), "serve", "--config", str(config), "--no-auth", "--port", str(port)],
        tmp / "serve.log",
        env={"XDG_DATA_HOME": str(tmp)},
    )
    process.wait_for(r"Uvicorn running on")
    yield Gateway(f"http://127.0.0.1:{port}", None, process)
    process.stop()


def api(gateway: Gateway, method: str, path: str, body: Any = None) -> Any:
    request = urllib.request.Request(
        gateway.url + "/api/v1" + path,
        data=None if body is None else json.dumps(body).encode(),
        headers={"Content-Type": "application/json"},
        method=method,
    )
    try:
        with urllib.request.urlopen(request) as answer:
            return json.load(answer)
    except urllib.error.HTTPError as err:
        return json.load(err)


def live(gateway: Gateway, page: Page, where: str = "/") -> None:
    page.goto(gateway.url + where)
    expect(page.get_by_test_id("connection")).to_have_text("live")


def test_a_lost_origin_says_home_first_with_its_cause_until_homed(
    cell: Gateway, browser: Browser
) -> None:
    assert cell.line is not None
    # x stands off 0 (a move in pulses passes while the origin is only unknown), so the
    # reset shows as a counter that went to 0 by itself.
    body = {"position": 2000, "unit": "pulse"}
    moved = api(cell, "POST", "/axes/x/move?wait=true&timeout=30", body)
    assert moved["state"] == "done", moved
    for width, height in ((1280, 800), (390, 844)):
        opened = open_page(browser, width, height)
        try:
            page = opened.page
            live(cell, page)
            card = page.get_by_test_id("axis-x")
            if width == 1280:
                expect(card.get_by_test_id("origin")).to_have_text("origin unknown")
                cell.line.call("power_cycle", body="1")
            origin = card.get_by_test_id("origin")
            expect(origin).to_contain_text("origin lost — home first")
            if width == 1280:
                # the cause is the feed's origin event's, in the toast and on the card
                toast = page.locator(".toast", has_text="x: origin lost — home first")
                expect(toast).to_contain_text("the controller was reset")
                cause = card.get_by_test_id("origin-cause")
                expect(cause).to_contain_text("the controller was reset")
            # the gateway would refuse these (409 home first): disabled, the reason on them
            for direction in ("ccw", "cw"):
                jog = card.get_by_test_id(f"jog-{direction}")
                expect(jog).to_be_disabled()
                expect(jog).to_have_attribute("title", re.compile("^home first"))
            # millimetres are unknown: the pulses shown, never a millimetre value
            expect(card.get_by_test_id("position")).to_have_text("0")
            expect(card.get_by_test_id("user-unknown")).to_have_text("mm unknown until homed")
            shot(page, f"origin-lost-card-{width}")
            page.goto(cell.url + "/#/axis/x")
            axis = page.get_by_test_id("axis-page")
            expect(axis.get_by_test_id("origin")).to_contain_text("origin lost — home first")
            expect(axis.get_by_test_id("home-first")).to_contain_text("home first")
            move = axis.get_by_test_id("move-go")
            expect(move).to_be_disabled()
            expect(move).to_have_attribute("title", re.compile("^home first"))
            expect(axis.get_by_role("button", name="step x cw 1 pulse")).to_be_disabled()
            home = axis.get_by_role("button", name="home x")
            expect(home).to_be_enabled()
            shot(page, f"origin-lost-page-{width}")
        finally:
            opened.context.close()
        assert opened.errors == [], opened.errors

    opened = open_page(browser)
    try:
        page = opened.page
        live(cell, page, "/#/axis/x")
        axis = page.get_by_test_id("axis-page")
        axis.get_by_label("homing method").select_option("0H")
        axis.get_by_role("button", name="home x").click()
        expect(axis.get_by_test_id("origin")).to_have_text("homed", timeout=30_000)
        expect(page.locator(".toast", has_text="x: homed")).to_be_visible()
        expect(axis.get_by_test_id("move-go")).to_be_enabled()
        expect(axis.get_by_test_id("home-first")).to_have_count(0)
        expect(axis.get_by_test_id("user-unknown")).to_have_count(0)
        expect(axis.get_by_test_id("position")).to_have_text(re.compile(r"^-?\d+\.\d{3}$"))
    finally:
        opened.context.close()
    assert opened.errors == [], opened.errors


def test_a_wrapped_counter_shows_the_negative_position_and_the_raw_counter(
    cell: Gateway, session: Session
) -> None:
    page = session.page
    live(cell, page)
    card = page.get_by_test_id("axis-u")
    expect(card.get_by_test_id("position")).to_have_text(re.compile(r"\d"))
    # u has no soft limits: a jog CCW runs below 0, and in EP0 the counter wraps (§7-4)
    api(cell, "POST", "/axes/u/jog", {"direction": "ccw", "speed": "high"})
    expect(card.get_by_test_id("counter")).to_be_visible()
    api(cell, "POST", "/axes/u/stop", {"mode": "decelerate"})
    expect(card).to_contain_text("STOPPED")
    view = api(cell, "GET", "/axes/u")
    assert view["position"] < 0 and view["counter"] == view["position"] + 16_777_216, view
    expect(card.get_by_test_id("pulses")).to_have_text(f"{view['position']:,}")
    expect(card.get_by_test_id("counter")).to_have_text(f"counter {view['counter']:,}")
    expect(card.get_by_test_id("position")).to_have_text(f"{view['position_user']:,.3f}")
    shot(page, "wrapped-counter")
    api(cell, "POST", "/axes/u/errors/ack", {})  # if the jog reached the CCW limit


def test_positions_and_motion_never_read_are_unknown_not_zero_or_stopped(
    unread: Gateway, session: Session
) -> None:
    page = session.page
    page.goto(unread.url + "/")
    card = page.get_by_test_id("axis-x")
    expect(card.get_by_test_id("position-note")).to_have_text("not read yet")
    expect(card.get_by_test_id("position")).to_have_text("—")
    expect(card.get_by_test_id("moving-unknown")).to_have_text("MOTION UNKNOWN")
    expect(card).to_contain_text("STALE")
    expect(card).not_to_contain_text("STOPPED")
    expect(card.get_by_test_id("pulses")).to_have_count(0)
    page.goto(unread.url + "/#/axis/x")
    axis = page.get_by_test_id("axis-page")
    expect(axis.get_by_test_id("position-note")).to_have_text("not read yet")
    expect(axis.get_by_test_id("moving-unknown")).to_be_visible()
    shot(page, "never-read")


def test_latched_errors_show_by_name(cell: Gateway, session: Session) -> None:
    assert cell.line is not None
    page = session.page
    live(cell, page)
    head = page.get_by_test_id("controller-sim.2").locator(".ctlhead")
    cell.line.call("ems", body="2", pressed=True)
    try:
        expect(head.get_by_test_id("latched-emergency_stop")).to_have_text("emergency stop")
        expect(head).not_to_contain_text("emergency_stop")
    finally:
        cell.line.call("ems", body="2", pressed=False)
        api(cell, "POST", "/axes/u/errors/ack", {})
        api(cell, "POST", "/axes/v/errors/ack", {})
    expect(head.get_by_test_id("latched-emergency_stop")).to_have_count(0)


def test_the_speed_profile_waits_while_a_motor_of_the_controller_moves(
    cell: Gateway, session: Session
) -> None:
    page = session.page
    live(cell, page)
    # motor 1 moves: v's speed data cannot be read now (the gateway answers 409)
    api(cell, "POST", "/axes/u/jog", {"direction": "cw", "speed": "low"})
    expect(page.get_by_test_id("axis-u")).to_contain_text("MOVING")
    page.goto(cell.url + "/#/axis/v")
    expect(page.get_by_test_id("speed-wait")).to_contain_text("not while one moves")
    api(cell, "POST", "/axes/u/stop", {"mode": "decelerate"})
    expect(page.locator("form.speed")).to_contain_text("pps")
    assert session.errors == [], session.errors


def test_without_soft_limits_only_absolute_moves_in_the_user_unit_wait_for_a_home(
    cell: Gateway, session: Session
) -> None:
    assert cell.line is not None
    page = session.page
    live(cell, page, "/#/axis/u")
    axis = page.get_by_test_id("axis-page")
    expect(axis.get_by_test_id("pulses")).not_to_have_text("0")  # off 0: a reset shows
    cell.line.call("power_cycle", body="2")
    expect(axis.get_by_test_id("origin")).to_contain_text("origin lost — home first")
    move = axis.get_by_test_id("move-go")
    # an absolute move in mm is refused (409 home first); in pulses, or relative, it passes
    expect(move).to_be_disabled()
    expect(axis.get_by_test_id("move-refused")).to_contain_text("absolute moves in mm")
    axis.get_by_test_id("move-relative").check()
    expect(move).to_be_enabled()
    expect(axis.get_by_test_id("move-refused")).to_have_count(0)
    axis.get_by_test_id("move-relative").uncheck()
    axis.get_by_test_id("move-unit").select_option("pulse")
    expect(move).to_be_enabled()
    expect(axis.get_by_role("button", name="step u cw 1 pulse")).to_be_enabled()
    expect(axis.get_by_test_id("home-first")).to_have_count(0)
