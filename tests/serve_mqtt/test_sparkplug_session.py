"""The Sparkplug B session rules without a broker (robostar.serve.faces.mqtt.sparkplug.session),
each payload read by the independent decoder: seq wraps from 255 to 0, bdSeq is one more per
connection and wraps too, a DDATA carries only what changed and by alias, a value of another type
or an undeclared metric needs a birth, a quality change carries the Quality property."""

from __future__ import annotations

import pytest

from robostar.serve.faces.mqtt.sparkplug.session import (
    Metric,
    NeedsBirth,
    NodeSession,
    SparkplugTopics,
)
from robostar.serve.model import Quality

from . import sparkplug_wire as wire


def _session() -> NodeSession:
    session = NodeSession(SparkplugTopics("g", "n"))
    session.next_connection(now=0.0)
    session.node_birth(now=0.0)
    return session


def test_seq_wraps_from_255_to_0_and_bdseq_counts_connections() -> None:
    session = _session()
    session.device_birth("d", [Metric("m", 0, 0.0)], now=0.0)  # seq 1
    datas = [session.device_data("d", [Metric("m", k, 0.0)]) or b"" for k in range(1, 300)]
    seqs = [wire.read(data).seq for data in datas]
    assert seqs[:3] == [2, 3, 4] and seqs[253:256] == [255, 0, 1]
    deaths = [wire.read(session.next_connection(now=0.0)).metrics[0].value for _ in range(300)]
    assert deaths[:2] == [1, 2] and deaths[254:257] == [255, 0, 1]


def test_data_by_alias_only_what_changed_and_births_when_needed() -> None:
    session = _session()
    birth = wire.read(
        session.device_birth("d", [Metric("a", 1.5, 1.0, "mm"), Metric("b", True, 1.0)])
    )
    aliases = {m.name: m.alias for m in birth.metrics}
    assert birth.metrics[0].properties == {"engUnit": "mm", "Quality": 192}
    assert session.device_data("d", [Metric("a", 1.5, 2.0), Metric("b", True, 2.0)]) is None
    data = wire.read(session.device_data("d", [Metric("a", 2, 3.0), Metric("b", True, 3.0)]) or b"")
    assert [(m.name, m.alias, m.value) for m in data.metrics] == [(None, aliases["a"], 2.0)]
    stale = wire.read(session.device_data("d", [Metric("a", 2, 4.0, quality=Quality.STALE)]) or b"")
    assert stale.metrics[0].properties == {"Quality": 500}
    with pytest.raises(NeedsBirth):
        session.device_data("d", [Metric("b", "text", 5.0)])  # Boolean declared
    with pytest.raises(NeedsBirth):
        session.device_data("d", [Metric("c", 1, 5.0)])  # never declared
    again = wire.read(session.device_birth("d", [Metric("a", 2.0, 6.0), Metric("c", 1, 6.0)]))
    assert {m.name: m.alias for m in again.metrics}["a"] == aliases["a"]  # stable
