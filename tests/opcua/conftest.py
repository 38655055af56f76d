"""The fixtures of these tests, from ``tests/support/opcua_cell.py``."""

from tests.support.opcua_cell import cell

__all__ = ["cell"]
