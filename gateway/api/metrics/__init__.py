"""What ``GET /metrics`` exposes: HTTP, WebSocket, cell, process and worker series."""
