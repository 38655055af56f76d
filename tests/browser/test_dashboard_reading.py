"""The dashboard read as a person reads it, in a real Chromium: nothing cut off, a plot's
scale, the line trace following its tail, and a name for every control.

Against the ``serve --simulate`` process the other browser tests share, at 1280x800 and on a
phone (390x844). These tests move the conveyor (controller 3, motor 2) and stop it again.
"""

from __future__ import annotations

import itertools
import json
import re
import urllib.request
from collections.abc import Iterator
from typing import Any

import pytest
from playwright.sync_api import Browser, Page, Route, expect

from tests.support.browser_rig import Gateway, Session, open_page, shot

#: A move far enough to be under way for the whole look at the page (conveyor, in pulses).
FAR = 60_000


def _post(gateway: Gateway, path: str, body: dict[str, Any]) -> Any:
    request = urllib.request.Request(
        gateway.url + "/api/v1" + path,
        data=json.dumps(body).encode(),
        headers={"Content-Type": "application/json"},
        method="POST",
    )
    with urllib.request.urlopen(request) as answer:
        return json.load(answer)


@pytest.fixture
def conveyor_stopped_after(gateway: Gateway) -> Iterator[None]:
    yield
    _post(gateway, "/axes/conveyor/stop", {"mode": "immediate"})


def _live(gateway: Gateway, page: Page, where: str = "/") -> None:
    page.goto(gateway.url + where)
    expect(page.get_by_test_id("connection")).to_have_text("live")


#: Every element of ``root`` whose text is cut off: wider than its box, or reaching past the
#: right edge of the box that clips it.
CLIPPED = """root => {
  const out = [];
  for (const e of root.querySelectorAll('*')) {
    if (e.scrollWidth > e.clientWidth + 1 && getComputedStyle(e).overflowX !== 'visible') {
      out.push(`${e.className}: ${e.textContent}`);
    }
  }
  const edge = root.getBoundingClientRect().right;
  for (const e of root.children) {
    if (e.getBoundingClientRect().right > edge + 1) out.push(`past the edge: ${e.textContent}`);
  }
  return out;
}"""


@pytest.mark.usefixtures("conveyor_stopped_after")
@pytest.mark.parametrize(("width", "height"), [(1280, 800), (390, 844)])
def test_nothing_in_a_card_head_or_a_failure_reason_is_cut_off(
    gateway: Gateway, browser: Browser, width: int, height: int
) -> None:
    opened = open_page(browser, width, height)
    try:
        page = opened.page
        _live(gateway, page)
        card = page.get_by_test_id("axis-conveyor")
        _post(gateway, "/axes/conveyor/move", {"position": FAR, "relative": True, "unit": "pulse"})
        expect(card).to_contain_text("MOVING")
        card.scroll_into_view_if_needed()
        expect(card.locator("span.target")).to_contain_text("pulse")
        head = card.locator("header.axishead")
        assert head.evaluate(CLIPPED) == []
        shot(page, f"moving-{width}")
        # a stop ends the move short of its target: the failure's whole reason can be read
        _live(gateway, page, "/#/axis/conveyor")
        _post(gateway, "/axes/conveyor/stop", {"mode": "immediate"})
        op = page.get_by_test_id("op")
        expect(op).to_contain_text(re.compile("failed|unknown"))
        assert op.evaluate("e => e.scrollWidth <= e.clientWidth + 1"), op.inner_text()
        text = op.inner_text()
        assert not text.endswith("…") and len(text) > 20, text
        op.evaluate("e => e.scrollIntoView({block: 'center'})")  # not under the sticky bar
        shot(page, f"axis-failed-{width}")
        assert opened.foreign == []
    finally:
        opened.context.close()


def test_a_plot_shows_a_scale_with_the_unit(gateway: Gateway, session: Session) -> None:
    page = session.page
    _live(gateway, page)
    card = page.get_by_test_id("axis-x")
    plot = card.locator(".plot")
    expect(plot).to_have_attribute("data-y-ticks", re.compile(r"\|"))
    labels = (plot.get_attribute("data-y-ticks") or "").split("|")
    assert len(labels) >= 2 and len(set(labels)) == len(labels), labels
    assert all(label.endswith(" mm") for label in labels), labels
    values = [float(label.removesuffix(" mm")) for label in labels]
    position = float(card.get_by_test_id("position").inner_text().replace(",", ""))
    assert values == sorted(values) and values[0] <= position <= values[-1], (values, position)
    steps = {round(b - a, 9) for a, b in itertools.pairwise(values)}
    assert len(steps) == 1, steps  # evenly spaced: a scale, not one label near the value
    expect(plot).to_have_attribute("aria-label", re.compile(r"scale .+ mm to .+ mm"))


