"""New N1 hosts connecting while another host polls (figures, never asserted):
``python -m bench.n1_connect``.

Each local host that connects to the line server's N1 face is named by the user and process
holding its socket (a read of ``/proc/net/tcp`` and of the processes' descriptors). That lookup
runs in a worker thread of its own, one lookup after the other; this bench shows what it would
cost the event loop otherwise and what the loop sees now:

1. The lookup itself (``find_owner`` for a connected loopback peer), p50 and max: how long
   every line and face of the server stood still per connecting host when it ran on the loop.
2. 16 hosts connecting at once (each looked up, the rate limit aside) while one host polls AA
   through the same face: the loop's largest lag (a 1 ms timer's lateness) and the polling
   host's AA latency, p50/p99/max, against the same host polling with nobody connecting, and
   with the lookups run on the loop as they were before.
"""

from __future__ import annotations

import asyncio
import socket
import time

from bench.measure import percentile
from robostar import AsyncClient
from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.faces.n1 import host as n1_host
from robostar.serve.faces.n1 import peer_owner

HOSTS = 16
LOOKUPS = 50


def lookup_cost() -> list[float]:
    """Seconds each ``find_owner`` takes for a peer connected on this machine."""
    seconds = []
    with socket.create_server(("127.0.0.1", 0)) as server:
        for _ in range(LOOKUPS):
            client = socket.create_connection(server.getsockname()[:2])
            accepted, peer = server.accept()
            with client, accepted:
                start = time.perf_counter()
                peer_owner.find_owner(peer[0], peer[1])
                seconds.append(time.perf_counter() - start)
    return seconds


async def _lag(stop: asyncio.Event, lags: list[float]) -> None:
    """How late a 1 ms timer fires, again and again, until ``stop``."""
    loop = asyncio.get_running_loop()
    while not stop.is_set():
        asked = loop.time() + 0.001
        await asyncio.sleep(0.001)
        lags.append(loop.time() - asked)


async def _poll(client: AsyncClient, stop: asyncio.Event, out: list[float]) -> None:
    while not stop.is_set():
        start = time.perf_counter()
        await client.status()
        out.append(time.perf_counter() - start)


def _connect_all(address: tuple[str, int]) -> list[socket.socket]:
    """``HOSTS`` connections at once, from a thread (not the server's loop)."""
    return [socket.create_connection(address) for _ in range(HOSTS)]


def _on_the_loop(address: object, *, common_name: str | None = None) -> tuple[str, int] | None:
    """The lookup as it was before: done at once, by the caller (the loop), no thread."""
    due = peer_owner.lookup_due(address, common_name=common_name)
    if due is not None:
        peer_owner.find_owner(*due)
    return None


async def burst() -> dict[str, list[float]]:
    line = LineConfig("cell", "sim://", poll_interval=0.05)
    config = ServeConfig(
        lines=(line,), faces={"n1": {"lines": {"cell": "127.0.0.1:0"}, "max_clients": 2 * HOSTS}}
    )
    out: dict[str, list[float]] = {}
    async with LineServer(config) as server:
        face = server.faces["n1"]
        address = face.addresses["cell"]  # type: ignore[attr-defined]
        host = face.hosts["cell"]  # type: ignore[attr-defined]
        async with AsyncClient(f"tcp://{address[0]}:{address[1]}") as client:
            for label in ("quiet", "in a thread", "on the loop"):
                stop = asyncio.Event()
                lags: list[float] = []
                reads: list[float] = []
                tasks = [
                    asyncio.create_task(_lag(stop, lags)),
                    asyncio.create_task(_poll(client, stop, reads)),
                ]
                await asyncio.sleep(0.2)
                sockets: list[socket.socket] = []
                if label != "quiet":
                    # every one of them looked up: the rate limit is lifted for the bench
                    peer_owner._lookups = type(peer_owner._lookups)(maxlen=HOSTS)
                    real = peer_owner.lookup_due
                    n1_host.lookup_due = _on_the_loop if label == "on the loop" else real  # type: ignore[assignment]
                    sockets = await asyncio.to_thread(_connect_all, address)
                    while host.clients < HOSTS + 1 or any(c.peer is None for c in host.connections):
                        await asyncio.sleep(0.005)
                await asyncio.sleep(0.2)
                stop.set()
                await asyncio.gather(*tasks)
                n1_host.lookup_due = peer_owner.lookup_due
                for sock in sockets:
                    sock.close()
                while host.clients > 1:
                    await asyncio.sleep(0.005)
                out[f"{label} lag"] = lags
                out[f"{label} AA"] = reads
    return out


def main() -> None:
    cost = lookup_cost()
    print("1. find_owner for a local peer (what each connecting host cost the loop before)")
    print(
        f"  p50 {percentile(cost, 50) * 1e3:7.2f} ms   max {max(cost) * 1e3:7.2f} ms"
        f"   ({LOOKUPS} lookups)"
    )
    figures = asyncio.run(burst())
    print(f"2. {HOSTS} hosts connecting at once while one host polls AA, by where lookups run")
    for label in ("quiet", "in a thread", "on the loop"):
        lag = figures[f"{label} lag"]
        reads = figures[f"{label} AA"]
        print(
            f"  {label:<12} loop lag max {max(lag) * 1e3:6.2f} ms"
            f"   AA p50 {percentile(reads, 50) * 1e3:6.2f} ms"
            f"  p99 {percentile(reads, 99) * 1e3:6.2f} ms  max {max(reads) * 1e3:6.2f} ms"
            f"  ({len(reads)} reads)"
        )


if __name__ == "__main__":
    main()
