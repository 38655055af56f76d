"""The fixtures of these tests, from ``tests/support/sim_wire.py``."""

from tests.support.sim_wire import eeprom_dir, make_wire, wire

__all__ = ["eeprom_dir", "make_wire", "wire"]
