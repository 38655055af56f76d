"""The fixtures of these tests, from ``tests/support/bus_rig.py``."""

from tests.support.bus_rig import make_bus

__all__ = ["make_bus"]
