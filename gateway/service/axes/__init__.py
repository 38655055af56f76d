"""The axes as users see them: motion requests checked and turned into commands, speed data,
position formats, soft limits, jogs toward a limit. ``service.AxisService`` is the front."""

from gateway.service.axes.service import AxisService

__all__ = ["AxisService"]
