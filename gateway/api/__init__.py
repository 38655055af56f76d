"""The REST and WebSocket API (issue 5): FastAPI routes over the service layer."""
