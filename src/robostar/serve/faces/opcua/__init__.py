"""The OPC UA face: every line as a Robotics companion-spec motion device system (OPC 40010-1).

``robostar serve --opcua HOST:PORT`` (or ``[opcua]`` in the config; docs/opcua.md) starts an
asyncua server with the DI, IA and Robotics nodesets and, under DI's ``DeviceSet``, one
``MotionDeviceSystemType`` per line (``address_space.py``). The lines' models fill its
variables with source timestamps and status codes (``publisher.py``), and alarms become
OPC UA alarm conditions with Acknowledge, Confirm and shelving (``conditions.py``);
``Start``, ``Stop``, ``LoadByName`` and a vendor ``EmergencyStop`` go
through the line's lease and audit for operators only (``methods.py``); each line's
``Control`` object shows its lease and takes TakeControl / ReleaseControl (``control.py``).

Security by default (``security.py``): Basic256Sha256 endpoints only (Sign, SignAndEncrypt),
a self-signed application certificate made on first start and kept, client applications from a
trust list (``trust.py``), users from the line server's users file; no anonymous access and
no unsigned endpoint unless ``allow_anonymous_read`` (loopback only), which adds a read-only one
for local tools.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from asyncua import ua
from asyncua.common.callback import CallbackType
from asyncua.common.node import Node
from asyncua.crypto.security_policies import SecurityPolicyFactory, SecurityPolicyNone
from asyncua.server.event_generator import EventGenerator
from asyncua.server.server import Server

from robostar.commands.base import Command
from robostar.commands.variables import ReadGlobalFloat, ReadGlobalInt
from robostar.errors import RobostarError, UsageError
from robostar.serve.faces.opcua._ua import AttributeIds, ObjectIds, UaStatusCodeError
from robostar.serve.faces.opcua.address_space import (
    DeviceNodes,
    Namespaces,
    build_line,
    namespaces,
)
from robostar.serve.faces.opcua.conditions import AlarmConditions, ConditionMethods
from robostar.serve.faces.opcua.control import REFRESH_SECONDS, ControlNodes, build_control
from robostar.serve.faces.opcua.methods import handler_for
from robostar.serve.faces.opcua.nodesets import CachedInternalServer, LoadReport
from robostar.serve.faces.opcua.publisher import ALARM_EVENT_FIELDS, NodeWriter
from robostar.serve.faces.opcua.reads import FreshReads
from robostar.serve.faces.opcua.security import (
    RefuseAllRuleset,
    RoleRuleset,
    UsersManager,
    ensure_certificate,
)
from robostar.serve.faces.opcua.setpoints import SetpointAttributeService, speed_setter
from robostar.serve.faces.opcua.settings import OpcUaSettings, settings_from
from robostar.serve.faces.opcua.trust import ClientTrustList
from robostar.serve.model import Sample
from robostar.serve.users import UserStore

if TYPE_CHECKING:
    from robostar.serve.line import Line
    from robostar.serve.line_server import LineServer

__all__ = ["OpcUaFace", "OpcUaSettings", "create", "settings_from"]

log = logging.getLogger("robostar.serve.opcua")


class OpcUaFace:
    """The OPC UA server of a line server (see the module docstring)."""

    def __init__(self, server: LineServer, settings: OpcUaSettings) -> None:
        self.server = server
        self.settings = settings
        self.users = UserStore(settings.users)
        self.ua: Server | None = None
        self.ns: Namespaces | None = None
        self.devices: dict[str, DeviceNodes] = {}
        self.publishers: dict[str, NodeWriter] = {}
        self.conditions: dict[str, AlarmConditions] = {}
        """Each line's alarm conditions: kept when its nodes are made again."""
        self._condition_methods = ConditionMethods()
        self.tasks: set[asyncio.Task[Any]] = set()
        self.load = LoadReport()
        self.startup_seconds = 0.0
        """Wall time of start(): address space, certificate, the lines' nodes, listening."""
        self._event_type: ua.NodeId | None = None
        self._setpoints: SetpointAttributeService | None = None
        self._setpoint_nodes: dict[str, list[ua.NodeId]] = {}
        self.reads = FreshReads(self.publishers.get)
        """Clients' Reads brought up to their maxAge (reads.py)."""
        self.controls: dict[str, ControlNodes] = {}
        """Each line's Control object (its lease; control.py)."""

    @property
    def address(self) -> str:
        """The endpoint URL (with the real port when the settings asked for port 0)."""
        return self.settings.url(self.port)

    @property
    def port(self) -> int:
        bserver = self.ua.bserver if self.ua is not None else None
        return bserver.port if bserver is not None else self.settings.port

    async def start(self) -> None:
        """Make the address space and the lines' nodes, then listen. A failure (the port taken,
        say) stops what was started and raises UsageError naming it."""
        try:
            await self._start()
        except BaseException as exc:
            await self.stop()
            if isinstance(exc, OSError):
                raise UsageError(
                    f"opcua: cannot serve {self.settings.endpoint}: {exc.strerror or exc}"
                ) from exc
            raise

    async def _start(self) -> None:
        started = time.perf_counter()
        s = self.settings
        manager = UsersManager(self.users, allow_anonymous=s.allow_anonymous_read)
        iserver = CachedInternalServer(s.cache_dir, user_manager=manager)
        iserver.bind_condition_methods = True  # ConditionRefresh replays the active alarms
        server = Server(iserver=iserver)
        space_started = time.perf_counter()
        await server.init()
        self.load = await iserver.load_nodesets(server)
        self.load.seconds = time.perf_counter() - space_started
        self._setpoints = SetpointAttributeService(iserver.aspace)
        iserver.attribute_service = self._setpoints  # clients' writes go to the setpoints
        # one PreRead listener: asyncua keeps one per callback type and priority, so a second
        # subscription replaced the first (maxAge reads stopped reaching the line)
        server.subscribe_server_callback(CallbackType.PreRead, self._before_read)
        server.set_endpoint(s.endpoint)
        server.set_server_name("robostar serve")
        server.product_uri = "urn:robostar"
        server.manufacturer_name = "robostar"
        await server.set_application_uri(s.application_uri)
        cert, key = await ensure_certificate(s.state_dir, s.application_uri, s.hostname)
        await server.load_certificate(str(cert))
        await server.load_private_key(str(key))
        policies = [
            ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
            ua.SecurityPolicyType.Basic256Sha256_Sign,
        ]
        tokens: list[type] = [ua.UserNameIdentityToken]
        if s.allow_anonymous_read:
            policies.append(ua.SecurityPolicyType.NoSecurity)
            tokens.append(ua.AnonymousIdentityToken)
        server.set_security_policy(
            # every channel unsigned (read-only) until _secure_endpoints marks the signed ones
            policies,
            permission_ruleset=RoleRuleset(self.users, secure=False),
        )
        server.set_identity_tokens(tokens)
        server.set_certificate_validator(
            ClientTrustList(s.pki, accept_unknown=s.accept_unknown_clients)
        )
        self.ua = server
        self.ns = await namespaces(server)
        event_type = await server.create_custom_event_type(
            self.ns.vendor,
            "N1AlarmConditionType",
            ObjectIds.AlarmConditionType,
            list(ALARM_EVENT_FIELDS),
        )
        self._event_type = event_type.nodeid
        self._condition_methods.bind(server)
        for line in self.server.lines.values():
            await self._build(line)
        await server.start()
        self._secure_endpoints(server)
        refresher = asyncio.create_task(self._refresh_controls(), name="opcua control")
        refresher.add_done_callback(_report_end)
        self.tasks.add(refresher)
        for line in self.server.lines.values():
            jobs = [(self._pump(line), f"opcua {line.name}")]
            if s.global_ints or s.global_floats:
                jobs.append((self._read_globals(line), f"opcua {line.name} GR"))
            for job, name in jobs:
                task = asyncio.create_task(job, name=name)
                task.add_done_callback(_report_end)
                self.tasks.add(task)
        self.startup_seconds = time.perf_counter() - started
        log.info(
            "opcua face: %s, %d line(s), started in %.2f s (address space %s in %.2f s)",
            s.endpoint,
            len(self.devices),
            self.startup_seconds,
            "from cache" if self.load.cached else "imported",
            self.load.seconds,
        )

    def _secure_endpoints(self, server: Server) -> None:
        """Mark the signed endpoints' channels secure, and close asyncua's back door.

        Every channel starts with the ruleset of an unsigned one (nothing that moves the robot),
        and the signed endpoints' policy factories get the secure one: should asyncua's private
        list of factories ever change shape, the server refuses to start rather than fail open.
        asyncua also serves a client that asks for no security on a policy of its own when no
        endpoint offers it; a factory for it whose ruleset refuses every request takes its
        place unless anonymous reading is on (and then that endpoint is the read-only one).
        """
        factories = getattr(server, "_policies", None)
        signed = [
            f
            for f in factories or []
            if getattr(f, "mode", None)
            in (ua.MessageSecurityMode.Sign, ua.MessageSecurityMode.SignAndEncrypt)
        ]
        if not isinstance(factories, list) or len(signed) != 2:
            raise RuntimeError("opcua: asyncua's endpoint policies are not as expected")
        for factory in signed:
            factory.permission_ruleset = RoleRuleset(self.users, secure=True)
        if not self.settings.allow_anonymous_read:
            factories.append(
                SecurityPolicyFactory(  # type: ignore[no-untyped-call]
                    SecurityPolicyNone,
                    ua.MessageSecurityMode.None_,
                    permission_ruleset=RefuseAllRuleset(),
                )
            )

    async def _build(self, line: Line) -> None:
        assert self.ua is not None and self.ns is not None and self._event_type is not None
        nodes = await build_line(
            self.ua,
            self.ns,
            line.name,
            line.info,
            shown_channels(line),
            line.config.io_ports,
            dict(line.config.channels),
            self.settings.global_ints,
            self.settings.global_floats,
        )
        self.devices[line.name] = nodes
        for name, node in nodes.methods.items():
            self.ua.link_method(node, handler_for(line, name, None))
        for channel, ch in nodes.channels.items():
            for name, node in ch.methods.items():
                self.ua.link_method(node, handler_for(line, name, channel))
        await self._writable(line, nodes)
        self.controls[line.name] = await build_control(self.ua, self.ns.vendor, line, nodes.system)
        events = EventGenerator(self.ua.iserver.isession)
        await events.init(self._event_type, emitting_node=nodes.system.nodeid)
        conditions = self.conditions.get(line.name)
        if conditions is None:
            conditions = AlarmConditions(
                self.ua, line.name, self.ns.vendor, self._event_type, line.record
            )
            self.conditions[line.name] = conditions
            self._condition_methods.lines.append(conditions)
        await conditions.attach(events, nodes.system.nodeid)
        publisher = NodeWriter(self.ua, nodes, conditions, self.ns.robotics, self.ns.vendor)
        await publisher.waiting()
        if line.model.get("online") is None:
            await publisher.show_online(line.up)
        self.publishers[line.name] = publisher
        self.reads.register(line, nodes)

    async def _writable(self, line: Line, nodes: DeviceNodes) -> None:
        """The line's setpoints (each channel's SpeedOverride) take operators' writes."""
        assert self._setpoints is not None
        setters = self._setpoints.setters
        for old in self._setpoint_nodes.pop(line.name, []):
            setters.pop(old, None)
        mine = self._setpoint_nodes[line.name] = []
        writable = ua.AccessLevel.CurrentRead.mask | ua.AccessLevel.CurrentWrite.mask
        for channel, ch in nodes.channels.items():
            speed = ch.values["speed"]
            setters[speed.nodeid] = speed_setter(line, channel)
            mine.append(speed.nodeid)
            for attribute in (AttributeIds.AccessLevel, AttributeIds.UserAccessLevel):
                await speed.write_attribute(
                    attribute, ua.DataValue(ua.Variant(writable, ua.VariantType.Byte))
                )

    async def _rebuild(self, line: Line) -> None:
        """The line came up after the face started: its channels and axes are known now.

        The old nodes are removed without asyncua's search of the whole address space for
        references to each (a second's freeze of the loop for one line): the only references
        into the line's subtree from outside are those of its parents (DeviceSet, the Server's
        event notifier), each the source's forward twin of an inverse reference the system
        node holds, so those are removed by hand first.
        """
        old = self.devices.pop(line.name)
        system = old.system
        for ref in await system.get_references(direction=ua.BrowseDirection.Inverse):
            source = Node(system.session, ref.NodeId)
            with contextlib.suppress(UaStatusCodeError):
                await source.delete_reference(
                    system.nodeid, ref.ReferenceTypeId, forward=True, bidirectional=False
                )
        await system.delete(delete_references=False, recursive=True)
        await self._build(line)

    async def _pump(self, line: Line) -> None:
        with line.model.subscribe(maxsize=10_000) as changes:
            try:
                await self.publishers[line.name].apply_all(line.model.snapshot().items())
            except Exception:
                log.exception("opcua %s: cannot show the model", line.name)
            async for change in changes:
                try:
                    device = self.devices.get(line.name)
                    if device is not None and (change.key != "info" or device.with_info):
                        await self.publishers[line.name].apply(change.key, change.sample)
                        continue
                    if device is None and change.key not in ("info", "online"):
                        # the nodes could not be made again (logged): try when the line
                        # comes (back) up, not at every change
                        continue
                    await (self._build(line) if device is None else self._rebuild(line))
                    await self.publishers[line.name].apply_all(line.model.snapshot().items())
                except Exception:  # one bad value must not stop the line's updates
                    log.exception("opcua %s: cannot show %s", line.name, change.key)

    async def _before_read(self, event: Any, dispatcher: Any = None) -> None:
        """asyncua's PreRead: the variables read brought up to the client's maxAge, and the
        Control variables to the lease as it is."""
        await self.reads.before_read(event, dispatcher)
        await self._control_before_read(event, dispatcher)

    async def _control_before_read(self, event: Any, dispatcher: Any = None) -> None:
        """A client's Read of a Control variable sees the lease as it is at that read."""
        if not getattr(event, "is_external", False):
            return
        wanted = {item.NodeId for item in event.request_params.NodesToRead}
        for control in list(self.controls.values()):
            if wanted & control.node_ids:
                await control.show()

    async def _refresh_controls(self) -> None:
        """Subscribers' view of every line's lease (SecondsLeft runs down, leases expire)."""
        while True:
            for control in list(self.controls.values()):
                try:
                    await control.show()
                except Exception:  # a line whose nodes are being made again
                    log.debug("opcua %s: control not shown", control.line.name, exc_info=True)
            await asyncio.sleep(REFRESH_SECONDS)

    async def _read_globals(self, line: Line) -> None:
        """The configured global variables, read through the line's queue (after the
        consumers' reads, like any read) every ``globals_interval``; a failed read leaves the
        value with the status of a stale one."""
        s = self.settings
        commands: list[tuple[str, Command[Any]]] = [
            *((f"global/int/{i}", ReadGlobalInt(i)) for i in s.global_ints),
            *((f"global/float/{i}", ReadGlobalFloat(i)) for i in s.global_floats),
        ]
        while True:
            for key, command in commands:
                publisher = self.publishers.get(line.name)
                try:
                    value = await line.read(command, max_age=0)
                    if publisher is not None:
                        await publisher.apply(key, Sample(value, time.time()))
                except RobostarError as exc:
                    log.debug("opcua %s: %s not read: %s", line.name, key, exc)
                    if publisher is not None:
                        await publisher.stale(key)
                except Exception:  # a bug here must not end the reads of every variable
                    log.exception("opcua %s: %s", line.name, key)
            await asyncio.sleep(s.globals_interval)

    async def stop(self) -> None:
        for task in list(self.tasks):
            task.cancel()
        for task in list(self.tasks):
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self.tasks.clear()
        for conditions in self.conditions.values():
            conditions.close()
        server, self.ua = self.ua, None
        if server is not None and server.bserver is not None:
            await server.stop()


def shown_channels(line: Line) -> tuple[int, ...]:
    """The line's channels (configured, else the controller's) that the controller has: a
    channel configured for a controller without it would show only empty values. Before the
    controller has answered, the configured ones (the nodes are made again once it has)."""
    channels = line.channels()
    if line.info is None:
        return channels
    present = {c.channel for c in line.info.channels if c.axes_in_use}
    return tuple(c for c in channels if c in present) or channels


def _report_end(task: asyncio.Task[Any]) -> None:
    """A face task ends only when stopped; any other end is a bug, and is logged."""
    if not task.cancelled() and task.exception() is not None:
        log.error("opcua: %s ended", task.get_name(), exc_info=task.exception())


def create(server: LineServer, options: Mapping[str, Any]) -> OpcUaFace:
    """``options``: the ``[opcua]`` section (docs/opcua.md)."""
    return OpcUaFace(server, settings_from(options))
