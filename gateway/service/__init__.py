"""What users act on, by resource: the running gateway (``runtime``), the axes (``axes``),
their operations (``operations``) and the controllers (``controllers``); shared by them, the
configuration, names and ids (``topology``), views, leases, roles, local/remote control,
service events, the WebSocket feed, stop-all and the loop's baud change.
See docs/architecture.md."""
