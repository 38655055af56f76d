"""The audit record: what was asked of the machines, written before it acts, that cannot tear.

``record`` (``AuditRecord``: write-ahead and queued entries, the newest in memory),
``chain_file`` (the file: numbered, chained by SHA-256, cut back on a failed write, rotated),
``bounds`` (values of bounded size), ``history`` (older pages read back from the files) and
``verify`` (checking files after the fact).
"""

from gateway.service.audit.chain_file import ChainFile, RotationPolicy
from gateway.service.audit.record import (
    MEMORY,
    MEMORY_BYTES,
    PAGE_LIMIT,
    AuditRecord,
    AuditUnavailable,
    FsyncPolicy,
    WriteAhead,
    utc_now,
)
from gateway.service.audit.verify import Break, Verified, verify

__all__ = [
    "MEMORY",
    "MEMORY_BYTES",
    "PAGE_LIMIT",
    "AuditRecord",
    "AuditUnavailable",
    "Break",
    "ChainFile",
    "FsyncPolicy",
    "RotationPolicy",
    "Verified",
    "WriteAhead",
    "utc_now",
    "verify",
]
