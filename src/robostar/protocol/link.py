"""The link layer (ACK/NAK/RST, resends, timeouts) as one transition table, for both roles.

No I/O and no clock: the driver feeds bytes with :meth:`Link.receive_data`, takes bytes to write
from :meth:`Link.data_to_send`, asks :meth:`Link.next_deadline` when to call
:meth:`Link.handle_timeout`, and passes the current time (any monotonic seconds) into every call.
Each call returns the events it produced.

Every allowed ``(state, input)`` pair is in :data:`TRANSITIONS`; a pair that is not there is a
rule broken by the peer (the link sends RST and reports :class:`ExchangeFailed` with a
:class:`~robostar.errors.LinkRuleError`) or, for an app call, raised as LinkRuleError at once.
``docs/protocol.md`` draws the table.

The parts live in modules of their own, re-exported here: the states, inputs and transition
table (``link_table``), the events (``link_events``), the common machine (``link_base``), the
host's end (``link_host``, with its resync rules, fence, timers and clean-answer fast path in
``link_resync``, ``link_fence``, ``link_timers``, ``link_fast``) and the controller's end
(``link_controller``).
"""

from __future__ import annotations

from robostar.protocol.link_base import Link, announced_wait
from robostar.protocol.link_controller import ControllerLink
from robostar.protocol.link_events import (
    AnswerReceived,
    ExchangeComplete,
    ExchangeFailed,
    Fence,
    Ignored,
    LinkEvent,
    PeerMovedOn,
    RequestReceived,
    UploadPacketReceived,
    UploadReady,
)
from robostar.protocol.link_host import HostLink
from robostar.protocol.link_table import (
    APP_TURN,
    EARLY_CODES,
    MAX_ANNOUNCED_WAIT,
    MAX_BACKLOG,
    MAX_MULTI_PACKETS,
    MAX_NAKS,
    MAX_RESENDS,
    STOP_CODES,
    TRANSITIONS,
    After,
    FailReason,
    Input,
    Role,
    State,
)

__all__ = [
    "APP_TURN",
    "EARLY_CODES",
    "MAX_ANNOUNCED_WAIT",
    "MAX_BACKLOG",
    "MAX_MULTI_PACKETS",
    "MAX_NAKS",
    "MAX_RESENDS",
    "STOP_CODES",
    "TRANSITIONS",
    "After",
    "AnswerReceived",
    "ControllerLink",
    "ExchangeComplete",
    "ExchangeFailed",
    "FailReason",
    "Fence",
    "HostLink",
    "Ignored",
    "Input",
    "Link",
    "LinkEvent",
    "PeerMovedOn",
    "RequestReceived",
    "Role",
    "State",
    "UploadPacketReceived",
    "UploadReady",
    "announced_wait",
]
