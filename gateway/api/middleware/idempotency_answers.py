"""What a retried ``Idempotency-Key`` is answered when its first request left no response:
the operation it started, as it stands; or, when it started none and its outcome was never
recorded (the process stopped between acting and answering), that the outcome is unknown.
And the refusal of a keyed request whose ``in progress`` record cannot be written.

None of these acts: they are answers about a request that was, or was not, carried out.
"""

from __future__ import annotations

from datetime import UTC, datetime

from fastapi.responses import JSONResponse
from starlette.requests import Request
from starlette.routing import NoMatchFound
from starlette.types import Receive, Scope, Send

from gateway.api.motion_problems import motion_problem
from gateway.api.problems import Problem, problem_response, problem_type
from gateway.errors import NotFoundError
from gateway.service.operations import history
from gateway.service.operations.book import Operations
from gateway.service.operations.types import OperationState

__all__ = [
    "HEADER",
    "OUTCOME_UNKNOWN",
    "REPLAYED_HEADER",
    "answer_operation",
    "answer_outcome_unknown",
    "refuse_unrecorded",
]

HEADER = "Idempotency-Key"
REPLAYED_HEADER = "Idempotent-Replayed"
#: The problem slug of a keyed request whose outcome was never recorded.
OUTCOME_UNKNOWN = "idempotency-outcome-unknown"
#: Seconds a client waits before retrying a request refused for its unwritten key.
UNRECORDED_RETRY_AFTER = 5


async def answer_operation(scope: Scope, receive: Receive, send: Send, ident: str) -> None:
    """The operation a key's request started before the process stopped, as it stands."""
    operations: Operations = scope["app"].state.operations
    try:
        op = await history.find(operations, ident)
    except NotFoundError:
        problem = Problem(
            type=problem_type("conflict"),
            title="Conflict",
            status=409,
            detail=f"{HEADER}: its request started operation {ident}, which is no longer "
            "retained; nothing was done again",
            field=f"header.{HEADER}",
        )
        response = problem_response(problem)
    else:
        try:
            location = str(scope["app"].url_path_for("get_operation", id=op.id))
        except NoMatchFound:
            location = f"/api/v1/operations/{op.id}"
        view = op.view()
        if op.final and op.state is not OperationState.DONE:
            raised = motion_problem(view, location)
            response = problem_response(raised.problem, None, raised.headers)
        else:
            status = 200 if op.state is OperationState.DONE else 202
            response = JSONResponse(
                view.model_dump(mode="json"), status_code=status, headers={"Location": location}
            )
    response.headers[REPLAYED_HEADER] = "true"
    await response(scope, receive, send)


def _audit_path(scope: Scope) -> str:
    try:
        return str(scope["app"].url_path_for("read_audit"))
    except NoMatchFound:
        return "/api/v1/audit"


async def answer_outcome_unknown(
    scope: Scope, receive: Receive, send: Send, key: str, accepted: float
) -> None:
    """409: the first request with ``key`` was accepted at ``accepted`` (seconds since the
    epoch) and the gateway stopped before its outcome was recorded. It may have acted, so it
    is not carried out again; the client finds out what happened from the audit log and the
    resource's state."""
    when = datetime.fromtimestamp(accepted, UTC).isoformat(timespec="milliseconds")
    method, path = scope.get("method", "POST"), scope.get("path", "")
    problem = Problem(
        type=problem_type(OUTCOME_UNKNOWN),
        title="The outcome of the first request with this key is unknown",
        status=409,
        detail=(
            f"{HEADER} {key!r}: {method} {path} with this key was accepted at {when} and the "
            "gateway stopped before its outcome was recorded. It may or may not have acted; "
            "it is not done again. Check what happened (GET "
            f"{_audit_path(scope)}: the request's intent and outcome entries; the resource's "
            "own state, e.g. the controller's program status, outputs or settings read back) "
            "and send a new request with a new key if it is still wanted."
        ),
        field=f"header.{HEADER}",
        rule="a retried request never acts twice, before or after a restart",
        outcome="unknown",
        key=key,
        accepted=when,
    )
    response = problem_response(problem, Request(scope), {REPLAYED_HEADER: "true"})
    await response(scope, receive, send)


async def refuse_unrecorded(
    scope: Scope, receive: Receive, send: Send, key: str, reason: str
) -> None:
    """503 with ``Retry-After``: the ``in progress`` record of ``key`` could not be written
    (disk full, read-only, I/O error), so the request is not handed to its route."""
    problem = Problem(
        type=problem_type("state-unavailable"),
        title="The state store cannot record the request",
        status=503,
        detail=f"{HEADER} {key!r} could not be recorded before the request acts ({reason}); "
        "nothing was done",
        field=f"header.{HEADER}",
        rule="a keyed request acts only once its key is on disk",
        outcome="not_done",
    )
    headers = {"Retry-After": str(UNRECORDED_RETRY_AFTER)}
    response = problem_response(problem, Request(scope), headers)
    await response(scope, receive, send)
