"""Sparkplug B session rules for one edge node, sans-IO: topics, bdSeq, seq, aliases, payloads.

The node's lines are its devices. The rules (Sparkplug 3.0) this keeps:

- Every MQTT connection has a new ``bdSeq`` (0-255): the NDEATH set as the connection's last
  will carries it, and so does the NBIRTH published once connected, so a host application can
  tell which death belongs to which birth.
- ``seq`` counts every NBIRTH, DBIRTH, DDATA and DDEATH of a node session: the NBIRTH is 0, each
  message after it one more, 255 wrapping to 0. NDEATH has none.
- A birth names every metric with its alias, datatype, value, timestamp and properties
  (``engUnit``, ``Quality``); data messages after it use the alias alone. An alias belongs to
  one (device, name) for the life of the process, so it never changes across rebirths.
- A metric a birth did not declare, or a value of another type than the birth declared, cannot
  go in a DDATA: :class:`NeedsBirth` says the device must be born again.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass

from robostar.serve.faces.mqtt.leaves import Scalar
from robostar.serve.faces.mqtt.sparkplug import sparkplug_b_pb2 as pb
from robostar.serve.model import Quality

__all__ = [
    "BD_SEQ",
    "NAMESPACE",
    "REBIRTH",
    "Metric",
    "NeedsBirth",
    "NodeSession",
    "SparkplugTopics",
    "decode",
    "quality_code",
    "rebirth_request",
]

NAMESPACE = "spBv1.0"
BD_SEQ = "bdSeq"
REBIRTH = "Node Control/Rebirth"
QUALITY = "Quality"
ENG_UNIT = "engUnit"
_QUALITY_CODES = {Quality.GOOD: 192, Quality.STALE: 500, Quality.LINE_DOWN: 0}
"""Quality codes as Sparkplug host applications read the ``Quality`` property: 192 good,
500 stale, 0 bad (the line is down)."""

_U64 = (1 << 64) - 1


def quality_code(quality: Quality) -> int:
    return _QUALITY_CODES[quality]


@dataclass(frozen=True)
class SparkplugTopics:
    """``spBv1.0/<group>/<TYPE>/<node>[/<device>]`` and the primary host's STATE topic."""

    group: str
    node: str

    def of_node(self, kind: str) -> str:
        return f"{NAMESPACE}/{self.group}/{kind}/{self.node}"

    def of_device(self, kind: str, device: str) -> str:
        return f"{NAMESPACE}/{self.group}/{kind}/{self.node}/{device}"

    def device_commands(self) -> str:
        """The subscription filter for every device's DCMD."""
        return f"{NAMESPACE}/{self.group}/DCMD/{self.node}/+"

    @staticmethod
    def state(host: str) -> str:
        return f"{NAMESPACE}/STATE/{host}"


@dataclass(frozen=True)
class Metric:
    """One metric's value as read: ``at`` in unix seconds."""

    name: str
    value: Scalar
    at: float
    unit: str | None = None
    quality: Quality = Quality.GOOD


class NeedsBirth(Exception):
    """A DDATA cannot carry this metric (undeclared, or its type changed): birth the device."""


def _datatype(value: Scalar) -> int:
    if isinstance(value, bool):
        return pb.Boolean
    if isinstance(value, int):
        return pb.Int64
    if isinstance(value, float):
        return pb.Double
    return pb.String  # text, and a value not read yet (null), which is text until it is not


def _fits(datatype: int, value: Scalar) -> bool:
    if value is None:
        return True
    if datatype == pb.Double:
        return isinstance(value, int | float) and not isinstance(value, bool)
    return _datatype(value) == datatype


def _set_value(out: pb.Payload.Metric, datatype: int, value: Scalar) -> None:
    if value is None:
        out.is_null = True
    elif datatype == pb.Boolean:
        out.boolean_value = bool(value)
    elif datatype == pb.Int64:
        assert isinstance(value, int)
        out.long_value = value & _U64  # two's complement, as the specification says
    elif datatype == pb.Double:
        assert isinstance(value, int | float)
        out.double_value = float(value)
    else:
        out.string_value = str(value)


def _ms(seconds: float) -> int:
    return round(seconds * 1000)


