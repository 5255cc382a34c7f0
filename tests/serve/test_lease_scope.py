"""A line's lease scope: by default every state change needs the lease, so a second N1 host's
global writes are refused while a first host holds control; with ``shared = ["globals"]`` both
hosts write globals side by side, every write carried out in each host's order, while what
stays exclusive (speed here) is still refused; the setting is read from the config and checked."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from robostar.client.aio import AsyncClient
from robostar.commands.control import SetSpeed
from robostar.commands.variables import ReadGlobalInt, WriteGlobalInt
from robostar.errors import ControlHeldError
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.config import ConfigError, config_from_mapping

WRITES = 20


def _config(audit: Path, shared: frozenset[str]) -> ServeConfig:
    return ServeConfig(
        lines=(LineConfig("cell1", "sim://", poll_interval=0.5, shared=shared),),
        faces={"n1": {"lines": {"cell1": "127.0.0.1:0"}}},
        audit_path=str(audit),
    )


Outcome = tuple[list[str], list[str], int, int, dict[int, list[int]]]


async def _two_hosts(config: ServeConfig) -> Outcome:
    """Host A holds control (a speed write), then A and B each write their own global
    ``WRITES`` times side by side: the outcomes of A's and B's writes, the globals read back,
    and the values each global was written on the wire, in the order they went out."""
    async with LineServer(config) as server:
        wire: dict[int, list[int]] = {11: [], 12: []}

        def carried_out(command: object, result: object, who: object) -> None:
            if isinstance(command, WriteGlobalInt) and not isinstance(result, BaseException):
                wire[command.index].append(command.value)

        server.lines["cell1"].on_exchange(carried_out)
        host, port = server.faces["n1"].addresses["cell1"]
        url = f"tcp://{host}:{port}"
        async with AsyncClient(url) as a, AsyncClient(url) as b:
            await a.execute(SetSpeed(1, 40))  # A: the cell's host program, holding control

            async def writes(client: AsyncClient, index: int) -> list[str]:
                outcomes = []
                for value in range(WRITES):
                    try:
                        await client.execute(WriteGlobalInt(index, value))
                        outcomes.append("ok")
                    except ControlHeldError:
                        outcomes.append("refused")
                return outcomes

            a_out, b_out = await asyncio.gather(writes(a, 11), writes(b, 12))
            with pytest.raises(ControlHeldError):
                await b.execute(SetSpeed(1, 90))  # speed stays exclusive either way
            return (
                a_out,
                b_out,
                await a.execute(ReadGlobalInt(11)),
                await b.execute(ReadGlobalInt(12)),
                wire,
            )


def _refused(audit: Path) -> int:
    entries = [json.loads(raw) for raw in audit.read_text().splitlines()]
    return sum(1 for e in entries if e["outcome"].startswith("refused: "))


def test_two_hosts_write_globals_side_by_side_when_the_line_shares_them(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    shared = frozenset({"globals"})
    a_out, b_out, a_last, b_last, wire = asyncio.run(_two_hosts(_config(audit, shared)))
    assert a_out == ["ok"] * WRITES and b_out == ["ok"] * WRITES
    assert (a_last, b_last) == (WRITES - 1, WRITES - 1)
    assert wire == {11: list(range(WRITES)), 12: list(range(WRITES))}  # each in its order
    assert _refused(audit) == 1  # B's speed write only


def test_by_default_a_second_hosts_global_writes_are_refused(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    a_out, b_out, a_last, _, wire = asyncio.run(_two_hosts(_config(audit, frozenset())))
    assert a_out == ["ok"] * WRITES
    assert b_out == ["refused"] * WRITES
    assert a_last == WRITES - 1 and wire == {11: list(range(WRITES)), 12: []}
    assert _refused(audit) == WRITES + 1  # each refusal audited


def test_the_shared_scope_is_read_from_the_config_and_checked() -> None:
    line = {"url": "sim://", "shared": ["globals"]}
    config = config_from_mapping({"lines": {"cell1": line}})
    assert config.lines[0].shared == frozenset({"globals"})
    assert config_from_mapping({"lines": {"cell1": {"url": "sim://"}}}).lines[0].shared == set()
    with pytest.raises(ConfigError, match=r"lines\.cell1\.shared: 'motion' cannot be shared"):
        config_from_mapping({"lines": {"cell1": {"url": "sim://", "shared": ["motion"]}}})
