"""What a request may carry, checked before anything reaches the line: numbers in range, file
names the controller takes, coordinates, JSON bodies. A bad value is a :class:`Forbidden` (400)
that says in words what was wrong."""

from __future__ import annotations

import math
from typing import Any

from starlette.requests import Request

from robostar.client.files import point_lines
from robostar.commands.job import MAX_STEP
from robostar.errors import UsageError
from robostar.protocol.fields import FileName
from robostar.serve.faces.web.deps import Forbidden
from robostar.types import JobFile, PointFile

__all__ = [
    "coordinate",
    "file_name",
    "file_params",
    "file_text",
    "int_field",
    "json_body",
    "steps",
]


def int_field(value: object, name: str, low: int, high: int) -> int:
    if isinstance(value, bool):
        raise Forbidden(400, f"{name}: a whole number {low}-{high}")
    try:
        number = int(str(value).strip())
    except ValueError:
        raise Forbidden(400, f"{name}: a whole number {low}-{high}, not {value!r}") from None
    if not low <= number <= high:
        raise Forbidden(400, f"{name}: {number} is not in {low}-{high}")
    return number


def file_name(text: str) -> FileName:
    try:
        name = FileName.parse(text.strip())
        return name.check("", "name")
    except UsageError as exc:
        raise Forbidden(400, str(exc)) from None


def steps(name: FileName, text: str) -> tuple[str, ...]:
    """An uploaded file's lines, as FB will send them; a JOB of more steps than the protocol
    counts (FA could not even announce its length) is refused before anything is sent."""
    lines = tuple(text.splitlines())
    if name.is_job and len(lines) > MAX_STEP:
        raise Forbidden(400, f"{name} has {len(lines)} lines; a job holds at most {MAX_STEP}")
    return lines


def file_params(request: Request) -> tuple[int, FileName]:
    channel = int_field(request.path_params["channel"], "channel", 1, 3)
    return channel, file_name(request.path_params["name"])


def file_text(content: JobFile | PointFile) -> str:
    if isinstance(content, JobFile):
        return "\n".join(content.lines) + "\n"
    return "\n".join(point_lines(content)) + "\n"


def coordinate(value: object, name: str) -> float:
    text = str(value).strip() if value is not None else ""
    if not text:
        raise Forbidden(400, f"{name}: enter a number")
    try:
        number = float(text)
    except ValueError:
        raise Forbidden(400, f"{name}: {text!r} is not a number") from None
    if not math.isfinite(number) or abs(number) >= 1e6:
        raise Forbidden(400, f"{name}: {text} is not a coordinate")
    if round(number, 3) != number:
        raise Forbidden(400, f"{name}: at most 3 decimals ({text})")
    return number


async def json_body(request: Request) -> dict[str, Any]:
    try:
        body = await request.json()
    except ValueError:
        raise Forbidden(400, "the body is not JSON") from None
    if not isinstance(body, dict):
        raise Forbidden(400, "the body must be a JSON object")
    return body
