"""What the caller gives is what is sent: names the wire would change and values finer than a
field's resolution are refused before anything is encoded (issue #11)."""

from __future__ import annotations

import pytest

from robostar.commands.files import DeleteFile
from robostar.commands.job import SelectJob
from robostar.commands.motion import MoveBy
from robostar.commands.variables import WriteGlobalFloat
from robostar.errors import FieldError
from robostar.protocol.fields import FileName, encode_coord
from robostar.types import CoordSystem, MotionType


@pytest.mark.parametrize("name", ["A B.JOB", "AB\x00.JOB", " AB.JOB", "AB.JOB ", "A\tB.JOB"])
def test_a_name_the_wire_would_change_is_refused(name: str) -> None:
    with pytest.raises(FieldError, match="no spaces or control characters"):
        DeleteFile(1, name)
    with pytest.raises(FieldError, match="no spaces or control characters"):
        FileName.exact(name)


def test_a_padded_field_from_a_peer_is_still_read() -> None:
    assert str(FileName.parse("   RS.JOB")) == "RS.JOB"


def test_a_job_argument_is_taken_exactly() -> None:
    with pytest.raises(FieldError):
        SelectJob(1, "R S.JOB")


@pytest.mark.parametrize("value", [0.0004, 1e-9, 12.3456, -0.0001])
def test_a_request_value_finer_than_the_resolution_is_refused(value: float) -> None:
    with pytest.raises(FieldError, match=r"finer than the field's resolution of 0\.001"):
        WriteGlobalFloat(3, value).encode()
    with pytest.raises(FieldError, match="finer"):
        MoveBy(1, MotionType.JOINT, CoordSystem.ANGLE, (value,)).encode()


@pytest.mark.parametrize("value", [12.345, 0.1 + 0.2, -123.001, 99999.999, 0.0, 5])
def test_values_on_the_resolution_pass_whatever_their_binary_noise(value: float) -> None:
    assert encode_coord("GW", "value", value, exact=True) == encode_coord("GW", "value", value)


def test_an_answer_value_is_rounded_to_the_field() -> None:
    # A controller's computed position has more decimals than the field: it is rounded.
    assert encode_coord("AC", "axis 1", 1.23456) == b"     1.235"
