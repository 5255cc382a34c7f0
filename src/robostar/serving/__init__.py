"""Serving the N1 protocol in the controller role, to many host programs at once.

One machinery for the simulator and the line server; each connection is its own N1 session.

- :class:`Session` (sans-IO, a :class:`~robostar.transport.peer.BytePeer`): one connection's
  :class:`~robostar.protocol.link.ControllerLink`; decodes each request with the command
  registry, assembles an FB upload (the whole :class:`~robostar.commands.files.UploadFile`,
  lines included, is handed over at the END, within :class:`UploadLimits`) and hands every
  request to its :class:`Backend` as a :class:`Request`.
- :class:`Backend`: ``handle(request)`` answers now or later with ``request.answer(result)``
  (encoded by the command's ``encode_answer``) or ``request.refuse(reason, flag)`` (0x31, 0x32,
  0x33; the reason is the session's ``last_error``, KD's text); raising :class:`Refusal` refuses
  too. Two-phase commands (DB, DC, CE): ``answer(wait)`` sends the first answer, ``finish()``
  (or ``refuse``) the second, always to the session that asked; once that session moved on,
  ``request.live`` is False and answers are dropped; ``request.abort(reason)`` ends the exchange
  with RST instead (an outcome the backend cannot tell). KD is the backend's to answer (the
  session's ``last_error`` holds the last refusal of that session). Hooks, each given the
  session: ``begin_upload`` (refuse an FB before its lines, synchronously),
  ``exchange_abandoned`` (the host gave up a request the backend still has), ``note_error``,
  ``session_closed``.
- Hosts: :class:`AsyncHost` (asyncio, one session per TCP connection, ``max_clients``) and the
  threaded :class:`~robostar.serving.threaded.PeerHost` the simulator runs on (TCP clients and a
  pseudo-terminal, each its own line). Both drop one failing or stalled connection and go on.

A backend that answers AA later, from a task::

    class Status(Backend):
        def handle(self, request: Request) -> None:
            if not isinstance(request.command, ReadStatus):
                raise Refusal("only AA here", FLAG_UNSUPPORTED)
            asyncio.get_running_loop().call_later(0.01, request.answer, STATUS)

    backend = Status()
    host = AsyncHost(lambda name: Session(backend, name=name), max_clients=8)
    address = await host.start("127.0.0.1", 0)
"""

from robostar.serving.address import (
    DEFAULT_LISTEN,
    check_host,
    check_port,
    is_loopback,
    parse_listen,
    tcp_url,
    warn_remote,
)
from robostar.serving.aio import AsyncHost
from robostar.serving.session import Backend, Refusal, Request, Session, UploadLimits
from robostar.serving.threaded import PeerHost, SessionSource

__all__ = [
    "DEFAULT_LISTEN",
    "AsyncHost",
    "Backend",
    "PeerHost",
    "Refusal",
    "Request",
    "Session",
    "SessionSource",
    "UploadLimits",
    "check_host",
    "check_port",
    "is_loopback",
    "parse_listen",
    "tcp_url",
    "warn_remote",
]
