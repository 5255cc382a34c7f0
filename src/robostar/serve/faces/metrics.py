"""The metrics face: a Prometheus text endpoint (``GET /metrics``) with per-line figures.

With a token configured (required beyond loopback) a scrape must send it as
``Authorization: Bearer TOKEN`` (Prometheus: ``authorization: {credentials: TOKEN}``).

The ``Host`` header must name the endpoint, by the same rule as the API and the dashboard
(:class:`robostar.serve.http_guard.HostRule`: the listen address, the loopback names on a loopback
address, any IP address on a wildcard one, and the names in the ``hosts`` option); anything else
gets a 400 before the token is looked at. Without it a web page on a name that resolves to
127.0.0.1 (DNS rebinding) could read the figures from a browser on this machine.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import logging
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from robostar.errors import UsageError
from robostar.listen import check_host, parse_listen, warn_remote
from robostar.serve.http_guard import HostRule, hosts_option

if TYPE_CHECKING:
    from robostar.serve.line_server import LineServer

__all__ = ["HealthCollector", "MetricsFace", "create", "registry_for"]

log = logging.getLogger("robostar.serve.metrics")


class HealthCollector(Collector):
    """Reads every line's health at scrape time (nothing to update on the hot path)."""

    def __init__(self, server: LineServer) -> None:
        self.server = server

    def collect(self) -> Iterator[Metric]:
        up = GaugeMetricFamily("robostar_line_up", "1 when the line is open", labels=["line"])
        exchanges = CounterMetricFamily(
            "robostar_line_exchanges", "Exchanges run on the line", labels=["line"]
        )
        errors = CounterMetricFamily(
            "robostar_line_errors", "Exchanges that ended in an error", labels=["line"]
        )
        reconnects = CounterMetricFamily(
            "robostar_line_reconnects", "Times the line was reopened", labels=["line"]
        )
        latency = GaugeMetricFamily(
            "robostar_line_latency_seconds", "Duration of the last exchange", labels=["line"]
        )
        p99 = GaugeMetricFamily(
            "robostar_line_latency_p99_seconds",
            "99th percentile of recent exchanges",
            labels=["line"],
        )
        depth = GaugeMetricFamily(
            "robostar_line_queue_depth", "Requests queued or running", labels=["line"]
        )
        age = GaugeMetricFamily(
            "robostar_line_poll_age_seconds", "Time since the last complete poll", labels=["line"]
        )
        updates = CounterMetricFamily(
            "robostar_model_updates", "Values stored in the model", labels=["line"]
        )
        subscribers = GaugeMetricFamily(
            "robostar_model_subscribers", "Subscriptions to the model", labels=["line"]
        )
        for name, line in self.server.lines.items():
            health = line.health
            up.add_metric([name], 1.0 if line.up else 0.0)
            exchanges.add_metric([name], health.exchanges)
            errors.add_metric([name], health.errors)
            reconnects.add_metric([name], health.reconnects)
            depth.add_metric([name], line.queue_depth)
            updates.add_metric([name], line.model.updates)
            subscribers.add_metric([name], line.model.subscribers)
            if health.latency is not None:
                latency.add_metric([name], health.latency)
            if health.latencies:
                ordered = sorted(health.latencies)
                p99.add_metric([name], ordered[min(len(ordered) - 1, int(len(ordered) * 0.99))])
            if health.poll_age is not None:
                age.add_metric([name], health.poll_age)
        yield from (
            up,
            exchanges,
            errors,
            reconnects,
            latency,
            p99,
            depth,
            age,
            updates,
            subscribers,
        )


def registry_for(server: LineServer) -> CollectorRegistry:
    registry = CollectorRegistry()
    registry.register(HealthCollector(server))
    return registry


