"""Who may do what: three roles (viewer, operator, admin), each allowing everything of the ones
below, so that a token given to a dashboard cannot move a machine."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Role"]


class Role(StrEnum):
    """viewer (read, subscribe) < operator (motion, settings, leases) < admin (raw, EEPROM,
    programs, mode, framing, line trace)."""

    VIEWER = "viewer"
    OPERATOR = "operator"
    ADMIN = "admin"

    @property
    def rank(self) -> int:
        """0 for viewer, 1 operator, 2 admin."""
        return _RANKS[self]

    def allows(self, required: Role) -> bool:
        """True when this role may do what ``required`` may."""
        return self.rank >= required.rank


_RANKS = {Role.VIEWER: 0, Role.OPERATOR: 1, Role.ADMIN: 2}
