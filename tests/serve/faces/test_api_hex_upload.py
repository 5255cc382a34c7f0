"""{"hex": ...} over the API is one request packet; FB's is only the upload's header (its lines
follow in packets of their own), so it must be refused, not carried out as an empty upload."""

from __future__ import annotations

import asyncio

import httpx

from robostar.commands.files import DownloadFile, UploadFile
from robostar.serve import LineConfig, LineServer, ServeConfig, Who
from robostar.types import CoordSystem, JobFile

JOB = ["MAIN", "MOVJ P0001 V=50", "MOVJ P0002 V=50", "EOP"]


def test_hex_fb_is_refused_naming_the_command_form_and_the_file_is_kept() -> None:
    config = ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
        faces={"api": {"listen": "127.0.0.1:0"}},
    )

    async def main() -> tuple[httpx.Response, JobFile, httpx.Response]:
        async with LineServer(config) as server:
            line = server.lines["cell1"]
            erin = Who("erin", "api")
            await line.execute(UploadFile(1, "WELD.JOB", 1, JOB), who=erin, implicit_lease=True)
            host, port = server.faces["api"].address  # type: ignore[attr-defined]
            url = f"http://{host}:{port}/lines/cell1/commands"
            packet = UploadFile(1, "WELD.JOB", 1, JOB).encode().hex()  # as an N1 host sends it
            headers = {"x-robostar-who": "erin"}
            async with httpx.AsyncClient(timeout=10) as http:
                refused = await http.post(
                    url, headers=headers, json={"hex": packet, "implicit_lease": True}
                )
                # the form the message names carries the lines, and works
                form = {
                    "command": "UploadFile",
                    "args": {"channel": 1, "file": "OTHER.JOB", "job_number": 2, "lines": JOB},
                    "implicit_lease": True,
                }
                carried = await http.post(url, headers=headers, json=form)
            after = await line.read(DownloadFile(1, "WELD.JOB", CoordSystem.ANGLE), max_age=0)
            assert isinstance(after, JobFile)
            return refused, after, carried

    refused, after, carried = asyncio.run(main())
    assert refused.status_code == 400, refused.text
    assert '{"command": "UploadFile"' in refused.json()["message"]
    assert '"lines": [...]' in refused.json()["message"]
    assert list(after.lines) == JOB  # the job is not wiped
    assert carried.status_code == 200, carried.text
