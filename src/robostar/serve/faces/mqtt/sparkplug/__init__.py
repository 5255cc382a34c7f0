"""Sparkplug B on the MQTT face: the server an edge node, each line a device.

``session`` keeps the specification's rules (bdSeq, seq, aliases, births and deaths) without
I/O; ``node`` runs them on one MQTT connection. ``sparkplug_b_pb2`` is generated from
``sparkplug_b.proto`` (``make generate``).
"""
