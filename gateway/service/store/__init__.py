"""The durable state: a SQLite database in the state directory (``StateStore``), with the
operations, the idempotency keys and the counters that must outlive the process (``records``),
and where the state directory is when the configuration names none (``location``)."""

from gateway.service.store.database import StateStore
from gateway.service.store.location import default_state_dir
from gateway.service.store.records import RequestKey, StoredKey, request_key

__all__ = ["RequestKey", "StateStore", "StoredKey", "default_state_dir", "request_key"]