def test_every_control_is_named_by_its_axis_and_direction(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    _live(gateway, page)
    card = page.get_by_test_id("axis-x")
    expect(card.get_by_role("button", name="jog x cw low speed", exact=True)).to_be_visible()
    expect(card.get_by_role("button", name="jog x ccw low speed", exact=True)).to_be_visible()
    expect(card.get_by_role("button", name="stop x", exact=True)).to_be_visible()
    _live(gateway, page, "/#/axis/y")
    for name in (
        "jog y ccw low speed", "jog y cw low speed", "jog y ccw high speed",
        "jog y cw high speed", "step y ccw 1 pulse", "step y cw 1 pulse", "stop y", "move y",
        "home y",
    ):  # fmt: skip
        expect(page.get_by_role("button", name=name, exact=True)).to_have_count(1)
    # no button is named by symbols alone
    names = page.get_by_role("button").evaluate_all(
        "all => all.map(e => e.getAttribute('aria-label') || e.textContent.trim())"
    )
    assert all(re.search(r"[A-Za-z]{2}", n) for n in names), names


def _hold_puts(page: Page, held: list[Route]) -> None:
    def hold(route: Route) -> None:
        if route.request.method == "PUT":
            held.append(route)  # answered when the test lets it go
        else:
            route.continue_()

    page.route(re.compile(r".*/api/v1/loops/sim/trace$"), hold)


def test_the_trace_follows_its_tail_and_keeps_the_hex_box_while_it_is_set(
    gateway: Gateway, session: Session
) -> None:
    page = session.page
    _live(gateway, page, "/#/trace/sim")
    log = page.get_by_role("log")
    page.get_by_label("trace on").check()
    try:
        # more lines than the box shows: the newest are in view
        page.wait_for_function(
            "() => document.querySelectorAll('.trace .tl').length >= 60", timeout=60_000
        )
        at_bottom = "e => e.scrollHeight - e.scrollTop - e.clientHeight <= 24"
        page.wait_for_function(
            f"() => ({at_bottom})(document.querySelector('.trace'))", timeout=15_000
        )
        assert log.evaluate("e => e.scrollHeight > e.clientHeight + 100")
        shot(page, "trace")
        # scrolled up to read: the view stays where the reader is while new lines come
        log.evaluate("e => { e.scrollTop = 0; e.dispatchEvent(new Event('scroll')); }")
        count = page.locator(".trace .tl").count()
        last = page.locator(".trace .tl").last.inner_text()
        page.wait_for_function(
            "last => document.querySelector('.trace .tl:last-child').innerText !== last",
            arg=last,
            timeout=15_000,
        )
        assert count >= 60 and log.evaluate("e => e.scrollTop") == 0
        # the hex box keeps what was clicked while its PUT is on its way, whatever the
        # half-second refresh reads meanwhile
        hex_box = page.get_by_label("hex")
        hex_box.uncheck()  # another test may have left the loop's trace in hex
        with page.expect_response(
            lambda r: r.url.endswith("/loops/sim/trace") and r.request.method == "GET"
        ):
            pass
        expect(hex_box).not_to_be_checked()
        held: list[Route] = []
        _hold_puts(page, held)
        hex_box.check()
        for _ in range(2):
            with page.expect_response(
                lambda r: r.url.endswith("/loops/sim/trace") and r.request.method == "GET"
            ):
                pass
            expect(hex_box).to_be_checked()
        assert len(held) == 1
        held[0].continue_()
        expect(log.locator(".tl.tx").last).to_contain_text(re.compile(r"24 3[0-9]"))
        expect(hex_box).to_be_checked()
        page.unroute(re.compile(r".*/api/v1/loops/sim/trace$"))
        hex_box.uncheck()
        expect(hex_box).not_to_be_checked()
    finally:
        page.get_by_label("trace on").uncheck()
