"""The running gateway: the loops' schedulers and pollers, the state cache, the service events,
the control states and the key switch reader, built from the configuration (``Runtime``); the
state log; the bus's words the faces read (``bus_types``); the simulated configuration
(``simulated``)."""

from gateway.service.runtime.runtime import Runtime

__all__ = ["Runtime"]
