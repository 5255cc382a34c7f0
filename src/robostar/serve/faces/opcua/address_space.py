"""One controller line as a Robotics companion-spec ``MotionDeviceSystemType`` instance.

Under ``DeviceSet`` (DI), per line::

    <line>                                MotionDeviceSystemType
      MotionDevices/<channel>             MotionDeviceType: identity, category, SpeedOverride,
        Axes/Axis<n>                        InControl; per axis MotionProfile, ActualPosition
        Robostar/                           (vendor) OriginDone, InPosition, Ready, Running,
                                            Alarm, JobStep, CartesianPosition, ArmForm
      Controllers/<line>                  ControllerType: identity, Software/Firmware
        TaskControls/<channel>            TaskControlType: TaskProgramName, TaskProgramLoaded,
          TaskControlOperation/             ExecutionMode; the state machine's Start, Stop,
            TaskControlStateMachine         LoadByName
        Robostar/                         (vendor) Online, Alarms, AlarmHistory, Inputs,
                                          Outputs, EmergencyStop()
      SafetyStates/<line>                 SafetyStateType: EmergencyStop, OperationalMode,
                                          ProtectiveStop (informational, as the spec says)

The type instances are made by asyncua from the imported types (mandatory children only);
asyncua also makes the types' placeholder children (``<AxisIdentifier>`` ...) literally, so
they are removed and the real ones added. Optional children the N1 can fill are added by hand
with the spec's browse names.

Names: a name the spec defines keeps the spec's namespace (``Robotics:MotionDevices``,
``DI:ParameterSet``, ``Robotics:ActualPosition``); a name this server chooses for an instance
(the line, ``Channel1``, ``Axis1``, ``Firmware``) and everything vendor-specific is in the
robostar namespace ``urn:robostar:n1``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from asyncua import ua
from asyncua.common.node import Node
from asyncua.server.server import Server

from robostar.serve.faces.opcua._ua import (
    AttributeIds,
    ObjectIds,
    StatusCodes,
    UaStatusCodeError,
    node_id,
    status,
)
from robostar.types import ChannelInfo, ControllerInfo, RobotType

__all__ = [
    "DI_URI",
    "ROBOTICS_URI",
    "VENDOR_URI",
    "DeviceNodes",
    "Namespaces",
    "build_line",
    "namespaces",
]

DI_URI = "http://opcfoundation.org/UA/DI/"
ROBOTICS_URI = "http://opcfoundation.org/UA/Robotics/"
VENDOR_URI = "urn:robostar:n1"
"""The robostar vendor namespace: what the companion spec has no place for."""

# Robotics nodeset ids (namespace-relative, from Opc.Ua.Robotics.NodeSet2.xml)
MOTION_DEVICE_SYSTEM_TYPE = 1002
CONTROLLER_TYPE = 1003
MOTION_DEVICE_TYPE = 1004
TASK_CONTROL_OPERATION_TYPE = 1008
TASK_CONTROL_TYPE = 1011
SAFETY_STATE_TYPE = 1013
AXIS_TYPE = 16601
EXECUTION_MODE_ENUMERATION = 18191
DEVICE_SET = 5001
"""DI's DeviceSet object, where devices live."""

_CATEGORY = {
    RobotType.XY: 3,  # CARTESIAN_ROBOT
    RobotType.SCARA: 2,  # SCARA_ROBOT
    RobotType.TRANSFER: 3,
    RobotType.CYLINDER: 6,  # CYLINDRICAL_ROBOT
}
ROTARY, LINEAR, OTHER = 1, 3, 0
_UNITS = "http://www.opcfoundation.org/UA/units/un/cefact"
MILLIMETRE = ua.EUInformation(
    NamespaceUri=_UNITS,
    UnitId=0x4D4D54,  # UN/CEFACT "MMT"
    DisplayName=ua.LocalizedText("mm"),
    Description=ua.LocalizedText("millimetre"),
)
DEGREE = ua.EUInformation(
    NamespaceUri=_UNITS,
    UnitId=0x4444,  # UN/CEFACT "DD"
    DisplayName=ua.LocalizedText("°"),
    Description=ua.LocalizedText("degree [unit of angle]"),
)


@dataclass(frozen=True)
class Namespaces:
    di: int
    robotics: int
    vendor: int


async def namespaces(server: Server) -> Namespaces:
    return Namespaces(
        di=await server.get_namespace_index(DI_URI),
        robotics=await server.get_namespace_index(ROBOTICS_URI),
        vendor=await server.register_namespace(VENDOR_URI),
    )


