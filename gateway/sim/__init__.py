"""The simulated RC-233 loop: built on gateway.protocol, never imported by the gateway proper."""
