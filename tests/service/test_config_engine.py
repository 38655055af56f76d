"""``[engine] workers`` groups the loops into line worker processes: every loop in exactly one
group, no unknown name, each error naming the key and the rule; without it, one worker a
loop on a host with more than one core, one for all on a host with one."""

from __future__ import annotations

from typing import Any

import pytest

from gateway.service.config import ConfigError, parse_config
from gateway.service.config_engine import EngineSettings, worker_groups


def _cell(engine: dict[str, Any] | None = None) -> dict[str, Any]:
    loops = [
        {"name": name, "port": f"socket://127.0.0.1:{port}", "controllers": [{"body": "1"}]}
        for name, port in (("a", 4001), ("b", 4002), ("c", 4003))
    ]
    return {"loops": loops} | ({"engine": engine} if engine is not None else {})


@pytest.mark.parametrize(
    ("workers", "says"),
    [
        ([["a", "b"], ["zz", "c"]], "engine.workers[1][0]: 'zz' is not a loop of this file"),
        ([["a", "b"], ["b", "c"]],
         "engine.workers[1][0]: loop 'b' is already in engine.workers[0][1]"),
        ([["a"], ["c"]],
         "engine.workers: the loops ['b'] are in no group (each loop in exactly one)"),
        ([["a", "b", "c"], []], "engine.workers[1]: a worker runs at least one loop"),
    ],
)  # fmt: skip
def test_bad_groups_are_refused_naming_the_key_and_the_rule(
    workers: list[list[str]], says: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config(_cell({"workers": workers}), "cell.toml")
    assert says in str(caught.value)


def test_a_bad_backoff_is_refused() -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config(_cell({"restart_backoff": [1.0, 0]}), "cell.toml")
    assert "engine.restart_backoff[1]: Input should be greater than 0" in str(caught.value)


def test_the_groups_as_configured() -> None:
    config = parse_config(_cell({"workers": [["c", "a"], ["b"]]}))
    assert worker_groups(config.engine, ["a", "b", "c"], cores=8) == [["c", "a"], ["b"]]


def test_by_default_one_worker_a_loop_unless_the_host_has_one_core() -> None:
    assert worker_groups(EngineSettings(), ["a", "b", "c"], cores=2) == [["a"], ["b"], ["c"]]
    assert worker_groups(EngineSettings(), ["a", "b", "c"], cores=1) == [["a", "b", "c"]]
