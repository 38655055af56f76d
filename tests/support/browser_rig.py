"""Fixtures of the browser tests: the gateway as a process, Debian's chromium, the sim's line.

``rc233-gateway serve --simulate`` runs as a separate process (the way ``make run`` runs it)
with the simulator's control surface on; the tests drive the dashboard in a real headless
Chromium through Playwright for Python and check what reached the simulated line through the
control surface's ``trace`` (the simulator's own line log: every frame a controller heard).
Every request the page makes to anywhere but 127.0.0.1 is aborted and fails the test.

Playwright cannot download its own browser here: the tests use ``/usr/bin/chromium`` (Debian's
``chromium`` package; ``make test`` installs it when it is missing) and FAIL, never skip, when
it cannot be started.
"""

from __future__ import annotations

import json
import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import (
    Browser,
    BrowserContext,
    Page,
    Playwright,
    expect,
    sync_playwright,
)

from tests.support.chromium import CHROMIUM, CHROMIUM_ARGS

GATEWAY = Path(sys.executable).parent / "rc233-gateway"
INSTALL_HINT = (
    "the browser tests need Debian's chromium at /usr/bin/chromium: "
    "`apt-get update && apt-get install -y chromium` (as root; `make test` does it when it "
    "is missing). Playwright's own browser download is not used."
)
#: Any URL that does not go to 127.0.0.1.
FOREIGN = re.compile(r"^(?!(https?|wss?)://127\.0\.0\.1[:/]).*")
#: Real seconds to wait for something the page or the gateway does.
WAIT = 15.0
# Assertions wait as long as actions: expect's own default (5 s) is too short on a busy host.
expect.set_options(timeout=WAIT * 1000)
#: Where screenshots go for people to look at (the test output).
SHOTS = Path(os.environ.get("RC233_SCREENSHOTS", "test-output/screenshots"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


class Process:
    """A child process whose output lines are read by a thread, so a test waits on them."""

    def __init__(self, argv: list[str], log: Path, env: dict[str, str] | None = None) -> None:
        self.log = log
        self.lines: queue.Queue[str] = queue.Queue()
        self.proc = subprocess.Popen(
            argv,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env={**os.environ, **(env or {})},
        )
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        with self.log.open("w") as out:
            for line in self.proc.stdout:
                out.write(line)
                out.flush()
                self.lines.put(line)

    def wait_for(self, pattern: str, timeout: float = 30.0) -> re.Match[str]:
        """The first output line matching ``pattern`` (fails with the log after ``timeout``)."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            try:
                line = self.lines.get(timeout=max(left, 0.001))
            except queue.Empty:
                pytest.fail(f"no line matching {pattern!r}: {self.log.read_text()[-2000:]}")
            found = re.search(pattern, line)
            if found:
                return found

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)


class Line:
    """The simulator's control surface: JSON lines, one request and one answer each."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
        self.file = self.sock.makefile("rw", encoding="utf-8", newline="\n")

    def call(self, op: str, **fields: Any) -> dict[str, Any]:
        self.file.write(json.dumps({"op": op, **fields}) + "\n")
        self.file.flush()
        answer: dict[str, Any] = json.loads(self.file.readline())
        assert answer["ok"], answer
        return answer

    def mark(self) -> int:
        """The next record number of the line log."""
        records = self.call("trace", since=0)["trace"]
        return int(records[-1]["seq"]) + 1 if records else 0

    def heard(self, since: int, body: str | None = None) -> list[str]:
        """The command texts the controllers heard since ``since`` (``$1SS`` -> ``SS``)."""
        out = []
        for r in self.call("trace", since=since)["trace"]:
            if r["kind"] == "heard" and r["ref"] > 0 and (body is None or r["body"] == body):
                out.append(r["data"][2:].rstrip("\r"))
        return out

    def clock(self) -> tuple[float, float]:
        """The simulator's clock against this process's ``time.monotonic()`` (one clock for
        every process on Linux, and the simulator's real clock): ``(offset, scale)`` with
        ``sim time = offset + scale * monotonic``. Read from the quickest of a few ``state``
        calls, so it is right to within half that call's round trip."""
        best: tuple[float, float, float] | None = None
        for _ in range(5):
            before = time.monotonic()
            state = self.call("state")["state"]
            after = time.monotonic()
            if best is None or after - before < best[0]:
                scale = float(state["time_scale"])
                best = (after - before, float(state["time"]) - scale * (before + after) / 2, scale)
        assert best is not None
        return best[1], best[2]

    def heard_when(self, since: int, texts: tuple[str, ...]) -> float:
        """When (``time.monotonic()``) a controller first heard one of ``texts`` since
        ``since``: the simulator's own record time, not when a read of the log saw it."""
        offset, scale = self.clock()
        for r in self.call("trace", since=since)["trace"]:
            if r["kind"] == "heard" and r["ref"] > 0 and r["data"][2:].rstrip("\r") in texts:
                return (float(r["time"]) - offset) / scale
        pytest.fail(f"no {texts} heard since record {since}")

    def wait_heard(
        self, since: int, check: Callable[[list[str]], bool], timeout: float = WAIT
    ) -> tuple[list[str], float]:
        """Read the line log until ``check(heard)`` holds: the frames and the real seconds
        it took. Each read is one request to the simulator (the wait is on its answers)."""
        start = time.monotonic()
        while True:
            heard = self.heard(since)
            if check(heard):
                return heard, time.monotonic() - start
            if time.monotonic() - start > timeout:
                pytest.fail(f"the line never showed it; heard {heard[-30:]}")

    def close(self) -> None:
        self.sock.close()


@dataclass
class Gateway:
    """A running ``serve``: its URL, its simulator's line, its log."""

    url: str
    line: Line | None
    process: Process
    extra: list[Process] = field(default_factory=list)


def start_simulated(tmp: Path, *options: str) -> Gateway:
    """``rc233-gateway serve --simulate`` with the control surface on."""
    port, control = free_port(), free_port()
    process = Process(
        [
            str(GATEWAY), "serve", "--simulate", "--no-auth", "--port", str(port),
            "--control", f"127.0.0.1:{control}", "--eeprom-dir", str(tmp), *options,
        ],
        tmp / "serve.log",
        env={"XDG_DATA_HOME": str(tmp)},
    )  # fmt: skip
    process.wait_for(r"Uvicorn running on")
    return Gateway(f"http://127.0.0.1:{port}", Line(control), process)


# Module scope, not session: while Playwright's sync API is open its event loop counts as
# running in this thread, and the asyncio tests of the other directories could not start theirs.
@pytest.fixture(scope="module")
def playwright() -> Iterator[Playwright]:
    with sync_playwright() as p:
        yield p


def launch(playwright: Playwright, executable: Path = CHROMIUM) -> Browser:
    """Debian's chromium, or the test fails (never skips) saying how to install it."""
    if not executable.exists():
        pytest.fail(f"no {executable}: {INSTALL_HINT}")
    try:
        return playwright.chromium.launch(executable_path=str(executable), args=CHROMIUM_ARGS)
    except Exception as exc:  # any failure to start is the same message to the user
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        pytest.fail(f"{executable} did not start ({first}): {INSTALL_HINT}")


@pytest.fixture(scope="module")
def browser(playwright: Playwright) -> Iterator[Browser]:
    started = launch(playwright)
    yield started
    started.close()


# One gateway for the session: starting one costs seconds, and every module leaves it as it
# found it (test_dashboard.py's line cut is undone before that test ends).
@pytest.fixture(scope="session")
def gateway(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Gateway]:
    running = start_simulated(tmp_path_factory.mktemp("gateway"))
    yield running
    assert running.line is not None
    running.line.close()
    running.process.stop()


@dataclass
class Session:
    """A page in its own browser context, and what it tried to reach off 127.0.0.1."""

    page: Page
    context: BrowserContext
    foreign: list[str]
    errors: list[str]


def open_page(browser: Browser, width: int = 1280, height: int = 800) -> Session:
    context = browser.new_context(viewport={"width": width, "height": height})
    foreign: list[str] = []

    def refuse(route: Any) -> None:
        foreign.append(route.request.url)
        route.abort()

    # Matched in the browser's driver, so requests to 127.0.0.1 never wait for this Python
    # thread (which is often busy reading the simulator's line log).
    context.route(FOREIGN, refuse)
    page = context.new_page()
    page.add_init_script(EVENT_TIMES)
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on(
        "console",
        lambda msg: errors.append(msg.text) if msg.type == "error" else None,
    )
    page.set_default_timeout(WAIT * 1000)
    return Session(page, context, foreign, errors)


@pytest.fixture
def session(browser: Browser) -> Iterator[Session]:
    opened = open_page(browser)
    yield opened
    opened.context.close()
    assert opened.foreign == [], f"the page tried to leave 127.0.0.1: {opened.foreign}"


#: Added to a page before its own scripts: the wall-clock time (ms since the epoch, the clock
#: ``time.time()`` reads) of the last pointerup, blur, visibilitychange and WebSocket close the
#: page saw, recorded by listeners that run before the page's own.
EVENT_TIMES = """
window.__at = {};
(() => {
  const at = (name) => () => { window.__at[name] = performance.timeOrigin + performance.now(); };
  for (const name of ["pointerup", "blur"]) window.addEventListener(name, at(name), true);
  document.addEventListener("visibilitychange", at("visibilitychange"), true);
  // Whichever WebSocket class the page gets (Playwright's route puts its own in place).
  const watched = (Base) =>
    class extends Base {
      constructor(...args) {
        super(...args);
        this.addEventListener("close", at("websocket-close"));
      }
    };
  let current = watched(window.WebSocket);
  Object.defineProperty(window, "WebSocket", {
    configurable: true,
    get: () => current,
    set: (Base) => { current = watched(Base); },
  });
})();
"""


def page_event_when(page: Page, name: str) -> float:
    """When (``time.monotonic()``) the page last saw event ``name`` (see ``EVENT_TIMES``)."""
    epoch_ms = page.evaluate("name => window.__at[name]", name)
    assert epoch_ms is not None, f"the page saw no {name}"
    return float(epoch_ms) / 1000 - (time.time() - time.monotonic())


def shot(page: Page, name: str) -> Path:
    """A screenshot in the test output for people to look at."""
    SHOTS.mkdir(parents=True, exist_ok=True)
    path = SHOTS / f"{name}.png"
    page.screenshot(path=str(path))
    return path