class NodeSession:
    """One edge node's session state and payloads (see the module's docstring)."""

    def __init__(self, topics: SparkplugTopics) -> None:
        self.topics = topics
        self.bd_seq = -1
        """The current connection's bdSeq (-1: none yet)."""
        self.seq = 0
        self._aliases: dict[tuple[str, str], int] = {}
        self._names: dict[int, tuple[str, str]] = {}
        self._types: dict[tuple[str, str], int] = {}
        self._sent: dict[tuple[str, str], tuple[Scalar, Quality]] = {}
        self.born: set[str] = set()
        """The devices born in this node session (a DDATA needs its device born)."""

    # -- the node --------------------------------------------------------------------------
    def next_connection(self, now: float | None = None) -> bytes:
        """A new connection's bdSeq, and the NDEATH payload to set as its last will."""
        self.bd_seq = (self.bd_seq + 1) % 256
        self.born.clear()
        payload = pb.Payload(timestamp=_ms(time.time() if now is None else now))
        metric = payload.metrics.add(name=BD_SEQ, datatype=pb.Int64)
        metric.long_value = self.bd_seq
        return payload.SerializeToString()

    def node_birth(self, now: float | None = None) -> bytes:
        """The NBIRTH (seq 0): bdSeq, and the rebirth control a host application writes."""
        at = time.time() if now is None else now
        self.seq = 0
        self.born.clear()
        payload = pb.Payload(timestamp=_ms(at), seq=self._next_seq())
        bd = payload.metrics.add(name=BD_SEQ, datatype=pb.Int64, timestamp=_ms(at))
        bd.long_value = self.bd_seq
        rebirth = payload.metrics.add(name=REBIRTH, datatype=pb.Boolean, timestamp=_ms(at))
        rebirth.boolean_value = False
        return payload.SerializeToString()

    # -- the devices -----------------------------------------------------------------------
    def alias(self, device: str, name: str) -> int:
        key = (device, name)
        alias = self._aliases.get(key)
        if alias is None:
            alias = self._aliases[key] = len(self._aliases) + 1  # 0 is left for "none"
            self._names[alias] = key
        return alias

    def name_of(self, device: str, alias: int) -> str | None:
        key = self._names.get(alias)
        return key[1] if key is not None and key[0] == device else None

    def device_birth(
        self, device: str, metrics: Iterable[Metric], now: float | None = None
    ) -> bytes:
        """A DBIRTH declaring every metric (name, alias, datatype, value, time, properties)."""
        at = time.time() if now is None else now
        payload = pb.Payload(timestamp=_ms(at), seq=self._next_seq())
        for metric in metrics:
            key = (device, metric.name)
            datatype = _datatype(metric.value)
            self._types[key] = datatype
            self._sent[key] = (metric.value, metric.quality)
            out = payload.metrics.add(
                name=metric.name,
                alias=self.alias(device, metric.name),
                datatype=datatype,
                timestamp=_ms(metric.at),
            )
            _set_value(out, datatype, metric.value)
            if metric.unit is not None:
                _property(out, ENG_UNIT, pb.String, metric.unit)
            _property(out, QUALITY, pb.Int32, quality_code(metric.quality))
        self.born.add(device)
        return payload.SerializeToString()

    def changed(self, device: str, metric: Metric) -> bool:
        """Whether ``metric`` differs from what was last sent (value or quality)."""
        return self._sent.get((device, metric.name)) != (metric.value, metric.quality)

    def device_data(
        self, device: str, metrics: Iterable[Metric], now: float | None = None
    ) -> bytes | None:
        """A DDATA of the metrics that changed, by alias (None: nothing changed). Raises
        :class:`NeedsBirth` for a metric the device's birth did not declare as such."""
        changes = [m for m in metrics if self.changed(device, m)]
        if device not in self.born:
            raise NeedsBirth(f"device {device} is not born")
        for metric in changes:
            datatype = self._types.get((device, metric.name))
            if datatype is None or not _fits(datatype, metric.value):
                raise NeedsBirth(f"metric {metric.name} is new or changed its type")
        if not changes:
            return None
        at = time.time() if now is None else now
        payload = pb.Payload(timestamp=_ms(at), seq=self._next_seq())
        for metric in changes:
            key = (device, metric.name)
            datatype = self._types[key]
            out = payload.metrics.add(alias=self._aliases[key], timestamp=_ms(metric.at))
            _set_value(out, datatype, metric.value)
            if self._sent[key][1] != metric.quality:
                _property(out, QUALITY, pb.Int32, quality_code(metric.quality))
            self._sent[key] = (metric.value, metric.quality)
        return payload.SerializeToString()

    def declared(self, device: str, metric: Metric) -> bool:
        """Whether a birth of ``device`` declared ``metric`` with a type its value fits."""
        datatype = self._types.get((device, metric.name))
        return datatype is not None and _fits(datatype, metric.value)

    def historical_data(
        self, device: str, metrics: Iterable[Metric], now: float | None = None
    ) -> bytes | None:
        """A DDATA of changes made while the broker was away, each flagged ``is_historical``
        and timed when it was read, after the device's birth gave the current state. Metrics
        the birth does not declare as such are left out (None: none left)."""
        kept = [m for m in metrics if self.declared(device, m)]
        if device not in self.born or not kept:
            return None
        at = time.time() if now is None else now
        payload = pb.Payload(timestamp=_ms(at), seq=self._next_seq())
        for metric in kept:
            key = (device, metric.name)
            out = payload.metrics.add(
                alias=self._aliases[key], timestamp=_ms(metric.at), is_historical=True
            )
            _set_value(out, self._types[key], metric.value)
            _property(out, QUALITY, pb.Int32, quality_code(metric.quality))
        return payload.SerializeToString()

    def device_death(self, device: str, now: float | None = None) -> bytes:
        self.born.discard(device)
        at = time.time() if now is None else now
        return pb.Payload(timestamp=_ms(at), seq=self._next_seq()).SerializeToString()

    def _next_seq(self) -> int:
        seq = self.seq
        self.seq = (seq + 1) % 256
        return seq


def _property(metric: pb.Payload.Metric, key: str, datatype: int, value: int | str) -> None:
    metric.properties.keys.append(key)
    prop = metric.properties.values.add(type=datatype)
    if isinstance(value, str):
        prop.string_value = value
    else:
        prop.int_value = value


def rebirth_request(now: float | None = None) -> bytes:
    """An NCMD asking a node to be born again (as a host application asks it)."""
    payload = pb.Payload(timestamp=_ms(time.time() if now is None else now))
    metric = payload.metrics.add(name=REBIRTH, datatype=pb.Boolean)
    metric.boolean_value = True
    return payload.SerializeToString()


def decode(payload: bytes) -> pb.Payload:
    """A received payload (NCMD, DCMD); ``google.protobuf.message.DecodeError`` if not one."""
    message = pb.Payload()
    message.ParseFromString(payload)
    return message
