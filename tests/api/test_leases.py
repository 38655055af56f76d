"""Control leases: the ``Leases`` rules on a test clock, then through the API with tokens."""

from __future__ import annotations

import pytest

from gateway.errors import ConflictError, InvalidInputError
from gateway.service.leases import Leases
from tests.support.sim_app import auth, json_of, running_app


class Clock:
    """A clock the test moves."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_acquire_renew_conflict_and_expiry() -> None:
    clock = Clock()
    leases = Leases(clock)
    first = leases.acquire("main.1.2", "alice", 30)
    assert (first.holder, first.expires) == ("alice", 1030.0)
    clock.now += 10
    renewed = leases.acquire("main.1.2", "alice", 30)
    assert (renewed.acquired, renewed.expires) == (1000.0, 1040.0)  # same holder: renewed
    with pytest.raises(ConflictError) as caught:
        leases.acquire("main.1.2", "bob", 30)
    assert caught.value.holder == "alice"
    assert "30.0 s" in str(caught.value) and "alice" in str(caught.value)
    with pytest.raises(ConflictError):
        leases.check("bob", ["main.1.2"])
    leases.check("alice", ["main.1.2", "main.1"])  # the holder passes
    clock.now += 30  # 1040: expired
    assert leases.get("main.1.2") is None
    leases.check("bob", ["main.1.2"])
    assert leases.acquire("main.1.2", "bob", 5).holder == "bob"


def test_axis_and_controller_guard_each_other() -> None:
    leases = Leases(Clock())
    leases.acquire("main.1", "alice", 60)
    with pytest.raises(ConflictError) as caught:
        leases.acquire("main.1.1", "bob", 60)  # its controller is alice's
    assert caught.value.holder == "alice"
    leases.acquire("main.2.2", "bob", 60)
    with pytest.raises(ConflictError) as caught:
        leases.acquire("main.2", "alice", 60)  # one of its axes is bob's
    assert caught.value.holder == "bob"
    leases.acquire("main.1.1", "alice", 60)  # the controller's holder may take its axes


def test_release_by_holder_or_force_and_ttl_rule() -> None:
    leases = Leases(Clock())
    leases.acquire("main.1", "alice", 60)
    with pytest.raises(ConflictError):
        leases.release("main.1", "bob")
    assert leases.release("main.1", "bob", force=True) is not None
    assert leases.release("main.1", "alice") is None  # nothing held
    for ttl in (0, -1, float("inf"), 86_401):
        with pytest.raises(InvalidInputError) as caught:
            leases.acquire("main.1", "alice", ttl)
        assert caught.value.field == "ttl"


async def test_lease_refuses_other_clients_but_never_a_stop() -> None:
    async with running_app(roles=True) as api:
        client = api.client
        r = await client.post("/axes/x/lease", json={"ttl": 60}, headers=auth("alice"))
        assert r.status_code == 200 and json_of(r)["holder"] == "alice"
        mark = api.mark()
        r = await client.post(
            "/axes/x/move", json={"position": 100, "unit": "pulse"}, headers=auth("bob")
        )
        assert r.status_code == 409
        problem = json_of(r)
        assert problem["holder"] == "alice" and "alice" in problem["detail"]
        r = await client.put("/axes/x/speed", json={"oh": 4000}, headers=auth("bob"))
        assert r.status_code == 409 and json_of(r)["holder"] == "alice"
        # the controller's other axis is free, but bob cannot lease the whole controller
        r = await client.post("/controllers/gantry/lease", json={"ttl": 5}, headers=auth("bob"))
        assert r.status_code == 409 and json_of(r)["holder"] == "alice"
        assert [t for t in api.heard("1", mark) if t.startswith(("2", "3", "OH4"))] == []
        # stop is never refused
        r = await client.post("/axes/x/stop", json={"mode": "decelerate"}, headers=auth("bob"))
        assert r.status_code == 200
        assert "SS" in api.heard("1", mark)
        # the holder moves
        r = await client.post(
            "/axes/x/move?wait=true", json={"position": 100, "unit": "pulse"}, headers=auth("alice")
        )
        assert json_of(r)["position"] == 100
        # reading the lease is for viewers too; taking it is not
        r = await client.get("/axes/sim.1.1/lease", headers=auth("viewer"))
        assert json_of(r)["holder"] == "alice" and 0 < json_of(r)["remaining"] <= 60
        r = await client.post("/axes/x/lease", json={"ttl": 5}, headers=auth("viewer"))
        assert r.status_code == 403
        # only the holder (or an admin) gives it back
        r = await client.delete("/axes/x/lease", headers=auth("bob"))
        assert r.status_code == 409
        r = await client.delete("/axes/x/lease", headers=auth("admin"))
        assert r.status_code == 200 and json_of(r)["holder"] is None
        r = await client.post(
            "/axes/x/move?wait=true", json={"position": 5, "unit": "pulse"}, headers=auth("bob")
        )
        assert json_of(r)["position"] == 5


async def test_controller_lease_guards_both_axes() -> None:
    async with running_app(roles=True) as api:
        r = await api.client.post("/controllers/sim.2/lease", headers=auth("alice"))
        assert r.status_code == 200 and json_of(r)["resource"] == "sim.2"
        r = await api.client.post("/axes/theta/step", json={"direction": "cw"}, headers=auth("bob"))
        assert r.status_code == 409 and json_of(r)["holder"] == "alice"
        r = await api.client.post(
            "/axes/x/step?wait=true", json={"direction": "cw"}, headers=auth("bob")
        )
        assert r.status_code == 200  # another controller
        r = await api.client.get("/controllers/nope/lease", headers=auth("viewer"))
        assert r.status_code == 404