def axis_profile(robot: RobotType, axis: int) -> int:
    """Whether pendant axis ``axis`` of a ``robot`` turns (degrees) or slides (mm)."""
    if robot is RobotType.SCARA:
        return LINEAR if axis == 3 else ROTARY
    if robot is RobotType.CYLINDER:
        return ROTARY if axis == 1 else LINEAR
    if robot in (RobotType.XY, RobotType.TRANSFER):
        return LINEAR
    return OTHER


@dataclass
class ChannelNodes:
    """The variables and methods of one channel (a motion device and its task control)."""

    channel: int
    device: Node
    task_control: Node
    state_machine: Node
    axes: list[Node] = field(default_factory=list)
    """ActualPosition of each axis in use, in AD's order."""
    values: dict[str, Node] = field(default_factory=dict)
    """Named variables: in_control, speed, program, loaded, current_state, origin, ... ."""
    methods: dict[str, Node] = field(default_factory=dict)
    """The task control state machine's methods by name (Start, Stop, LoadByName)."""


@dataclass
class DeviceNodes:
    """Everything of one line the face writes to or calls."""

    line: str
    system: Node
    controller: Node
    safety: Node
    channels: dict[int, ChannelNodes] = field(default_factory=dict)
    values: dict[str, Node] = field(default_factory=dict)
    """Line-wide variables: online, alarms, alarm_history, emergency_stop, io/in/0, ..."""
    methods: dict[str, Node] = field(default_factory=dict)
    """The line-wide methods by name (EmergencyStop)."""
    with_info: bool = True
    """Whether the controller's AD answer was known when the nodes were made (else the
    channels and axes are guesses, and the face makes them again once it is)."""


