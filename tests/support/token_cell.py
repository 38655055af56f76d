"""A served cell with a viewer's and an operator's token, to show where a token may appear."""

from __future__ import annotations

from gateway.api.security import hash_token

VIEWER = "VIEWtok-encoded-9c1d"


OPERATOR = "OPERtok-encoded-4e7b"


CELL = f"""
audit_log = "{{audit}}"

[security]
[[security.tokens]]
name = "dashboard"
role = "viewer"
sha256 = "{hash_token(VIEWER)}"

[[security.tokens]]
name = "mes"
role = "operator"
sha256 = "{hash_token(OPERATOR)}"

[[loops]]
name = "cell"
port = "/dev/serial/by-id/not-here"   # replaced by a simulated loop

[[loops.controllers]]
body = "1"

[[loops.controllers.axes]]
motor = 1
name = "x"
"""
