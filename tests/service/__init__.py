"""Tests of gateway/service: configuration, topology, the running gateway."""
