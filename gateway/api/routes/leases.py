"""Lease routes: ``GET/POST/DELETE /axes/{id}/lease`` and ``/controllers/{id}/lease``.

While a client holds a lease, the other clients' motion and setting requests on the resource
(an axis, its controller, or a controller's axes) are refused with 409 naming the holder;
stops are never refused. ``POST`` takes or renews (same holder) the lease; ``DELETE`` gives
it back (an admin may release anyone's). The routes are added to the axes router.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated

from fastapi import APIRouter, Body, Depends, Path, Request
from pydantic import BaseModel, Field

from gateway.api.app_services import leases_of
from gateway.api.audit import audit_note
from gateway.api.routes.bodies import LeaseRequest
from gateway.api.routes.deps import Operator, Viewer
from gateway.service.leases import Lease, Leases
from gateway.service.roles import Role

__all__ = ["LeaseView", "lease_routes"]


class LeaseView(BaseModel):
    """A resource's lease (``holder`` None: free)."""

    resource: str = Field(description="axis id (loop.body.motor) or controller id (loop.body)")
    holder: str | None = Field(description="the token's name holding it")
    ttl: float | None
    expires: float | None = Field(description="seconds since the epoch")
    remaining: float | None = Field(description="seconds left")


def lease_view(leases: Leases, resource: str, lease: Lease | None) -> LeaseView:
    """The view of ``lease`` on ``resource``."""
    if lease is None:
        return LeaseView(resource=resource, holder=None, ttl=None, expires=None, remaining=None)
    return LeaseView(
        resource=resource,
        holder=lease.holder,
        ttl=lease.ttl,
        expires=leases.wall(lease.expires),
        remaining=round(lease.remaining(leases.now()), 3),
    )


async def _leases(request: Request) -> Leases:
    return leases_of(request)


# Module level: the routes below are closures, and their annotations are resolved here.
Id = Annotated[
    str, Path(description="axis id (loop.body.motor), controller id (loop.body) or name")
]
Leased = Annotated[Leases, Depends(_leases)]


def lease_routes(
    router: APIRouter, collection: str, kind: str, resolve: Callable[[Request, str], str]
) -> None:
    """Add the lease routes of ``/{collection}/{id}/lease``; ``resolve`` maps an id or name
    to the resource id (``NotFoundError`` when unknown)."""
    path = f"/{collection}/{{id}}/lease"

    async def get_lease(
        id: Id,
        request: Request,
        leases: Leased,
        _: Viewer,
    ) -> LeaseView:
        resource = resolve(request, id)
        return lease_view(leases, resource, leases.get(resource))

    async def take_lease(
        id: Id,
        request: Request,
        leases: Leased,
        principal: Operator,
        body: Annotated[LeaseRequest | None, Body()] = None,
    ) -> LeaseView:
        resource = resolve(request, id)
        lease = leases.acquire(resource, principal.name, (body or LeaseRequest()).ttl)
        audit_note(request, result="held")
        return lease_view(leases, resource, lease)

    async def release_lease(
        id: Id,
        request: Request,
        leases: Leased,
        principal: Operator,
    ) -> LeaseView:
        resource = resolve(request, id)
        force = principal.role.allows(Role.ADMIN)
        released = leases.release(resource, principal.name, force=force)
        audit_note(request, result="released" if released else "not held")
        return lease_view(leases, resource, None)

    router.add_api_route(
        path,
        get_lease,
        methods=["GET"],
        response_model=LeaseView,
        name=f"get_{kind}_lease",
        summary=f"The lease on a {kind}",
    )
    router.add_api_route(
        path,
        take_lease,
        methods=["POST"],
        response_model=LeaseView,
        name=f"take_{kind}_lease",
        summary=f"Take or renew the lease on a {kind}",
        description="Other clients' motion and setting requests get 409 naming the holder "
        "while it is held; stops are never refused. 409 when another client holds it (or the "
        f"{'controller' if kind == 'axis' else 'axes'} it guards).",
    )
    router.add_api_route(
        path,
        release_lease,
        methods=["DELETE"],
        response_model=LeaseView,
        name=f"release_{kind}_lease",
        summary=f"Give back the lease on a {kind} (an admin may release anyone's)",
    )
