"""The running gateway takes its transports from whoever owns the process: it opens none."""

from __future__ import annotations

import pytest

from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config


def test_a_loop_without_a_transport_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match=SIM_LOOP):
        Runtime(simulated_config(["1"]), transports={})
