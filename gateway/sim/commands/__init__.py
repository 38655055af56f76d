"""The handlers of every host command form, one module per group of chapter 10.

Importing this package registers them all in ``gateway.sim.dispatch.HANDLERS``.
"""

from gateway.sim.commands import io, motion, positions, program, setup, speeds, status, storage

__all__ = ["io", "motion", "positions", "program", "setup", "speeds", "status", "storage"]
