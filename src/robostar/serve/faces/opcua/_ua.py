"""asyncua's names with the types its stubs lack, in one place.

asyncua's ``ua`` package re-exports ``ObjectIds``, ``StatusCodes`` and ``AttributeIds`` without
declaring them, and types node ids and status codes with ``NewType``s of int; these helpers
take plain ints so that the face's code stays readable and checked.
"""

from __future__ import annotations

import datetime as dt
from typing import Any, cast

from asyncua import ua
from asyncua.ua.attribute_ids import AttributeIds
from asyncua.ua.object_ids import ObjectIds
from asyncua.ua.status_codes import StatusCodes
from asyncua.ua.uaerrors import UaStatusCodeError

__all__ = [
    "AttributeIds",
    "ObjectIds",
    "StatusCodes",
    "UaStatusCodeError",
    "node_id",
    "status",
    "timestamp",
]


def node_id(identifier: int | str, namespace: int = 0) -> ua.NodeId:
    return ua.NodeId(cast(Any, identifier), cast(Any, namespace))


def status(code: int) -> ua.StatusCode:
    return ua.StatusCode(cast(Any, code))


def timestamp(moment: dt.datetime) -> Any:
    """A datetime as asyncua's DateTime (the same object; its stubs name it apart)."""
    return moment
