"""The fixtures of these tests, from ``tests/support/engine_rig.py`` and ``bus_rig.py``."""

from tests.support.bus_rig import make_bus
from tests.support.engine_rig import attach

__all__ = ["attach", "make_bus"]
