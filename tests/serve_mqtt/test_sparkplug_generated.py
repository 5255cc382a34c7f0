"""The checked-in Sparkplug B payload module is what protoc makes of sparkplug_b.proto (run
``make generate`` after changing the schema). Needs grpcio-tools (``make generate`` installs it);
skipped without it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_the_generated_module_is_fresh() -> None:
    pytest.importorskip("grpc_tools", reason="grpcio-tools is not installed (make generate)")
    tool = ROOT / "tools" / "generate_sparkplug.py"
    done = subprocess.run(
        [sys.executable, str(tool), "--check"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr


def test_the_schema_numbers_are_the_specifications() -> None:
    from robostar.serve.faces.mqtt.sparkplug import sparkplug_b_pb2 as pb

    metric = pb.Payload.Metric.DESCRIPTOR.fields_by_name
    assert pb.Payload.DESCRIPTOR.full_name == "org.eclipse.tahu.protobuf.Payload"
    assert (metric["name"].number, metric["alias"].number, metric["datatype"].number) == (1, 2, 4)
    assert (metric["long_value"].number, metric["string_value"].number) == (11, 15)
    assert (pb.Boolean, pb.Int64, pb.Double, pb.String) == (11, 4, 10, 12)