class _Builder:
    def __init__(self, server: Server, ns: Namespaces, line: str) -> None:
        self.server = server
        self.ns = ns
        self.line = line

    def rob(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(name, self.ns.robotics)

    def di(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(name, self.ns.di)

    def vendor(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(name, self.ns.vendor)

    def nodeid(self, path: str) -> ua.NodeId:
        return node_id(path, self.ns.vendor)

    async def instance(self, parent: Node, path: str, name: ua.QualifiedName, type_id: int) -> Node:
        """An instance of a Robotics type, mandatory children only, placeholders removed."""
        node = await parent.add_object(
            self.nodeid(path),
            name,
            objecttype=node_id(type_id, self.ns.robotics),
            instantiate_optional=False,
        )
        await _drop_placeholders(node)
        return node

    async def child(self, node: Node, *names: ua.QualifiedName) -> Node:
        return await node.get_child(list(names))

    async def variable(
        self,
        parent: Node,
        path: str,
        name: ua.QualifiedName,
        value: Any,
        variant: ua.VariantType,
        *,
        datatype: ua.NodeId | None = None,
        description: str | None = None,
    ) -> Node:
        node = await parent.add_variable(
            self.nodeid(path), name, ua.Variant(value, variant), datatype=datatype
        )
        if description:
            await node.write_attribute(
                AttributeIds.Description,
                ua.DataValue(ua.Variant(ua.LocalizedText(description))),
            )
        return node

    async def vendor_variables(
        self,
        parent: Node,
        prefix: str,
        specs: Sequence[tuple[str, str, Any, ua.VariantType, str]],
    ) -> dict[str, Node]:
        """Vendor variables under ``parent``: (key, browse name, initial value, type,
        description) each; the node id is ``<prefix>.<browse name>``."""
        made = {}
        for key, name, value, variant, description in specs:
            made[key] = await self.variable(
                parent,
                f"{prefix}.{name}",
                self.vendor(name),
                value,
                variant,
                description=description,
            )
        return made

    async def component_name(self, node: Node, path: str, text: str) -> None:
        """DI's optional ComponentName, which generic clients show as the instance's name."""
        await self.variable(
            node,
            f"{path}.ComponentName",
            self.di("ComponentName"),
            ua.LocalizedText(text),
            ua.VariantType.LocalizedText,
        )

    async def folder(self, parent: Node, path: str, name: str) -> Node:
        return await parent.add_object(self.nodeid(path), self.vendor(name))


async def _drop_placeholders(node: Node) -> None:
    """Remove the ``<...>`` placeholder children asyncua made from the type, at any depth.

    Each is fresh, referenced only by its parent: it is deleted without asyncua's search of
    the whole address space for references to it (a scan of every node per deleted node, two
    seconds per line), and the parent's one reference is removed by hand.
    """
    refs = await node.get_references(
        refs=ObjectIds.HierarchicalReferences, direction=ua.BrowseDirection.Forward
    )
    for ref in refs:
        name = ref.BrowseName.Name or ""
        child = Node(node.session, ref.NodeId)
        if name.startswith("<") and name.endswith(">"):
            await node.delete_reference(
                ref.NodeId, ref.ReferenceTypeId, forward=True, bidirectional=False
            )
            await child.delete(delete_references=False, recursive=True)
        elif ref.NodeClass == ua.NodeClass.Object:
            await _drop_placeholders(child)


async def _set(node: Node, value: Any, variant: ua.VariantType) -> None:
    await node.write_value(ua.DataValue(ua.Variant(value, variant)))


async def build_line(
    server: Server,
    ns: Namespaces,
    line: str,
    info: ControllerInfo | None,
    channels: Sequence[int],
    io_ports: Sequence[int],
    labels: dict[int, str],
    global_ints: Sequence[int] = (),
    global_floats: Sequence[int] = (),
) -> DeviceNodes:
    """Make the nodes of one line under DeviceSet; the values start empty with status
    ``BadWaitingForInitialData`` until the line's model fills them."""
    b = _Builder(server, ns, line)
    device_set = server.get_node(node_id(DEVICE_SET, ns.di))
    system = await b.instance(device_set, line, b.vendor(line), MOTION_DEVICE_SYSTEM_TYPE)
    await b.component_name(system, line, f"{line} (Robostar N1)")
    values: dict[str, Node] = {}

    # -- the controller ------------------------------------------------------------------
    controllers = await b.child(system, b.rob("Controllers"))
    controller = await b.instance(
        controllers, f"{line}.Controller", b.vendor(line), CONTROLLER_TYPE
    )
    await b.component_name(controller, f"{line}.Controller", f"{line} controller")
    model = info.name if info is not None else "N1"
    await _identity(controller, b, model)
    software_folder = await b.child(controller, b.rob("Software"))
    software = await software_folder.add_object(
        b.nodeid(f"{line}.Controller.Software.Firmware"),
        b.vendor("Firmware"),
        objecttype=node_id(15106, ns.di),  # DI SoftwareType
        instantiate_optional=False,
    )
    for child_name, value in (
        ("Manufacturer", ua.LocalizedText("Robostar")),
        ("Model", ua.LocalizedText(model)),
        ("SoftwareRevision", info.version if info else ""),
    ):
        with_child = await _maybe_child(software, b.di(child_name))
        if with_child is not None:
            await with_child.write_value(value)
    vendor = await b.folder(controller, f"{line}.Controller.Robostar", "Robostar")
    bool_, text, double, int32 = (
        ua.VariantType.Boolean,
        ua.VariantType.String,
        ua.VariantType.Double,
        ua.VariantType.Int32,
    )
    specs: list[tuple[str, str, Any, ua.VariantType, str]] = [
        ("online", "Online", False, bool_, "The line server reaches the controller."),
        ("alarms", "Alarms", [], text, "Current alarms as AB lists them (code : text)."),
        ("alarm_history", "AlarmHistory", [], text, "The alarm history (FH), newest first."),
    ]
    for port in io_ports:
        for direction, label in (("in", "Inputs"), ("out", "Outputs")):
            about = f"The 16 contacts of I/O port {port} ({label.lower()})."
            specs.append((f"io/{direction}/{port}", f"{label}{port}", [], bool_, about))
    for index in global_ints:
        about = f"Global integer variable {index} (GR)."
        specs.append((f"global/int/{index}", f"GlobalInt{index}", 0, int32, about))
    for index in global_floats:
        about = f"Global float variable {index} (GR)."
        specs.append((f"global/float/{index}", f"GlobalFloat{index}", 0.0, double, about))
    values.update(await b.vendor_variables(vendor, line, specs))
    emergency_stop = await vendor.add_method(
        b.nodeid(f"{line}.EmergencyStop"),
        b.vendor("EmergencyStop"),
        _no_call,
        [],
        [_status_argument("EmergencyStop")],
    )

    # -- the safety state: informational only, as the spec says ---------------------------
    safety_folder = await b.child(system, b.rob("SafetyStates"))
    safety = await b.instance(safety_folder, f"{line}.Safety", b.vendor(line), SAFETY_STATE_TYPE)
    await safety.write_attribute(
        AttributeIds.Description,
        ua.DataValue(
            ua.Variant(
                ua.LocalizedText(
                    "Informational only: not for safety functions (OPC 40010-1)."
                    " From the N1's alarms."
                )
            )
        ),
    )
    params = await b.child(safety, b.di("ParameterSet"))
    values["emergency_stop"] = await b.child(params, b.rob("EmergencyStop"))
    operational = await b.child(params, b.rob("OperationalMode"))
    await _set(operational, 0, ua.VariantType.Int32)  # OTHER: the host protocol does not say
    protective = await b.child(params, b.rob("ProtectiveStop"))
    # the N1 reports no protective stop: the value is a stand-in, and says so
    await protective.write_value(
        ua.DataValue(
            ua.Variant(False, ua.VariantType.Boolean),
            StatusCode=status(StatusCodes.UncertainSubstituteValue),
        )
    )

    # -- the channels: motion devices and task controls -----------------------------------
    devices = await b.child(system, b.rob("MotionDevices"))
    task_controls = await b.child(controller, b.rob("TaskControls"))
    built = {}
    for channel in channels:
        ch_info = _channel_info(info, channel)
        built[channel] = await _build_channel(
            b, devices, task_controls, channel, labels.get(channel), ch_info, model
        )
    return DeviceNodes(
        line,
        system,
        controller,
        safety,
        channels=built,
        values=values,
        methods={"EmergencyStop": emergency_stop},
        with_info=info is not None,
    )


async def _build_channel(
    b: _Builder,
    devices: Node,
    task_controls: Node,
    channel: int,
    label: str | None,
    info: ChannelInfo | None,
    model: str,
) -> ChannelNodes:
    """The channel's motion device and task control, both with the browse name
    ``Channel<n>`` (what a client's browse paths name, whatever the channel is called) and the
    configured label, if any, as their DisplayName and ComponentName (what people read)."""
    line = b.line
    base = f"{line}.ch{channel}"
    browse_name = b.vendor(f"Channel{channel}")
    shown = label or f"Channel{channel}"
    device = await b.instance(devices, f"{base}.Device", browse_name, MOTION_DEVICE_TYPE)
    await b.component_name(device, f"{base}.Device", f"{line} {shown}")
    await _identity(
        device,
        b,
        info.model if info is not None and info.model else model,
        serial=f"{line}/{channel}",
    )
    robot = info.robot_type if info is not None else RobotType.NOT_DEFINED
    category = await b.child(device, b.rob("MotionDeviceCategory"))
    await _set(category, _CATEGORY.get(robot, 0), ua.VariantType.Int32)
    params = await b.child(device, b.di("ParameterSet"))

    # TaskControl (made before the device refers to it)
    task = await b.instance(task_controls, f"{base}.Task", browse_name, TASK_CONTROL_TYPE)
    name_node = await _maybe_child(task, b.di("ComponentName"))
    if name_node is not None:
        await name_node.write_value(ua.LocalizedText(shown))
    if label:
        for node in (device, task):
            await node.write_attribute(
                AttributeIds.DisplayName, ua.DataValue(ua.Variant(ua.LocalizedText(label)))
            )
    task_params = await b.child(task, b.di("ParameterSet"))
    operation = await b.instance(
        task,
        f"{base}.Task.Operation",
        b.rob("TaskControlOperation"),
        TASK_CONTROL_OPERATION_TYPE,
    )
    machine = await b.child(operation, b.rob("TaskControlStateMachine"))
    nodes = ChannelNodes(channel, device, task, machine)
    nodes.values["speed"] = await b.child(params, b.rob("SpeedOverride"))
    nodes.values["in_control"] = await b.variable(
        params,
        f"{base}.InControl",
        b.rob("InControl"),
        False,
        ua.VariantType.Boolean,
        description="The servo is on.",
    )
    nodes.values["program"] = await b.child(task_params, b.rob("TaskProgramName"))
    nodes.values["loaded"] = await b.child(task_params, b.rob("TaskProgramLoaded"))
    nodes.values["execution_mode"] = await b.variable(
        task_params,
        f"{base}.ExecutionMode",
        b.rob("ExecutionMode"),
        0,
        ua.VariantType.Int32,
        datatype=node_id(EXECUTION_MODE_ENUMERATION, b.ns.robotics),
        description="CYCLE: a job started over the host link (CC) runs once, to its EOP.",
    )
    current_state = await b.child(machine, ua.QualifiedName("CurrentState", 0))
    nodes.values["current_state"] = current_state
    nodes.values["current_state_id"] = await b.child(current_state, ua.QualifiedName("Id", 0))
    # the spec's link from a motion device to the task control that moves it
    await b.variable(
        device,
        f"{base}.TaskControlReference",
        b.rob("TaskControlReference"),
        task.nodeid,
        ua.VariantType.NodeId,
    )
    for method, inputs in (
        ("Start", []),
        ("Stop", [_argument("StopMode", ua.VariantType.Int64, "Ignored: the N1 has one stop.")]),
        ("LoadByName", [_argument("Name", ua.VariantType.String, "The JOB file, e.g. RS.JOB")]),
    ):
        node = await machine.add_method(
            b.nodeid(f"{base}.{method}"),
            b.rob(method),
            _no_call,
            inputs,
            [_status_argument(method)],
        )
        nodes.methods[method] = node

    # axes
    axes_folder = await b.child(device, b.rob("Axes"))
    axes_in_use = info.axes_in_use if info is not None else ()
    for axis in axes_in_use:
        axis_node = await b.instance(
            axes_folder, f"{base}.Axis{axis}", b.vendor(f"Axis{axis}"), AXIS_TYPE
        )
        profile = axis_profile(robot, axis)
        await _set(await b.child(axis_node, b.rob("MotionProfile")), profile, ua.VariantType.Int32)
        axis_params = await b.child(axis_node, b.di("ParameterSet"))
        position = await b.child(axis_params, b.rob("ActualPosition"))
        units = await _maybe_child(position, ua.QualifiedName("EngineeringUnits", 0))
        unit = DEGREE if profile == ROTARY else MILLIMETRE
        if units is None:
            await position.add_property(
                b.nodeid(f"{base}.Axis{axis}.EngineeringUnits"),
                ua.QualifiedName("EngineeringUnits", 0),
                unit,
            )
        else:
            await units.write_value(unit)
        nodes.axes.append(position)

    # what the spec has no place for
    vendor = await b.folder(device, f"{base}.Robostar", "Robostar")
    bool_ = ua.VariantType.Boolean
    nodes.values.update(
        await b.vendor_variables(
            vendor,
            base,
            [
                ("origin", "OriginDone", False, bool_, "Homing (origin) is done."),
                ("in_position", "InPosition", False, bool_, "The axes are at their target."),
                ("ready", "Ready", False, bool_, "The channel is ready to run a job."),
                ("running", "Running", False, bool_, "A job or a motion is running."),
                ("alarm", "Alarm", False, bool_, "The channel has an alarm."),
                ("step", "JobStep", 0, ua.VariantType.Int32, "The step the job is at (CB)."),
                (
                    "cartesian",
                    "CartesianPosition",
                    [],
                    ua.VariantType.Double,
                    "The XY position (AC, XY), mm and degrees.",
                ),
                ("arm", "ArmForm", "", ua.VariantType.String, "SCARA arm form: LEFT, RIGHT, NONE."),
            ],
        )
    )
    return nodes


def _channel_info(info: ControllerInfo | None, channel: int) -> ChannelInfo | None:
    if info is None:
        return None
    for ch in info.channels:
        if ch.channel == channel:
            return ch
    return None


async def _identity(node: Node, b: _Builder, model: str, serial: str | None = None) -> None:
    values: dict[str, Any] = {
        "Manufacturer": ua.LocalizedText("Robostar"),
        "Model": ua.LocalizedText(model),
        "ProductCode": model,
        "SerialNumber": serial if serial is not None else b.line,
    }
    for name, value in values.items():
        child = await _maybe_child(node, b.di(name))
        if child is not None:
            await child.write_value(value)


async def _maybe_child(node: Node, name: ua.QualifiedName) -> Node | None:
    try:
        return await node.get_child([name])
    except UaStatusCodeError:
        return None


def _argument(name: str, variant: ua.VariantType, description: str) -> ua.Argument:
    argument = ua.Argument()
    argument.Name = name
    argument.DataType = node_id(variant.value)
    argument.ValueRank = -1
    argument.Description = ua.LocalizedText(description)
    return argument


def _status_argument(method: str) -> ua.Argument:
    if method == "LoadByName":
        about = "0 OK, 1 E_SystemState (refused by the controller), 3 E_ActiveAlarm"
    else:
        about = "0 OK; vendor codes: -1 refused by the controller, -3 an alarm is active"
    return _argument("Status", ua.VariantType.Int32, about)


async def _no_call(parent: ua.NodeId, *args: Any) -> ua.StatusCode:
    """Placeholder until the face binds the handler (never reached by a client)."""
    return status(StatusCodes.BadNotImplemented)
