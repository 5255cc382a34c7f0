"""Byte pipes by URL (serial, tcp://, sim://, pyserial URLs). Knows nothing of the protocol."""

from robostar.transport.peer import BytePeer

__all__ = ["BytePeer"]
