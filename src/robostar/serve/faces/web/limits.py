"""The dashboard's size limits, derived from the largest file the N1 protocol carries.

The largest legitimate request is a file upload, and the largest file the protocol can carry is
a JOB of ``MAX_STEP`` (9999: FA announces it in 4 digits, ED reports steps up to it) steps, each
one FB content field of at most ``LINE_MAX`` (100) bytes with its newline (``robostar.commands``).
A file saved on Windows ends its lines with CR LF: one byte more per line, dropped before the
lines are sent. A PNT file is smaller (a point line is 73 bytes at most). How much a given
controller holds is its own business (the manual's example announces a capacity of 2000 steps):
past it the controller refuses the upload itself, and the dashboard shows its reason; the
dashboard only refuses what no controller could take.

Every other request the dashboard takes (a sign-in, an action, a point, a variable) is a few
hundred bytes: the general body limit stays tight, and only the upload routes take more.
"""

from __future__ import annotations

import re

from robostar.commands.files import LINE_MAX
from robostar.commands.job import MAX_STEP

__all__ = [
    "DEFAULT_MAX_BODY",
    "FORM_OVERHEAD",
    "MAX_UPLOAD",
    "MAX_UPLOAD_BODY",
    "UPLOAD_ROUTES",
    "upload_too_large",
]

MAX_UPLOAD = MAX_STEP * (LINE_MAX + 1)
"""The largest file the dashboard takes: 9999 steps of 99 characters and a CR LF (1,009,899
bytes). The preview's file and the confirmed content are each held to it."""

FORM_OVERHEAD = 16 * 1024
"""Room in an upload's body for the rest of the form: multipart boundaries and part headers (the
file's name), the CSRF token, channel, name and job number (well under 1 KiB in practice)."""

MAX_UPLOAD_BODY = MAX_UPLOAD + FORM_OVERHEAD
"""The body limit of the upload routes (preview and confirm), whatever ``max_body`` says."""

DEFAULT_MAX_BODY = 64 * 1024
"""The body limit of every other route (the ``max_body`` option's default)."""

UPLOAD_ROUTES = re.compile(r"/line/[^/]+/files/upload(?:/confirm)?")
"""The paths that carry a file (matched in full)."""


def upload_too_large(what: str) -> str:
    """The 413's message: what was too large, and the limit with where it comes from."""
    return (
        f"{what} is over {MAX_UPLOAD} bytes, the largest file the N1 protocol carries "
        f"({MAX_STEP} steps of at most {LINE_MAX - 1} characters and a line end)"
    )
