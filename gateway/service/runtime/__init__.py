"""The running gateway: the loops' schedulers and pollers, the state cache, the key switch
reader and the state log, built from the configuration (``gateway.Gateway``); the bus's words
the faces read (``bus_types``); the simulated configuration (``simulated``)."""
