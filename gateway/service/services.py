"""The services of one running gateway, built once and shared by every face.

``Services`` holds the runtime and what stands on it: the audit record, the control leases,
the operations book, the axis and controller services, stop-all, the baud changer and the
WebSocket feed. The composition root (``gateway.compose``) builds it; REST/WebSocket, the
MQTT edge node and the OPC UA face are each handed this same object, so a lease taken over
REST binds an OPC UA call and every face's entries go to the one audit record.

``start()`` and ``close()`` own the order: the audit record first (nothing acts before its
entry can be written), then the operations the last process left unended (before the loops:
a jog left running is stopped by this process), then the loops; closing runs the other way.
"""

from __future__ import annotations

from dataclasses import dataclass

from gateway.service.audit import AuditRecord
from gateway.service.axes import AxisService
from gateway.service.baud import BaudChanger
from gateway.service.controllers import ControllerService
from gateway.service.feed import Feed
from gateway.service.leases import Leases
from gateway.service.operations import Operations
from gateway.service.runtime.runtime import Runtime
from gateway.service.stops import StopAll

__all__ = ["Services"]


@dataclass(frozen=True)
class Services:
    """What the faces serve, each built once over ``runtime``."""

    runtime: Runtime
    audit: AuditRecord
    leases: Leases
    operations: Operations
    axes: AxisService
    controllers: ControllerService
    stops: StopAll
    baud: BaudChanger
    feed: Feed

    async def start(self) -> None:
        """Open the audit record, restore the unended operations, start the loops."""
        self.audit.start()
        await self.operations.restore()  # before the loops: what the last process left unended
        await self.runtime.start()

    async def close(self) -> None:
        """Stop publishing and following operations, let each loop's transaction in flight
        finish and close the ports, then close the audit record (the last entries flushed)."""
        self.feed.close()
        self.operations.close()
        await self.runtime.close()
        await self.audit.close()
