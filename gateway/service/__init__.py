"""Axes and controllers as users see them: configuration, names, views, operations, leases."""
