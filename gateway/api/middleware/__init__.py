"""The pure ASGI layers every request passes before (and after) a route."""
