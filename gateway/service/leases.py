"""Control leases: one client holds an axis or a controller for a while, so that two clients
do not steer one machine at once.

While a lease is held, other clients' motion and setting requests on that resource are refused
with 409 naming the holder and the expiry; **stops are never refused** (they never ask). A
lease is on an axis id (``main.1.2``) or a controller id (``main.1``); the two levels guard
each other: an axis action checks the axis and its controller, a controller action the
controller and both axes, and a lease cannot be taken on an axis while another client holds
its controller (or on a controller while another holds one of its axes).

Ids only: the routes resolve names to ids first (``Topology``). Loop names contain no dot
(``NAME_PATTERN``), so the dots of an id tell the level: ``loop.body`` or ``loop.body.motor``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from gateway.errors import ConflictError, InvalidInputError

__all__ = ["MAX_TTL", "Lease", "Leases"]

#: The longest lease (seconds): a forgotten lease frees itself within a day at most.
MAX_TTL = 86_400.0


@dataclass(frozen=True)
class Lease:
    """One lease: who holds which resource until when (``clock`` seconds)."""

    resource: str
    holder: str
    ttl: float
    acquired: float
    expires: float

    def remaining(self, now: float) -> float:
        """Seconds left at ``now`` (0 when expired)."""
        return max(0.0, self.expires - now)


def _related(resource: str) -> tuple[str, ...]:
    """The resources whose lease also guards ``resource``: its controller, or its axes."""
    parts = resource.split(".")
    if len(parts) == 3:  # an axis: its controller
        return (f"{parts[0]}.{parts[1]}",)
    if len(parts) == 2:  # a controller: both motors (§2: two motors a controller)
        return (f"{resource}.1", f"{resource}.2")
    return ()


class Leases:
    """The leases of the gateway, in memory; ``clock`` is injectable (monotonic by default)."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._held: dict[str, Lease] = {}

    def now(self) -> float:
        """The leases' clock."""
        return self._clock()

    def wall(self, at: float) -> float:
        """A time on the leases' clock as seconds since the epoch (for views)."""
        return round(time.time() + (at - self._clock()), 3)

    # ------------------------------------------------------------------ reading

    def get(self, resource: str) -> Lease | None:
        """The lease on ``resource`` if one is held now."""
        lease = self._held.get(resource)
        if lease is not None and lease.expires <= self._clock():
            del self._held[resource]
            return None
        return lease

    def held(self) -> list[Lease]:
        """Every lease held now."""
        return [lease for r in list(self._held) if (lease := self.get(r)) is not None]

    # ------------------------------------------------------------------ changing

    def acquire(self, resource: str, holder: str, ttl: float) -> Lease:
        """Take (or renew, for the same holder) the lease on ``resource`` for ``ttl`` seconds.

        ``ConflictError`` naming the holder when another client holds the resource, its
        controller or one of its axes; ``InvalidInputError`` for a TTL outside (0, MAX_TTL].
        """
        if not (math.isfinite(ttl) and 0 < ttl <= MAX_TTL):
            raise InvalidInputError(
                f"lease ttl {ttl} s is out of range",
                field="ttl",
                rule=f"0 < ttl <= {MAX_TTL:g} seconds",
            )
        self.check(holder, (resource, *_related(resource)))
        now = self._clock()
        current = self._held.get(resource)
        acquired = current.acquired if current is not None and current.holder == holder else now
        lease = Lease(resource, holder, ttl, acquired, now + ttl)
        self._held[resource] = lease
        return lease

    def release(self, resource: str, holder: str, *, force: bool = False) -> Lease | None:
        """Give the lease on ``resource`` back; the released lease, or None if none was held.

        Only its holder may release it (``ConflictError`` naming the holder otherwise), unless
        ``force`` (an administrator).
        """
        lease = self.get(resource)
        if lease is None:
            return None
        if lease.holder != holder and not force:
            raise self._conflict(lease, f"release the lease on {resource}")
        del self._held[resource]
        return lease

    def check(self, holder: str, resources: Iterable[str]) -> None:
        """Refuse (``ConflictError`` naming the holder and the expiry) when another client
        holds a lease on any of ``resources``; the caller lists what its action touches."""
        for resource in resources:
            lease = self.get(resource)
            if lease is not None and lease.holder != holder:
                raise self._conflict(lease, f"act on {resource}")

    def _conflict(self, lease: Lease, what: str) -> ConflictError:
        left = lease.remaining(self._clock())
        until = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(self.wall(lease.expires)))
        return ConflictError(
            f"cannot {what}: {lease.resource} is leased by {lease.holder!r} for another "
            f"{left:.1f} s (until {until})",
            field="lease",
            holder=lease.holder,
        )
