"""The nodeset cache and the browse memo rely only on what asyncua offers publicly, and where
they rely on more (the memo overrides a private method) a test says so loudly: an asyncua
upgrade must not break startup, or slow browsing, without a failing test."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from asyncua import ua
from asyncua.server.address_space import NodeData, ViewService

from robostar.serve.faces.opcua.nodesets import CachedInternalServer

from .conftest import Model, Setup, connect, serving

pytestmark = pytest.mark.timeout(120)


class PublicOnlySpace:
    """An address space with only asyncua's public mapping methods: no private dict."""

    def __init__(self) -> None:
        self.entries: dict[ua.NodeId, NodeData] = {}

    def keys(self) -> Iterator[ua.NodeId]:
        return iter(list(self.entries))

    def __getitem__(self, nodeid: ua.NodeId) -> NodeData:
        return self.entries[nodeid]

    def __setitem__(self, nodeid: ua.NodeId, data: NodeData) -> None:
        self.entries[nodeid] = data

    def __contains__(self, nodeid: object) -> bool:
        return nodeid in self.entries

    def clear(self) -> None:
        self.entries.clear()


def _server(cache: Path) -> Any:
    server = CachedInternalServer(cache)
    server.aspace = PublicOnlySpace()  # type: ignore[assignment]
    return server


def test_the_cache_is_written_and_read_through_the_public_mapping(tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    first = _server(cache)
    node = NodeData(ua.NodeId("a", 1))
    ref = ua.ReferenceDescription()
    ref.NodeId = ua.NodeId("b", 1)
    node.references = [ref, ref]  # a reference repeated, as asyncua's init leaves some
    first.aspace[node.nodeid] = node
    first._write_cache(first.cache_file, ["http://opcfoundation.org/UA/", "urn:x"])

    second = _server(cache)
    asyncio.run(second.load_standard_address_space())
    assert list(second.aspace.keys()) == [ua.NodeId("a", 1)]
    assert second._cached_namespaces == ["http://opcfoundation.org/UA/", "urn:x"]
    second._drop_repeated_references()
    assert len(second.aspace[ua.NodeId("a", 1)].references) == 1


def test_the_browse_memo_overrides_a_method_asyncua_still_has(opcua_setup: Setup) -> None:
    # MemoViewService overrides asyncua's private ViewService._suitable_reftype; should a
    # release rename it, the memo would silently do nothing and every browse be slow again
    assert callable(getattr(ViewService, "_suitable_reftype", None))

    async def main() -> None:
        async with serving(opcua_setup) as server, connect(server, opcua_setup) as client:
            await Model(client).axis_position(1, 1)
            face: Any = server.faces["opcua"]
            assert face.ua.iserver.view_service._subtypes  # the memo answered the browses

    asyncio.run(main())
