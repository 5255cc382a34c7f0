"""An N1 upload (FB) is refused at once, before its lines, when another consumer holds the lease,
another N1 session included; the session that holds the lease uploads as before."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from robostar.client.aio import AsyncClient
from robostar.commands.control import SetSpeed
from robostar.commands.files import UploadFile
from robostar.errors import ControlHeldError
from robostar.serve import LineConfig, LineServer, ServeConfig

BODY = ["MAIN", *[f"MOVJ P{i % 100 + 1:04d} V=50" for i in range(198)], "EOP"]


def test_an_upload_from_an_n1_session_without_the_lease_is_refused_before_its_lines(
    tmp_path: Path,
) -> None:
    path = tmp_path / "audit.jsonl"

    async def main() -> tuple[list[int], list[int]]:
        config = ServeConfig(
            lines=(LineConfig("cell1", "sim://", poll_interval=0.5),),
            faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
            audit_path=str(path),
        )
        async with LineServer(config) as server:
            host, port = server.faces["n1"].addresses["cell1"]
            url = f"tcp://{host}:{port}"
            async with AsyncClient(url) as a, AsyncClient(url) as b:
                await a.execute(SetSpeed(1, 50))  # host A takes the lease
                b_sent: list[int] = []
                with pytest.raises(ControlHeldError, match="control of line cell1 is held by n1:"):
                    await b._call(UploadFile(1, "B.JOB", 2, BODY), lambda n, t: b_sent.append(n))
                a_sent: list[int] = []
                await a._call(UploadFile(1, "A.JOB", 3, BODY), lambda n, t: a_sent.append(n))
                return b_sent, a_sent

    b_sent, a_sent = asyncio.run(main())
    assert max(b_sent or [0]) == 0  # not one line crossed the wire
    assert max(a_sent) == len(BODY)  # the holder's own upload goes through
    entries = [json.loads(raw) for raw in path.read_text().splitlines()]
    refused = [e for e in entries if "UploadFile" in e["what"] and "file=B.JOB" in e["what"]]
    assert len(refused) == 1 and refused[0]["outcome"].startswith("refused: ")
