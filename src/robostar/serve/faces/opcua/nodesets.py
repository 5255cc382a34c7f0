"""The OPC Foundation's companion nodesets (DI, IA, Robotics), imported once and then cached.

A cold start fills asyncua's standard address space (about 1 s of Python) and imports the three
NodeSet2 files (about 0.6 s more). Both steps give the same nodes every time for the same files
and asyncua version, so the result is pickled to a cache file and a restart loads that instead
(about 0.3 s). The cache is keyed by a hash of the files, asyncua's version and Python's, so
a change of any of them rebuilds it; a cache that cannot be read is rebuilt, never trusted.

Why pickle and not asyncua's own shelf: the shelf keeps only the standard nodes and is slower to
load than the import it would save. The pickle is loaded with the garbage collector paused:
with it running, loading seven thousand nodes' object graphs takes ten times as long.
"""

from __future__ import annotations

import contextlib
import gc
import hashlib
import importlib.metadata
import logging
import os
import pickle
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from asyncua import ua
from asyncua.server.address_space import AddressSpace, NodeData, ViewService
from asyncua.server.internal_server import InternalServer
from asyncua.server.server import Server

from robostar.serve.faces.opcua._ua import ObjectIds, node_id

__all__ = [
    "NODESETS",
    "NODESET_DIR",
    "CachedInternalServer",
    "LoadReport",
    "MemoViewService",
    "cache_key",
]

log = logging.getLogger("robostar.serve.opcua")

NODESET_DIR = Path(__file__).with_name("nodesets")
NODESETS = ("Opc.Ua.Di.NodeSet2.xml", "Opc.Ua.IA.NodeSet2.xml", "Opc.Ua.Robotics.NodeSet2.xml")
"""In dependency order: IA needs DI, Robotics needs both."""


def cache_key() -> str:
    """What the cached address space depends on: the nodeset files, asyncua and Python."""
    digest = hashlib.sha256()
    digest.update(importlib.metadata.version("asyncua").encode())
    digest.update(sys.version.encode())
    for name in NODESETS:
        digest.update((NODESET_DIR / name).read_bytes())
    return digest.hexdigest()[:16]


@dataclass
class LoadReport:
    """How the address space was made this time (the startup benchmark reads it)."""

    cached: bool = False
    seconds: float = 0.0
    cache_file: Path | None = None


@contextlib.contextmanager
def _gc_paused() -> Iterator[None]:
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _private(path: Path) -> bool:
    """Whether ``path`` and its directory belong to this process's user and nobody else may
    write them: a pickle is code, and only such a file is loaded."""
    uid = getattr(os, "geteuid", lambda: None)()
    for each in {path, path.parent}:
        info = each.stat()
        if (uid is not None and info.st_uid != uid) or info.st_mode & 0o022:
            return False
    return True


def _nodes_of(aspace: AddressSpace) -> dict[ua.NodeId, NodeData]:
    """The address space's nodes, through its public mapping methods (``keys`` and item
    access), never its private dictionary: an asyncua release that renames that cannot break
    the cache."""
    # AddressSpace has keys() but no __iter__
    return {nodeid: aspace[nodeid] for nodeid in aspace.keys()}  # noqa: SIM118


def _fill(aspace: AddressSpace, nodes: dict[ua.NodeId, NodeData]) -> None:
    """Replace everything in ``aspace`` with ``nodes`` (its public ``clear`` and item
    assignment)."""
    aspace.clear()
    for nodeid, data in nodes.items():
        aspace[nodeid] = data


class MemoViewService(ViewService):
    """asyncua's browse service, remembering which reference types are subtypes of which.

    asyncua walks the reference type tree again for each reference of each node it browses;
    with the companion nodesets that is two thirds of the time spent making a line's nodes
    (4 of 6 s for 8 lines). The tree does not change once the nodesets are in, so the answers
    are kept from then on (:meth:`freeze`); before, nothing is kept.
    """

    def __init__(self, aspace: Any) -> None:
        super().__init__(aspace)
        self._subtypes: dict[tuple[ua.NodeId, ua.NodeId, bool], bool] | None = None

    def freeze(self) -> None:
        """The reference types are all known: remember the answers from now on."""
        self._subtypes = {}

    def _suitable_reftype(self, ref1: ua.NodeId, ref2: ua.NodeId, subtypes: bool) -> bool:
        memo = self._subtypes
        if memo is None:
            return super()._suitable_reftype(ref1, ref2, subtypes)
        key = (ref1, ref2, subtypes)
        answer = memo.get(key)
        if answer is None:
            answer = memo[key] = super()._suitable_reftype(ref1, ref2, subtypes)
        return answer


