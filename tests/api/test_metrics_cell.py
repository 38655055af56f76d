"""/metrics per controller and per axis, build and process metrics, HEAD /metrics.

The real app on the in-process simulated loop (tests/support/sim_app.py); the simulator's
control surface presses EMS and switches a controller off.
"""

from __future__ import annotations

from gateway import __version__
from gateway.service.runtime.simulated import SIM_LOOP
from gateway.sim.control import Controls
from tests.support.exposition import parse_exposition, value
from tests.support.sim_app import running_app


async def _scrape(api):  # type: ignore[no-untyped-def]
    response = await api.client.get("http://localhost/metrics")
    assert response.status_code == 200
    return parse_exposition(response.text)


async def test_axes_and_controllers_each_have_their_series() -> None:
    async with running_app() as api:
        response = await api.client.post("/axes/x/move", json={"position": 1500, "unit": "pulse"},
                                          params={"wait": "true"})  # fmt: skip
        assert response.status_code == 200, response.text
        await api.until(lambda: api.runtime.state.axis(SIM_LOOP, "1", 1).position == 1500)
        fams = await _scrape(api)
        assert value(fams, "rc233_axis_position_pulses", axis="sim.1.1") == 1500
        assert value(fams, "rc233_axis_moving", axis="sim.1.1") == 0
        assert value(fams, "rc233_axis_stale", axis="sim.1.1") == 0
        info = value(fams, "rc233_axis_info", axis="sim.1.1", name="x", controller="sim.1",
                     unit="mm", units_per_pulse="0.01")  # fmt: skip
        assert info == 1
        for kind in ("limit_error", "emergency_stop", "command_error", "step_out"):
            assert value(fams, "rc233_axis_error_latched", axis="sim.2.1", kind=kind) == 0
        assert value(fams, "rc233_controller_online", controller="sim.1", name="gantry") == 1
        ops = value(fams, "rc233_controller_operations_total", controller="sim.1",
                    kind="move", state="done")  # fmt: skip
        assert ops == 1
        assert value(fams, "rc233_build_info", version=__version__, python=_python(fams)) == 1
        for name in ("process_cpu_seconds_total", "process_resident_memory_bytes",
                     "process_start_time_seconds", "process_open_fds"):  # fmt: skip
            assert value(fams, name) > 0


async def test_ems_latches_on_the_axis_series_and_a_silent_controller_has_no_position() -> None:
    async with running_app() as api:
        controls = Controls(api.sim)
        controls.ems("2", True)
        await api.until(lambda: api.runtime.state.axis(SIM_LOOP, "2", 1).emergency)
        fams = await _scrape(api)
        assert value(fams, "rc233_axis_error_latched", axis="sim.2.1", kind="emergency_stop") == 1
        latched = value(fams, "rc233_controller_error_latched", controller="sim.2", name="head",
                        kind="emergency_stop")  # fmt: skip
        assert latched == 1
        controls.power("3", False)
        await api.until(lambda: api.runtime.state.controller(SIM_LOOP, "3").online is False)
        fams = await _scrape(api)
        assert value(fams, "rc233_controller_online", controller="sim.3", name="handler") == 0
        assert value(fams, "rc233_axis_stale", axis="sim.3.1") == 1
        samples = fams["rc233_axis_position_pulses"].samples
        assert not [k for k in samples if ("axis", "sim.3.1") in k[1]]  # no last good number
        timeouts = value(fams, "rc233_controller_timeouts_total", controller="sim.3",
                         name="handler")  # fmt: skip
        assert timeouts > 0
        assert value(fams, "rc233_controller_timeouts_total", controller="sim.1",
                     name="gantry") == 0  # fmt: skip


async def test_head_metrics_answers_without_a_body() -> None:
    async with running_app() as api:
        response = await api.client.head("http://localhost/metrics")
        assert response.status_code == 200
        assert response.headers["content-type"].startswith("text/plain; version=0.0.4")
        assert response.content == b""
        assert int(response.headers["content-length"]) > 1000


def _python(fams):  # type: ignore[no-untyped-def]
    ((_, labels),) = list(fams["rc233_build_info"].samples)
    return dict(labels)["python"]


async def test_homed_is_a_series_of_every_axis_and_a_reset_clears_it() -> None:
    async with running_app(("1",)) as api:
        fams = await _scrape(api)
        assert value(fams, "rc233_axis_homed", axis="sim.1.1") == 0  # not known at start
        await api.client.post("/axes/x/move", json={"position": 2000, "unit": "pulse"},
                              params={"wait": "true"})  # fmt: skip
        r = await api.client.post("/axes/x/home", json={"method": "0"},
                                  params={"wait": "true", "timeout": "30"})  # fmt: skip
        assert r.status_code == 200, r.text
        fams = await _scrape(api)
        assert value(fams, "rc233_axis_homed", axis="sim.1.1") == 1
        assert value(fams, "rc233_axis_homed", axis="sim.1.2") == 0
        assert value(fams, "rc233_axis_counter", axis="sim.1.1") == 0
        await api.client.post("/axes/x/move", json={"position": 3000, "unit": "pulse"},
                              params={"wait": "true"})  # fmt: skip
        Controls(api.sim).power_cycle("1")
        for _ in range(2):  # two readings of 0 by itself show it (one could be noise)
            await api.client.get("/axes/x", params={"fresh": "true"})
        fams = await _scrape(api)
        assert value(fams, "rc233_axis_homed", axis="sim.1.1") == 0
