"""The HTTP routes, by resource, with their dependencies and request bodies."""
