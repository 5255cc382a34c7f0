"""Programs under change control see every file written through the server, not only by the
dashboard: an N1 host program's upload is kept as a version under who wrote it; another face's
download adds none (it reads the controller's file as it is, so an edit made at the pendant stays
flagged by the check); the dashboard's own transfers keep how they came."""

from __future__ import annotations

import httpx
from web_harness import Stack, login

from robostar.commands.files import DownloadFile, UploadFile
from robostar.protocol.fields import FileName
from robostar.serve.lease import Who
from robostar.sim.filesystem import StoredJob
from robostar.types import CoordSystem

HOST = Who("press-host", "n1")
MES = Who("mes", "api")


def test_other_faces_transfers_are_kept_as_versions(stack: Stack) -> None:
    line = stack.line
    store = stack.face.app.state.deps.store
    lines = ("MAIN", "MOVJ P0001", "DELAY 20", "EOP")

    stack.call(line.execute(UploadFile(1, "HOST.JOB", 43, lines), who=HOST, implicit_lease=True))
    (kept,) = store.versions("cell1", 1, "HOST.JOB")
    assert (kept.who, kept.face, kept.how) == ("press-host", "n1", "upload")
    assert store.text(kept.hash) == "MAIN\nMOVJ P0001\nDELAY 20\nEOP\n"

    # changed at the pendant, then read by another face: no version (the check must still see it)
    edited = StoredJob(FileName.parse("HOST.JOB"), 43, ["MAIN", "MOVJ P0001", "DELAY 99", "EOP"])
    stack.in_sim(lambda c: c.model.channels[0].files.put(edited))
    stack.call(line.read(DownloadFile(1, "HOST.JOB", CoordSystem.ANGLE), who=MES))
    assert store.versions("cell1", 1, "HOST.JOB") == [kept]


def test_the_dashboards_own_upload_is_kept_once_as_the_dashboards(stack: Stack) -> None:
    store = stack.face.app.state.deps.store
    with httpx.Client(base_url=stack.url, timeout=30.0) as http:
        token = login(http, "erin")
        form = {"csrf_token": token, "channel": "1", "name": "WEBU.JOB", "job_number": "45"}
        answer = http.post(
            "/line/cell1/files/upload/confirm",
            data={**form, "content": "MAIN\nDELAY 5\nEOP\n", "confirmed": "yes"},
            follow_redirects=False,
        )
        assert answer.status_code == 303, answer.text
    (kept,) = store.versions("cell1", 1, "WEBU.JOB")
    assert (kept.who, kept.face) == ("erin", "web")
