"""Tests of the REST and WebSocket API."""
