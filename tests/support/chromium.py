"""Debian's chromium as the browser tests and bench/dashboard.py start it.

Playwright's own browser download is not used (it cannot reach the network here); the flags
keep a headless Chromium from reaching for Google's services at every start, which a closed
network refuses many times over.
"""

from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
