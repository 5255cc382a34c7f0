"""The hooks a backend has into its sessions, on the ControllerSession itself (no host, no
line): who uploads (``begin_upload`` is given the session), ending an exchange with RST
(``Request.abort``), and hearing at once that the host gave an exchange up (``exchange_abandoned``).
A backend serves many sessions, and these are what the line server needs of them (it once reached
into the session for each)."""

from __future__ import annotations

from robostar.commands.control import SetSpeed
from robostar.commands.files import UploadFile
from robostar.commands.status import ReadStatus
from robostar.controller_role import Backend, ControllerSession, Refusal, Request
from robostar.protocol.fields import FLAG_FAILED
from robostar.protocol.frame import ACK, NAK, RST, encode_packet

ACK_B = bytes((ACK,))
NAK_B = bytes((NAK,))
RST_B = bytes((RST,))
FB = UploadFile(1, "A.JOB", 2, ("MAIN", "EOP"))


def _request(command: SetSpeed | ReadStatus | UploadFile) -> bytes:
    return encode_packet(command.encode())


class Keeper(Backend):
    """Keeps every request unanswered (as a backend whose work is queued), and notes each hook."""

    def __init__(self, uploader: ControllerSession | None = None) -> None:
        self.requests: list[Request] = []
        self.uploads: list[tuple[ControllerSession, UploadFile]] = []
        self.abandoned: list[tuple[ControllerSession, Request]] = []
        self.uploader = uploader
        """The only session allowed to upload (None: any)."""

    def handle(self, request: Request) -> None:
        self.requests.append(request)

    def begin_upload(self, session: ControllerSession, command: UploadFile) -> None:
        self.uploads.append((session, command))
        if self.uploader is not None and session is not self.uploader:
            raise Refusal(f"only {self.uploader.name} uploads here", FLAG_FAILED)

    def exchange_abandoned(self, session: ControllerSession, request: Request) -> None:
        self.abandoned.append((session, request))


def _session(backend: Backend, name: str) -> tuple[ControllerSession, list[int]]:
    session = ControllerSession(backend, name=name)
    woken: list[int] = []
    session.on_ready = lambda: woken.append(1)
    return session, woken


# -- begin_upload(session, command) ------------------------------------------------------------
def test_begin_upload_is_told_which_of_the_backends_sessions_uploads() -> None:
    backend = Keeper()
    a, _ = _session(backend, "a")
    b, _ = _session(backend, "b")
    backend.uploader = a
    b.feed(_request(FB), 0.0)
    a.feed(_request(FB), 0.0)
    assert [(session.name, command.file) for session, command in backend.uploads] == [
        ("b", FB.file),
        ("a", FB.file),
    ]
    # b is refused before its lines, with the backend's reason for KD; a may send its lines
    assert b.output(0.0) == encode_packet(FB.error_answer(FLAG_FAILED))
    assert b.last_error == "only a uploads here"
    assert b.current is None
    assert a.output(0.0) == encode_packet(FB.ok())
    assert a.last_error == ""


# -- Request.abort(reason) ---------------------------------------------------------------------
def test_abort_ends_the_exchange_with_rst_at_once_and_kd_says_why() -> None:
    backend = Keeper()
    session, woken = _session(backend, "h1")
    session.feed(_request(SetSpeed(1, 5)), 0.0)
    assert session.output(0.0) == b""
    (request,) = backend.requests
    request.abort("the outcome is unknown")
    assert woken  # the host is asked for a turn now, not at the host's next input
    assert session.output(0.1) == RST_B
    assert not request.live
    assert session.current is None  # dropped, as any exchange the link gave up
    assert session.last_error == "the outcome is unknown"  # not the link's "aborted" text
    # the session goes on: the host's next request is handed over as ever
    session.feed(_request(ReadStatus()), 0.2)
    assert len(backend.requests) == 2 and backend.requests[1].live


def test_abort_in_the_backends_own_call_goes_out_with_the_same_turn() -> None:
    class Aborts(Backend):
        def handle(self, request: Request) -> None:
            request.abort("cannot say")

    session, _ = _session(Aborts(), "h1")
    session.feed(_request(SetSpeed(1, 5)), 0.0)
    assert session.output(0.0) == RST_B
    assert session.last_error == "cannot say"


def test_abort_sends_nothing_once_the_exchange_is_over() -> None:
    backend = Keeper()
    session, _ = _session(backend, "h1")
    session.feed(_request(SetSpeed(1, 5)), 0.0)
    first = backend.requests[0]
    session.feed(RST_B, 0.1)  # the host gives up...
    first.answer()  # ...and the answer that follows is not sent: the exchange ends
    assert session.output(0.2) == b""
    first.abort("too late")
    assert session.output(0.3) == b""
    assert session.last_error != "too late"


# -- exchange_abandoned(session, request) -----------------------------------------------------
def test_the_backend_hears_at_once_once_that_the_host_gave_the_exchange_up() -> None:
    backend = Keeper()
    session, _ = _session(backend, "h1")
    session.feed(_request(SetSpeed(1, 5)), 0.0)
    (request,) = backend.requests
    session.feed(ACK_B + NAK_B, 0.1)  # noise: the host still waits
    assert backend.abandoned == []
    session.feed(RST_B, 0.2)
    assert backend.abandoned == [(session, request)]  # at once, before the backend answers
    assert request.live  # still the backend's to answer: that ends the exchange
    session.feed(_request(ReadStatus()), 0.3)
    assert backend.abandoned == [(session, request)]  # once
    assert len(backend.requests) == 1  # the next request waits for the answer
    request.answer()
    assert session.output(0.4) == b""  # not sent: the host moved on
    assert len(backend.requests) == 2  # the held request is taken next
    assert isinstance(backend.requests[1].command, ReadStatus)


def test_a_new_request_is_the_host_giving_the_exchange_up_too() -> None:
    backend = Keeper()
    session, _ = _session(backend, "h1")
    session.feed(_request(SetSpeed(1, 5)), 0.0)
    session.feed(_request(SetSpeed(1, 6)), 0.1)
    assert backend.abandoned == [(session, backend.requests[0])]
    # the superseding request's own turn is told anew
    backend.requests[0].answer()
    session.output(0.2)
    second = backend.requests[1]
    session.feed(RST_B, 0.3)
    assert backend.abandoned[1:] == [(session, second)]


def test_input_in_the_same_read_as_the_request_is_told_at_once_too() -> None:
    # A host that sends its RST (or its next request) right behind its request gave the
    # exchange up as much as one whose RST comes later: the backend hears it at once (the line
    # server then never runs a write nobody waits for).
    backend = Keeper()
    session, _ = _session(backend, "h1")
    session.feed(_request(SetSpeed(1, 5)) + RST_B, 0.0)
    assert backend.abandoned == [(session, backend.requests[0])]
    backend.requests[0].answer()
    assert session.output(0.1) == b""  # the held RST still cancels the answer
