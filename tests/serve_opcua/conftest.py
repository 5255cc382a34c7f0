"""The OPC UA face on a free loopback port with the simulator behind it, and asyncua's own
client to talk to it (issue #16)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import shutil
from collections.abc import AsyncIterator, Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from asyncua import Client, ua
from asyncua.common.node import Node
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from cryptography.x509.oid import ExtendedKeyUsageOID

from robostar.serve import LineConfig, LineServer, ServeConfig
from robostar.serve.users import Role, UserStore
from robostar.types import Alarm

CLIENT_URI = "urn:robostar:tests:opcua-client"
PASSWORDS = {"olga": "operator-pass-1", "vic": "viewer-pass-1"}
"""olga is an operator, vic a viewer."""


@dataclass(frozen=True)
class Setup:
    users: Path
    state: Path
    cache: Path
    client_cert: Path
    client_key: Path


def make_setup(root: Path) -> Setup:
    """Users (olga the operator, vic the viewer), and a client certificate, under ``root``."""
    users = UserStore(root / "users.toml")
    users.add("olga", Role.OPERATOR, PASSWORDS["olga"])
    users.add("vic", Role.VIEWER, PASSWORDS["vic"])
    cert, key = root / "client-cert.der", root / "client-key.pem"
    asyncio.run(
        setup_self_signed_certificate(
            key,
            cert,
            CLIENT_URI,
            "localhost",
            [ExtendedKeyUsageOID.CLIENT_AUTH],
            {"commonName": "robostar tests"},
        )
    )
    # the audit log is opened (in the state directory) before the face makes that directory
    (root / "state").mkdir(mode=0o700, exist_ok=True)
    # the tests' client application is a known one: its certificate is in the trust list
    trusted = root / "state" / "pki" / "trusted"
    trusted.mkdir(parents=True)
    shutil.copy(cert, trusted / cert.name)
    return Setup(root / "users.toml", root / "state", root / "cache", cert, key)


@pytest.fixture(scope="session")
def opcua_setup(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Setup]:
    """Users, a certificate directory, a nodeset cache and a client certificate, shared by the
    session's tests (the first server of the session imports the nodesets, the others load
    the cache)."""
    yield make_setup(tmp_path_factory.mktemp("opcua"))


def config(
    setup: Setup,
    *,
    url: str = "sim://?speedup=20",
    poll: float = 0.05,
    slow: float = 1.0,
    channels: dict[int, str] | None = None,
    **opcua: Any,
) -> ServeConfig:
    options: dict[str, Any] = {
        "listen": "127.0.0.1:0",
        "users": str(setup.users),
        "state_dir": str(setup.state),
        "cache_dir": str(setup.cache),
    }
    options.update(opcua)
    line = LineConfig(
        "cell1", url, poll_interval=poll, slow_interval=slow, channels=dict(channels or {})
    )
    return ServeConfig(
        lines=(line,), faces={"opcua": options}, audit_path=str(setup.state / "audit.jsonl")
    )


@contextlib.asynccontextmanager
async def serving(setup: Setup, **options: Any) -> AsyncIterator[LineServer]:
    server = LineServer(config(setup, **options))
    await server.start()
    try:
        yield server
    finally:
        await server.stop()


@contextlib.asynccontextmanager
async def connect(
    server: LineServer,
    setup: Setup,
    user: str | None = "olga",
    *,
    mode: str = "SignAndEncrypt",
    password: str | None = None,
) -> AsyncIterator[Client]:
    """An asyncua client signed in as ``user`` (None: anonymous) over ``mode`` (``None_``: the
    unsigned endpoint)."""
    face: Any = server.faces["opcua"]
    client = Client(face.address, timeout=10)
    client.application_uri = CLIENT_URI
    if mode != "None_":
        await client.set_security_string(
            f"Basic256Sha256,{mode},{setup.client_cert},{setup.client_key}"
        )
    if user is not None:
        client.set_user(user)
        client.set_password(password if password is not None else PASSWORDS[user])
    async with client:
        yield client


class Model:
    """Browse-name paths into the Robotics model of line ``cell1``, as a SCADA client finds
    them: DeviceSet / <line> / ..."""

    def __init__(self, client: Client) -> None:
        self.client = client

    async def ns(self) -> tuple[int, int, int]:
        c = self.client
        return (
            await c.get_namespace_index("http://opcfoundation.org/UA/DI/"),
            await c.get_namespace_index("http://opcfoundation.org/UA/Robotics/"),
            await c.get_namespace_index("urn:robostar:n1"),
        )

    async def system(self, line: str = "cell1") -> Node:
        di, _, vendor = await self.ns()
        device_set = self.client.get_node(ua.NodeId(5001, di))
        return await device_set.get_child([f"{vendor}:{line}"])

    async def path(self, *names: str) -> Node:
        """A node below the system by browse names, each ``di:``, ``rob:``, ``ven:`` or
        ``0:`` prefixed."""
        di, rob, vendor = await self.ns()
        prefixes = {"di": di, "rob": rob, "ven": vendor, "0": 0}
        qualified = []
        for name in names:
            prefix, _, rest = name.partition(":")
            qualified.append(f"{prefixes[prefix]}:{rest}")
        return await (await self.system()).get_child(qualified)

    async def axis_position(self, channel: int, axis: int) -> Node:
        return await self.path(
            "rob:MotionDevices",
            f"ven:Channel{channel}",
            "rob:Axes",
            f"ven:Axis{axis}",
            "di:ParameterSet",
            "rob:ActualPosition",
        )

    async def alarm_event_type(self) -> Node:
        """The face's N1AlarmConditionType (an AlarmConditionType)."""
        _, _, vendor = await self.ns()
        return await self.client.get_node(ua.ObjectIds.AlarmConditionType).get_child(
            [f"{vendor}:N1AlarmConditionType"]
        )

    async def refresh_conditions(self, handler: Any) -> Any:
        """A new subscription to the line's alarm conditions, asked for the active ones
        (ConditionRefresh), as a client that comes late does; the subscription."""
        subscription = await self.client.create_subscription(20, handler)
        await subscription.subscribe_alarms_and_conditions(
            await self.system(), await self.alarm_event_type()
        )
        await self.client.get_node(ua.ObjectIds.ConditionType).call_method(
            ua.NodeId(ua.ObjectIds.ConditionType_ConditionRefresh),
            ua.Variant(subscription.subscription_id, ua.VariantType.UInt32),
        )
        return subscription

    async def state_machine(self, channel: int) -> Node:
        return await self.path(
            "rob:Controllers",
            "ven:cell1",
            "rob:TaskControls",
            f"ven:Channel{channel}",
            "rob:TaskControlOperation",
            "rob:TaskControlStateMachine",
        )


