"""The audit log as the API serves it: the service's record plus its Prometheus series.

The record itself is ``gateway.service.audit.AuditRecord`` (entries written ahead of what acts,
numbered and chained in a file that cannot tear, the newest in memory), the one the services
hold. ``audit_exposition`` is what ``/metrics`` says of it: entries written, write errors,
requests refused because their entry could not be written, and whether the file takes writes
(``rc233_audit_log_ok``).
"""

from __future__ import annotations

from gateway.api.metrics.exposition import Exposition
from gateway.service.audit import MEMORY, PAGE_LIMIT, AuditRecord

__all__ = ["MEMORY", "PAGE_LIMIT", "audit_exposition"]


def audit_exposition(audit: AuditRecord) -> str:
    """The metrics of the audit record ``audit`` in the Prometheus text format."""
    out = Exposition()
    out.family("rc233_audit_entries_total", "counter", "Audit entries recorded.")
    out.sample("rc233_audit_entries_total", {}, audit.last_seq)
    out.family(
        "rc233_audit_write_errors_total", "counter", "Audit lines a write to the file failed."
    )
    out.sample("rc233_audit_write_errors_total", {}, audit.write_errors)
    out.family(
        "rc233_audit_refused_total",
        "counter",
        "Requests refused (503) because their audit entry could not be written.",
    )
    out.sample("rc233_audit_refused_total", {}, audit.refused)
    out.family("rc233_audit_log_ok", "gauge", "0 while the last write to the file failed.")
    out.sample("rc233_audit_log_ok", {}, 1 if audit.healthy else 0)
    return out.text()
