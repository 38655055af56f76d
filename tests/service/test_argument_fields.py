"""The service's refusals name its own arguments (``position``, ``baud``, ``text.jump``), not a
field of some HTTP request: a face that is not REST (OPC UA's methods, a script calling the
service) reads them as they are. The REST face tells each as the field its route took it from,
exactly as before (the API tests check those problem bodies; here every route it maps is one
the app serves, so a renamed handler cannot silently lose its mapping)."""

from __future__ import annotations

from collections.abc import Sequence

import pytest
from fastapi.routing import APIRoute
from starlette.routing import BaseRoute

from gateway.api.service_fields import ROUTE_FIELDS
from gateway.errors import InvalidInputError, ParameterError
from gateway.service.axes import AxisService
from gateway.service.baud import BaudChanger
from gateway.service.controllers import ControllerService
from gateway.service.operations.terms import Direction, Unit
from gateway.service.runtime.simulated import SIM_LOOP
from tests.support.sim_app import json_of, running_app


async def test_the_axis_service_names_its_position_argument() -> None:
    async with running_app(("1",)) as api:
        axes: AxisService = api.services.axes
        mark = api.mark()
        with pytest.raises(InvalidInputError) as whole:
            await axes.move("x", 10.5, relative=False, unit=Unit.PULSE, holder="script")
        assert whole.value.field == "position"
        with pytest.raises(InvalidInputError) as beyond:
            await axes.move("x", 99_000_000, relative=True, unit=Unit.PULSE, holder="script")
        assert beyond.value.field == "position"
        # a jog against a soft limit it stands at is refused naming the direction
        await api.client.post("/axes/x/move?wait=true", json={"position": 0, "unit": "pulse"})
        with pytest.raises(InvalidInputError) as limit:
            await axes.step("x", Direction.CCW, holder="script")
        assert limit.value.field == "position"
        assert [t for t in api.heard("1", mark) if t.startswith(("2", "7", "8"))] == ["20"]


async def test_the_controller_and_loop_services_name_their_arguments() -> None:
    async with running_app(("1",)) as api:
        controllers: ControllerService = api.services.controllers
        with pytest.raises(InvalidInputError) as jump:
            controllers.programs.check("/D00/J+5/END")
        assert jump.value.field == "text.jump"
        ref = controllers.controller("sim.1")
        with pytest.raises(ParameterError) as number:  # the command's own parameter
            await controllers.resources.position(ref, 9999)
        assert number.value.field == "pn"
        baud: BaudChanger = api.services.baud
        with pytest.raises(InvalidInputError) as rate:
            await baud.change(SIM_LOOP, 2400)
        assert rate.value.field == "baud"
        # over REST the same refusals name the request's fields, as they always have
        r = await api.client.post("/programs/check", json={"text": "/D00/J+5/END"})
        assert json_of(r)["field"] == "body.text.jump"
        r = await api.client.post(f"/loops/{SIM_LOOP}/baud", json={"baud": 2400})
        assert r.status_code == 422 and json_of(r)["field"] == "body.baud", r.text


def _route_names(routes: Sequence[BaseRoute]) -> set[str]:
    """The names of the handlers among ``routes``, through the routers included in them."""
    names: set[str] = set()
    for route in routes:
        included = getattr(route, "original_router", None)  # an included router, as it is
        if included is not None:
            names |= _route_names(included.routes)
        elif isinstance(route, APIRoute):
            names.add(route.name)
    return names


async def test_every_route_the_rest_face_maps_is_served() -> None:
    async with running_app(("1",)) as api:
        served = _route_names(api.app.routes)
        assert set(ROUTE_FIELDS) <= served, set(ROUTE_FIELDS) - served
