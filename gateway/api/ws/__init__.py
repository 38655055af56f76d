"""The WebSocket face: the endpoint, its messages and their AsyncAPI document."""
