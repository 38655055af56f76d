"""Where ``Gateway`` lived before ``service/runtime/``: kept only while ``api/app.py`` imports
it from here (it is being edited on another branch); delete once that import names
``gateway.service.runtime.gateway``."""

from gateway.service.runtime.gateway import Gateway

__all__ = ["Gateway"]
