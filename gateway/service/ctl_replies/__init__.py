"""Where ``CommandResponse`` lived before ``service/controllers/``: kept only while
``api/ctl_deps.py`` imports it from here (it is being edited on another branch); delete once
that import names ``gateway.service.controllers.replies``. A package, not a module, so that
git follows the old module to its new home."""

from gateway.service.controllers.replies import CommandResponse

__all__ = ["CommandResponse"]
