"""rc233-gateway: RORZE RC-233 motion controllers on the network."""

__version__ = "0.1.0"
