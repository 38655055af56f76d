"""The MQTT face: the gateway as a Sparkplug B edge node (``[mqtt]`` in the configuration).

A northbound face beside ``gateway.api``: it reads the one state cache and publishes it to a
broker (``edge_node``), with the Sparkplug payloads of ``sparkplug`` and the metrics of
``metric_table``; DCMD stop and acknowledge in ``commands``. ``sparkplug_b_pb2`` is generated
from Eclipse Tahu's ``sparkplug_b.proto`` (tests/mqtt/test_generated.py says how).
"""
