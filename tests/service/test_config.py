"""The TOML configuration: every problem named by its key, the annotated example valid."""

from __future__ import annotations

from pathlib import Path

import pytest

from gateway.bus.config import LoopConfig
from gateway.bus.poll_plan import PollConfig
from gateway.service.config import ConfigError, load_config, parse_config
from gateway.service.roles import Role
from gateway.service.runtime.runtime import loop_config, poll_config
from gateway.service.topology import Topology

EXAMPLE = Path(__file__).parents[2] / "deploy" / "cell.example.toml"

MINIMAL = {"loops": [{"name": "main", "port": "socket://127.0.0.1:5233", "controllers": [
    {"body": "1"}]}]}  # fmt: skip


def _with(**changes: object) -> dict[str, object]:
    loop = dict(MINIMAL["loops"][0]) | changes  # type: ignore[index]
    return {"loops": [loop]}


def test_the_deploy_example_ships_no_working_token_and_says_what_it_holds(
    tmp_path: Path,
) -> None:
    # As shipped, the tokens are placeholders that are no digest: the file is refused.
    with pytest.raises(ConfigError) as caught:
        load_config(EXAMPLE)
    problems = str(caught.value).splitlines()[1:]
    assert [p.split(":")[0].strip() for p in problems] == [
        "security.tokens[0].sha256",
        "security.tokens[1].sha256",
    ]
    # With each placeholder replaced by a real digest, the rest of the file is valid.
    text = EXAMPLE.read_text("utf-8")
    placeholder = '"REPLACE-with-the-sha256-line-of-rc233-gateway-token"'
    for digit in "12":
        text = text.replace(placeholder, f'"{digit * 64}"', 1)
    filled = tmp_path / "cell.toml"
    filled.write_text(text, "utf-8")
    config = load_config(filled)
    loop = config.loops[0]
    assert loop.name == "main" and loop.baud == 9600
    assert [c.body for c in loop.controllers] == ["1", "2"]
    x = loop.controllers[0].axes[0]
    assert (x.name, x.unit, x.units_per_pulse, x.soft_min, x.soft_max) == (
        "x", "mm", 0.01, -5.0, 900.0)  # fmt: skip
    assert [t.role for t in config.security.tokens] == [Role.OPERATOR, Role.VIEWER]
    assert config.security.open_metrics and config.security.open_docs


def test_defaults_of_a_minimal_file() -> None:
    config = parse_config(MINIMAL)
    loop = config.loops[0]
    assert loop.timeouts.nak_retries == 3 and loop.poll.moving_period == 0.18
    assert config.security.tokens == [] and config.audit_log is None


@pytest.mark.parametrize(
    ("data", "key", "words"),
    [
        (_with(baud=19200), "loops[0]", "baud 19200: one of 9600, 1200, 300"),
        (_with(controllers=[{"body": "F"}]), "loops[0].controllers[0].body", "pattern"),
        (_with(controllers=[{"body": "1"}, {"body": "1"}]), "loops[0]", "body number once"),
        (_with(controllers=[]), "loops[0].controllers", "at least 1"),
        (_with(name="main.x"), "loops[0].name", "pattern"),
        (_with(colour="red"), "loops[0].colour", "Extra inputs are not permitted"),
        (
            _with(timeouts={"nak_retries": -1}),
            "loops[0].timeouts.nak_retries",
            "greater than or equal to 0",
        ),
        (
            _with(controllers=[{"body": "1", "axes": [{"motor": 3}]}]),
            "loops[0].controllers[0].axes[0].motor",
            "1 or 2",
        ),
        (
            _with(
                controllers=[{"body": "1", "axes": [{"motor": 1, "soft_min": 5, "soft_max": 1}]}]
            ),
            "loops[0].controllers[0].axes[0]",
            "soft_min 5.0 must be below soft_max 1.0",
        ),
        (
            _with(controllers=[{"body": "1", "axes": [{"motor": 1, "units_per_pulse": 0}]}]),
            "loops[0].controllers[0].axes[0].units_per_pulse",
            "greater than 0",
        ),
        (
            MINIMAL | {"security": {"tokens": [{"name": "a", "role": "boss", "sha256": "0" * 64}]}},
            "security.tokens[0].role",
            "'viewer', 'operator' or 'admin'",
        ),
        (
            MINIMAL | {"security": {"tokens": [{"name": "a", "role": "admin", "sha256": "abc"}]}},
            "security.tokens[0].sha256",
            "pattern",
        ),
    ],
)
def test_a_bad_value_is_named_by_its_key(data: dict[str, object], key: str, words: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config(data, "cell.toml")
    text = str(caught.value)
    assert text.startswith("cell.toml: ")
    assert f"  {key}: " in text, text
    assert words in text, text


def test_names_are_unique_across_the_file() -> None:
    data = _with(name="x", controllers=[{"body": "1", "axes": [{"motor": 1, "name": "x"}]}])
    with pytest.raises(ConfigError, match=r"axes\[0\]\.name: name 'x' is already used by "
                       r"loops\[0\]\.name"):  # fmt: skip
        parse_config(data)


def test_file_problems_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read the file"):
        load_config(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[loops]\nname=1\n")
    with pytest.raises(ConfigError, match=r"bad\.toml: not valid TOML"):
        load_config(bad)


def test_environment_overrides_a_top_level_key(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RC233_AUDIT_LOG", "/tmp/audit.jsonl")
    assert parse_config(MINIMAL).audit_log == Path("/tmp/audit.jsonl")


def test_timeouts_and_poll_periods_are_the_bus_settings_with_the_bus_defaults() -> None:
    # The file's [loops.timeouts] and [loops.poll] are LoopConfig's and PollConfig's fields:
    # the same names, the same defaults, and a value set in the file reaches the scheduler.
    loop = parse_config(MINIMAL).loops[0]
    for name, value in loop.timeouts.model_dump().items():
        assert getattr(LoopConfig(), name) == value, name
    for name, value in loop.poll.model_dump().items():
        assert getattr(PollConfig(), name) == value, name
    config = parse_config(
        _with(timeouts={"turnaround": 0.05, "nak_retries": 5}, poll={"idle_period": 2.5})
    )
    ref = Topology(config).loop("main")
    scheduler = loop_config(config.loops[0], ref, 1.0)
    assert (scheduler.turnaround, scheduler.nak_retries) == (0.05, 5)
    assert poll_config(config.loops[0]).idle_period == 2.5
