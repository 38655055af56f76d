"""What every part of the configuration shares: the strict section model, the name rule and
the error that names the key at fault."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from gateway.errors import GatewayError

__all__ = ["NAME_PATTERN", "ConfigError", "Name", "Strict"]

#: Names of loops, controllers and axes: no dots, so a name never reads as an id (`main.1.2`).
NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_-]{0,31}$"
Name = Annotated[str, Field(pattern=NAME_PATTERN)]


class ConfigError(GatewayError):
    """The configuration breaks a rule; the message names every key at fault."""


class Strict(BaseModel):
    """A section of the file: unknown keys refused, frozen, every float finite."""

    # allow_inf_nan: a NaN limit compares false with everything (a limit silently off), an
    # infinite scale turns every target into 0 or inf; every float of the file is finite.
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