async def read_values(client: Client, nodes: list[Node], max_age_ms: float) -> list[ua.DataValue]:
    """One Read request for the values of ``nodes`` with OPC UA's ``maxAge`` (asyncua's
    ``read_value`` always asks 0: the value as it is now)."""
    params = ua.ReadParameters()
    params.MaxAge = max_age_ms
    for node in nodes:
        item = ua.ReadValueId()
        item.NodeId = node.nodeid
        item.AttributeId = ua.AttributeIds.Value
        params.NodesToRead.append(item)
    return list(await client.uaclient.read(params))


async def until(predicate: Any, timeout: float = 10.0, what: str = "condition") -> None:
    """Wait for an async predicate to hold (polled; the machine may be slow, never a race)."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while True:
        if await predicate():
            return
        if loop.time() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        await asyncio.sleep(0.05)


def audited(setup: Setup, face: str = "opcua") -> list[tuple[str, str, str]]:
    """(who, what, outcome) of each audit record ``face`` wrote, in order."""
    lines = (setup.state / "audit.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines]
    return [(r["who"], r["what"], r["outcome"]) for r in records if r["face"] == face]


# -- alarm conditions, as a SCADA alarm list sees them ------------------------------------------
ACKNOWLEDGE = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
CONFIRM = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Confirm)
TIMED_SHELVE = ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_TimedShelve)
ONE_SHOT_SHELVE = ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_OneShotShelve)
UNSHELVE = ua.NodeId(ua.ObjectIds.ShelvedStateMachineType_Unshelve)


class Events:
    """A subscription's handler: every event notification, in order."""

    def __init__(self) -> None:
        self.events: list[Any] = []

    def event_notification(self, event: Any) -> None:
        self.events.append(event)

    def of(self, code: int) -> list[Any]:
        return [e for e in self.events if getattr(e, "AlarmCode", None) == code]

    async def next_of(self, code: int, seen: int, what: str) -> Any:
        """The first event of ``code`` after the ``seen`` ones already had."""

        async def more() -> bool:
            return len(self.of(code)) > seen

        await until(more, what=what)
        return self.of(code)[seen]


def field(event: Any, name: str) -> Any:
    return getattr(event, name)


def text(value: Any) -> str:
    return value.Text if isinstance(value, ua.LocalizedText) else str(value)


async def call(node: Any, method: ua.NodeId, *args: ua.Variant) -> ua.StatusCode:
    """Call ``method`` on ``node``; the status code it ends with (Good, or the refusal's)."""
    try:
        await node.call_method(method, *args)
    except ua.UaStatusCodeError as exc:
        return ua.StatusCode(exc.code)
    return ua.StatusCode(ua.StatusCodes.Good)


def ack_args(event: Any, comment: str) -> tuple[ua.Variant, ua.Variant]:
    """The arguments of Acknowledge, Confirm and AddComment: the event's id and a comment."""
    return (
        ua.Variant(field(event, "EventId"), ua.VariantType.ByteString),
        ua.Variant(ua.LocalizedText(comment), ua.VariantType.LocalizedText),
    )


async def subscribe(client: Client, handler: Events) -> Any:
    """A subscription to the line's alarm events, as an alarm list makes one."""
    model = Model(client)
    subscription = await client.create_subscription(20, handler)
    await subscription.subscribe_alarms_and_conditions(
        await model.system(), await model.alarm_event_type()
    )
    return subscription


@dataclass(frozen=True)
class RaisedAlarm:
    """An alarm raised in the line's model, seen by an operator's subscribed client."""

    server: LineServer
    client: Client
    events: Events
    raised: Any
    """The alarm's first event."""
    condition: Node
    """Its condition (the node the event names)."""


RaiseAlarm = Callable[[Alarm], contextlib.AbstractAsyncContextManager[RaisedAlarm]]


@pytest.fixture
def raised_alarm(opcua_setup: Setup) -> RaiseAlarm:
    """``async with raised_alarm(Alarm(code, text)) as alarm:`` serves the face with a slow
    poller (the alarms the test puts in the model stay there), signs olga in, subscribes to
    the alarm events, raises the alarm in the model and waits for its first event."""

    @contextlib.asynccontextmanager
    async def raise_alarm(alarm: Alarm) -> AsyncIterator[RaisedAlarm]:
        async with (
            serving(opcua_setup, poll=30.0) as server,
            connect(server, opcua_setup) as client,
        ):
            events = Events()
            subscription = await subscribe(client, events)
            server.line("cell1").model.set("alarms", (alarm,))
            raised = await events.next_of(alarm.code, 0, "the alarm's event")
            condition = client.get_node(field(raised, "NodeId"))
            yield RaisedAlarm(server, client, events, raised, condition)
            await subscription.delete()

    return raise_alarm