class CachedInternalServer(InternalServer):
    """asyncua's InternalServer whose address space comes from the cache when there is one.

    asyncua's ``Server.init()`` fills the standard nodes, fixes a few references and sets the
    server's own nodes; the nodesets can only be imported after that (the importer reads the
    namespace array those steps write). So the cache holds the space as it is after a whole
    cold start; a warm ``init()`` loads it in place of the standard nodes, asyncua's steps run
    on it again (harmless, except that they reset the namespace array and repeat two
    references), and :meth:`load_nodesets` then restores the array and drops the repeats.
    """

    def __init__(self, cache_dir: Path | None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.view_service: MemoViewService = MemoViewService(self.aspace)
        self.cache_dir = cache_dir
        self.cache_file = (
            None if cache_dir is None else cache_dir / f"address-space-{cache_key()}.pickle"
        )
        """Where the address space is cached (its name hashes the nodesets: read them once)."""
        self._cached_namespaces: list[str] | None = None

    async def load_standard_address_space(self, shelf_file: Path | None = None) -> None:
        cache = self.cache_file
        if cache is not None:
            cached = self._read_cache(cache)
            if cached is not None:
                nodes, self._cached_namespaces = cached
                _fill(self.aspace, nodes)
                return
        with _gc_paused():
            await super().load_standard_address_space(None)

    async def load_nodesets(self, server: Server) -> LoadReport:
        """Import DI, IA and Robotics into ``server`` (whose inside this is), or finish the
        load from the cache; call right after ``server.init()``. The caller times the whole
        (asyncua's init included) into the report's ``seconds``."""
        cache = self.cache_file
        namespace_node = server.get_node(node_id(ObjectIds.Server_NamespaceArray))
        if self._cached_namespaces is not None:
            current = await namespace_node.read_value()
            restored = list(self._cached_namespaces)
            restored[: len(current)] = current  # index 1 is this server's application URI
            await namespace_node.write_value(restored)
            self._drop_repeated_references()
            self.view_service.freeze()
            return LoadReport(True, 0.0, cache)
        importer_log = logging.getLogger("asyncua.common.xmlimporter")
        level = importer_log.level
        # the importer warns about each of the DI file's known oddities; they are expected
        importer_log.setLevel(logging.ERROR)
        with _gc_paused():
            for name in NODESETS:
                # strict mode off: DI 1.05 names a parent asyncua's strict import refuses
                # (BadParentNodeIdInvalid), although the node itself is sound
                await server.import_xml(str(NODESET_DIR / name), strict_mode=False)
        importer_log.setLevel(level)
        self.view_service.freeze()
        if cache is not None:
            self._write_cache(cache, list(await namespace_node.read_value()))
        return LoadReport(False, 0.0, cache)

    def _drop_repeated_references(self) -> None:
        for data in _nodes_of(self.aspace).values():
            seen: set[tuple[Any, ...]] = set()
            kept = []
            for ref in data.references:
                key = (ref.ReferenceTypeId, ref.NodeId, ref.IsForward)
                if key not in seen:
                    seen.add(key)
                    kept.append(ref)
            if len(kept) != len(data.references):
                data.references = kept

    def _read_cache(self, path: Path) -> tuple[dict[Any, Any], list[str]] | None:
        if not path.exists():
            return None
        if not _private(path):
            log.warning(
                "opcua: %s or its directory is not this user's alone; not loaded (rebuilt in"
                " memory at every start until cache_dir is private)",
                path,
            )
            return None
        try:
            with path.open("rb") as handle, _gc_paused():
                nodes, namespaces = pickle.load(handle)
        except FileNotFoundError:
            return None
        except Exception as exc:  # a truncated or foreign file: rebuild it
            log.warning("opcua: address space cache %s unreadable (%s); rebuilding", path, exc)
            return None
        if not isinstance(nodes, dict) or not isinstance(namespaces, list):
            return None
        return nodes, namespaces

    def _write_cache(self, path: Path, namespaces: list[str]) -> None:
        nodes = _nodes_of(self.aspace)
        # method callbacks cannot be pickled (and are bound again at every start)
        calls = {nodeid: data.call for nodeid, data in nodes.items() if data.call is not None}
        for nodeid in calls:
            nodes[nodeid].call = None
        try:
            path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
            if not _private(path.parent):
                log.warning("opcua: %s is not this user's alone; no cache written", path.parent)
                return
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".aspace-", suffix=".tmp")
            try:
                with os.fdopen(fd, "wb") as handle, _gc_paused():
                    pickle.dump((nodes, namespaces), handle, pickle.HIGHEST_PROTOCOL)
                os.replace(tmp, path)  # whole or not at all: a crash never leaves half a cache
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
        except OSError as exc:
            log.warning("opcua: cannot write the address space cache %s: %s", path, exc)
        finally:
            for nodeid, call in calls.items():
                nodes[nodeid].call = call
