"""The answer of a motion request waited for (``?wait=true``) that did not end ``done``.

Only ``done`` is a 2xx: a client that checks nothing but the status code must never take a
failed or doubtful motion for a success. The problem still carries the whole operation
(``operation``: state, error, final position) and ``Location`` names it.

=========  ======  =====================================================================
state      status  why this code
=========  ======  =====================================================================
failed     409     the machine's state stopped the motion (a limit, emergency stop, a stop
                   request, a command error): a conflict with the state of the axis, not a
                   fault of the gateway or the line; ``outcome`` ``done`` is not claimed
unknown    504     the controller stopped answering before the end was seen: the same
                   status as any other request whose outcome is in doubt (``outcome``
                   ``unknown``)
=========  ======  =====================================================================

Both carry ``Location``, so the idempotency store keeps them (the request may have moved the
axis: a retry with the same key must not move it again).
"""

from __future__ import annotations

from typing import Any

from gateway.api.problems import (
    PROBLEM_MEDIA_TYPE,
    ApiProblem,
    Problem,
    problem_type,
)
from gateway.service.operations.types import OperationState, OperationView

__all__ = ["MOTION_PROBLEM_RESPONSES", "motion_problem"]


def motion_problem(view: OperationView, location: str) -> ApiProblem:
    """The problem answered for an operation that ended ``failed`` or ``unknown``."""
    failed = view.state is OperationState.FAILED
    error = view.error
    why = f": {error.title}: {error.detail}" if error is not None else ""
    problem = Problem(
        type=problem_type("motion-failed" if failed else "motion-unknown"),
        title="The motion failed" if failed else "The outcome of the motion is unknown",
        status=409 if failed else 504,
        detail=f"operation {view.id} on {view.axis} ended {view.state.value}{why}",
        outcome=None if failed else "unknown",
        operation=view.model_dump(mode="json"),
    )
    return ApiProblem(problem, headers={"Location": location})


def _documented(description: str) -> dict[str, Any]:
    return {
        "description": description,
        "content": {PROBLEM_MEDIA_TYPE: {"schema": {"$ref": "#/components/schemas/Problem"}}},
    }


#: ``responses=`` entries of the motion routes (with wait=true).
MOTION_PROBLEM_RESPONSES: dict[int | str, dict[str, Any]] = {
    409: _documented(
        "leased, moving or busy (nothing sent); or with wait=true the motion ended `failed` "
        "(type urn:rc233-gateway:problem:motion-failed, `operation` holds it)"
    ),
    504: _documented(
        "the device did not answer; or with wait=true the motion's outcome is `unknown` "
        "(type urn:rc233-gateway:problem:motion-unknown, `operation` holds it)"
    ),
}
