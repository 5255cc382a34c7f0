"""The N1 protocol in the controller role: one session per host connection, sans-IO.

The machinery the simulator and the line server's N1 face share; each runs it on a host of its
own (the simulator's threaded :class:`~robostar.sim.host.PeerHost`, the N1 face's asyncio
:class:`~robostar.serve.faces.n1.host.AsyncHost`), with the limits of
:mod:`robostar.controller_role.limits`.

- :class:`ControllerSession` (sans-IO, a :class:`~robostar.transport.peer.BytePeer`): one
  connection's :class:`~robostar.protocol.link.ControllerLink`; decodes each request with the
  command registry, assembles an FB upload (the whole :class:`~robostar.commands.files.UploadFile`,
  lines included, is handed over at the END, within :class:`UploadLimits`) and hands every request
  to its :class:`Backend` as a :class:`Request`.
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
- Hosts (not in this package, each beside the one that runs it): the N1 face's
  :class:`~robostar.serve.faces.n1.host.AsyncHost` (asyncio, one session per TCP connection,
  ``max_clients``) and the simulator's threaded :class:`~robostar.sim.host.PeerHost` (TCP
  clients and a pseudo-terminal, each its own line). Both drop one failing or stalled connection
  and go on.

A backend that answers AA later, from a task::

    class Status(Backend):
        def handle(self, request: Request) -> None:
            if not isinstance(request.command, ReadStatus):
                raise Refusal("only AA here", FLAG_UNSUPPORTED)
            asyncio.get_running_loop().call_later(0.01, request.answer, STATUS)

    backend = Status()
    # AsyncHost: the N1 face's host
    host = AsyncHost(lambda name: ControllerSession(backend, name=name), max_clients=8)
    address = await host.start("127.0.0.1", 0)
"""

from robostar.controller_role.limits import HostLimits
from robostar.controller_role.session import (
    Backend,
    ControllerSession,
    Refusal,
    Request,
    UploadLimits,
)

__all__ = [
    "Backend",
    "ControllerSession",
    "HostLimits",
    "Refusal",
    "Request",
    "UploadLimits",
]
