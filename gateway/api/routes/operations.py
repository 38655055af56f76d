"""Routes of the operations: ``GET /operations/{id}`` and ``GET /operations``.

An operation is one motion request (move, home, jog, step): ``queued`` -> ``sent`` ->
``moving`` -> ``done`` | ``failed`` | ``unknown``, with its final position and error. The
gateway keeps them for a week (the newest 1,000 in memory, older ones read from the state
store); changes are also published on the WebSocket (``operation``).
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Path, Query, Request

from gateway.api.app_services import operations_of
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.deps import Viewer
from gateway.errors import NotFoundError
from gateway.service.operations import history
from gateway.service.operations.book import Operations
from gateway.service.operations.types import OperationState, OperationView

__all__ = ["router"]

router = APIRouter(tags=["operations"], responses=PROBLEM_RESPONSES)


async def _operations(request: Request) -> Operations:
    return operations_of(request)


Ops = Annotated[Operations, Depends(_operations)]


@router.get("/operations/{id}", response_model=OperationView, name="get_operation")
async def get_operation(
    id: Annotated[str, Path(description="operation id", examples=["op-1-00012345"])],
    operations: Ops,
    _: Viewer,
) -> OperationView:
    """One operation (404 when unknown or no longer kept)."""
    return (await history.find(operations, id)).view()


@router.get("/operations", response_model=list[OperationView])
async def list_operations(
    operations: Ops,
    _: Viewer,
    axis: Annotated[str | None, Query(max_length=64, description="axis id or name")] = None,
    state: Annotated[OperationState | None, Query()] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[OperationView]:
    """The newest operations first (of an axis, in a state)."""
    ident = None
    if axis is not None:
        try:
            ident = operations.runtime.topology.axis(axis).id
        except NotFoundError as exc:
            exc.field = "query.axis"
            raise
    found = await history.newest(operations, axis=ident, state=state, limit=limit)
    return [op.view() for op in found]
