"""The fixtures of these tests, from ``tests/support/ws_server.py``."""

from tests.support.ws_server import make_ws_server

__all__ = ["make_ws_server"]
