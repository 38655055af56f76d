"""The REST and WebSocket API: FastAPI routes over the service layer."""
