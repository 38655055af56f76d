"""The controllers as users see them: views, checked commands, positions, I/O, sensor logic,
mode, EEPROM, user programs, raw passthrough and the line trace. ``service.ControllerService``
is the front."""

from gateway.service.controllers.service import ControllerService

__all__ = ["ControllerService"]