class MetricsFace:
    """A minimal asyncio HTTP server answering ``GET /metrics`` (and 404 for anything else)."""

    def __init__(
        self,
        server: LineServer,
        listen: tuple[str, int],
        allow_remote: bool,
        token: str | None = None,
        *,
        hosts: tuple[str, ...] = (),
    ) -> None:
        if allow_remote and not token:
            raise UsageError("metrics: allow_remote needs a token")
        self.registry = registry_for(server)
        self.listen = listen
        self.host_rule = HostRule(listen[0], hosts)
        self.allow_remote = allow_remote
        self._authorization = None if token is None else f"Bearer {token}".encode()
        self.address: tuple[str, int] | None = None
        self._server: asyncio.Server | None = None

    async def start(self) -> None:
        host, port = self.listen
        check_host(host, self.allow_remote)
        self._server = await asyncio.start_server(self._handle, host, port)
        bound = self._server.sockets[0].getsockname()
        self.address = (str(bound[0]), int(bound[1]))
        warn_remote(host, self.address[1], "the metrics endpoint")
        log.info("metrics on http://%s:%d/metrics", *self.address)

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            request = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 5.0)
            target = request.split(b" ", 2)[1] if request.count(b" ") >= 2 else b""
            hosts = _headers(request, b"host")
            if len(hosts) != 1 or not self.host_rule.allows(hosts[0].decode("latin-1")):
                # checked first, as the other HTTP faces' HostGuard does: a rebinding page
                # learns nothing, not even whether a token is wanted (two Host headers: RFC 9112)
                shown = (hosts[0].decode("latin-1") if hosts else "")[:100]
                body = f"this server does not answer to the host {shown!r}\n".encode()
                head = b"HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain; charset=utf-8\r\n"
            elif not self._authorized(request):
                body = b"a token is needed: Authorization: Bearer TOKEN\n"
                head = (
                    b"HTTP/1.1 401 Unauthorized\r\nContent-Type: text/plain\r\n"
                    b'WWW-Authenticate: Bearer realm="robostar"\r\n'
                )
            elif request.startswith(b"GET ") and target.split(b"?")[0] == b"/metrics":
                body = generate_latest(self.registry)
                head = b"HTTP/1.1 200 OK\r\nContent-Type: text/plain; version=0.0.4\r\n"
            else:
                body = b"not found\n"
                head = b"HTTP/1.1 404 Not Found\r\nContent-Type: text/plain\r\n"
            writer.write(
                head + b"Content-Length: %d\r\nConnection: close\r\n\r\n" % len(body) + body
            )
            await writer.drain()
        except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, TimeoutError, OSError):
            pass
        finally:
            writer.close()
            with contextlib.suppress(OSError):
                await writer.wait_closed()

    def _authorized(self, request: bytes) -> bool:
        if self._authorization is None:
            return True
        values = _headers(request, b"authorization")
        return bool(values) and hmac.compare_digest(values[0], self._authorization)

    async def stop(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            server.close()
            await server.wait_closed()


def _headers(request: bytes, name: bytes) -> list[bytes]:
    """The values of every header ``name`` (lower case) in a request's head, stripped."""
    values = []
    for line in request.split(b"\r\n")[1:]:
        key, _, value = line.partition(b":")
        if key.strip().lower() == name:
            values.append(value.strip())
    return values


def create(server: LineServer, options: Mapping[str, Any]) -> MetricsFace:
    """``options``: ``{"listen": "HOST:PORT", "allow_remote": bool, "token": str, "hosts": [names
    besides the listen address]}``."""
    listen = options.get("listen")
    if not isinstance(listen, str):
        raise UsageError('metrics.listen: expected "HOST:PORT"')
    token = options.get("token")
    if token is not None and not isinstance(token, str):
        raise UsageError("metrics.token: expected a string")
    allow_remote = bool(options.get("allow_remote", False))
    hosts = hosts_option(options.get("hosts"), "metrics")
    return MetricsFace(server, parse_listen(listen), allow_remote, token, hosts=hosts)
