"""The configuration of ``rc233-gateway serve --simulate``: one loop, its axes named.

No file needed: loop ``sim`` on a simulated line in its line worker, controllers 1, 2 and 3 by
default, each axis named and given a unit so that a first user sees what a real cell looks
like. Soft limits sit inside the simulator's default scene (limits at -5,000 and 95,000
pulses, gateway/sim/scene.py), so a move the gateway refuses is one a real cell would not
want either.
"""

from __future__ import annotations

from collections.abc import Sequence

from gateway.service.config import GatewayConfig, parse_config

__all__ = ["SIM_LOOP", "simulated_config"]

#: The loop's name in ``--simulate`` (axis ids are ``sim.1.1`` ...).
SIM_LOOP = "sim"

#: body -> (controller name, (axis name, unit, units per pulse) of motor 1 and 2)
_NAMES: dict[str, tuple[str, tuple[tuple[str, str, float], tuple[str, str, float]]]] = {
    "1": ("gantry", (("x", "mm", 0.01), ("y", "mm", 0.01))),
    "2": ("head", (("z", "mm", 0.01), ("theta", "deg", 0.01))),
    "3": ("handler", (("gripper", "pulse", 1.0), ("conveyor", "pulse", 1.0))),
}
#: Soft limits in pulses inside the scene's limit sensors (-5,000 .. 95,000).
_SOFT_PULSES = (-4_000, 94_000)


def simulated_config(
    bodies: Sequence[str] = ("1", "2", "3"), tokens: Sequence[dict[str, str]] = ()
) -> GatewayConfig:
    """The configuration of a simulated loop with ``bodies`` (and API ``tokens`` if given)."""
    controllers = []
    for body in bodies:
        name, axes = _NAMES.get(
            body, (f"ctl{body}", ((f"ax{body}a", "pulse", 1.0), (f"ax{body}b", "pulse", 1.0)))
        )
        controllers.append(
            {
                "body": body,
                "name": name,
                "axes": [
                    {
                        "motor": motor,
                        "name": axis,
                        "unit": unit,
                        "units_per_pulse": per,
                        "soft_min": round(_SOFT_PULSES[0] * per, 9),
                        "soft_max": round(_SOFT_PULSES[1] * per, 9),
                    }
                    for motor, (axis, unit, per) in zip((1, 2), axes, strict=True)
                ],
            }
        )
    return parse_config(
        {
            "loops": [{"name": SIM_LOOP, "port": "sim://line-worker", "controllers": controllers}],
            "security": {"tokens": list(tokens)},
        },
        "--simulate",
    )
