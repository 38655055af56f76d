"""The fixtures of these tests, from ``tests/support/browser_rig.py``."""

from tests.support.browser_rig import browser, gateway, playwright, session

__all__ = ["browser", "gateway", "playwright", "session"]
