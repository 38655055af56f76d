"""Where the running gateway (now ``gateway.service.runtime.Runtime``) lived, under the name
``Gateway``: kept only while ``api/app.py`` imports it from here (it is being edited on
another branch); delete once that import names ``gateway.service.runtime``. A package, not a
module, so that git follows the old module to its new home."""

from gateway.service.runtime.runtime import Runtime as Gateway

__all__ = ["Gateway"]
