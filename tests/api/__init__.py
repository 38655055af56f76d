"""Tests of the REST and WebSocket API (issue 5)."""
