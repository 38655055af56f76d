"""The address space: ``Objects/RC233Gateway/Loops/<loop>/Controllers/<controller>/Axes/<axis>``.

Browse names come from the configuration (a name, else the id). Node ids are strings that
say where a value is, ``ns=<cell>;s=<id>/<Variable>`` (``main.1.1/ActualPosition``), so a PLC
project can name them without browsing. Per axis the variables of ``values.AXIS_VARIABLES``,
``ActualPosition`` with ``EngineeringUnits`` and, with soft limits, ``EURange``; per controller
``values.CONTROLLER_VARIABLES`` and a nameplate after OPC 40001-1 ``MachineIdentification``
(``Identification``: Manufacturer, Model, SoftwareRevision); per loop its line and counters.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from asyncua import Node, Server, ua

from gateway.opcua.values import (
    AXIS_VARIABLES,
    CONTROLLER_VARIABLES,
    COUNTER_VARIABLES,
    LOOP_VARIABLES,
)
from gateway.service.topology import AxisRef, ControllerRef, Topology

__all__ = ["NAMESPACE", "Nodes", "Variable", "build"]

#: The namespace of the cell's nodes.
NAMESPACE = "urn:rc233-gateway:cell"
MANUFACTURER = "RORZE"
MODEL = "RC-233"


@dataclass(frozen=True)
class Variable:
    """One variable node and the variant type its values are written as."""

    node: ua.NodeId
    variant: ua.VariantType


@dataclass
class Nodes:
    """The nodes built: variables by owner id (loop name, controller id, axis id) and name,
    and the objects methods are called on."""

    index: int
    variables: dict[str, dict[str, Variable]] = field(default_factory=dict)
    loops: dict[ua.NodeId, str] = field(default_factory=dict)
    controllers: dict[ua.NodeId, str] = field(default_factory=dict)
    axes: dict[ua.NodeId, str] = field(default_factory=dict)
    objects: dict[str, Node] = field(default_factory=dict)

    def node_id(self, owner: str, name: str) -> ua.NodeId:
        """The node id of variable ``name`` of ``owner``."""
        return ua.NodeId(f"{owner}/{name}", self.index)


async def _variables(
    nodes: Nodes, parent: Node, owner: str, table: dict[str, ua.VariantType]
) -> dict[str, Node]:
    held = nodes.variables.setdefault(owner, {})
    made: dict[str, Node] = {}
    for name, variant in table.items():
        node_id = nodes.node_id(owner, name)
        var = await parent.add_variable(
            node_id,
            ua.QualifiedName(name.rsplit("/", 1)[-1], nodes.index),
            ua.Variant(None),
            variant,
        )
        await var.write_attribute(
            ua.AttributeIds.DataType,
            ua.DataValue(ua.Variant(ua.NodeId(variant.value), ua.VariantType.NodeId)),
        )
        # Bad until the first reading: a client that reads at once is told it waits.
        await var.write_value(
            ua.DataValue(ua.Variant(None), ua.StatusCode(ua.StatusCodes.BadWaitingForInitialData))
        )
        held[name] = Variable(node_id, variant)
        made[name] = var
    return made


def _name(ident: str, name: str | None) -> str:
    return name or ident


async def _axis(nodes: Nodes, folder: Node, ref: AxisRef) -> Node:
    idx = nodes.index
    obj = await folder.add_object(
        ua.NodeId(ref.id, idx), ua.QualifiedName(_name(ref.id, ref.name), idx)
    )
    params = await obj.add_object(
        ua.NodeId(f"{ref.id}/ParameterSet", idx), ua.QualifiedName("ParameterSet", idx)
    )
    position = (await _variables(nodes, params, ref.id, AXIS_VARIABLES))["ActualPosition"]
    unit = ua.EUInformation(
        NamespaceUri="rc233-gateway",
        UnitId=-1,
        DisplayName=ua.LocalizedText(ref.unit),
        Description=ua.LocalizedText(ref.unit),
    )
    await position.add_property(idx, "EngineeringUnits", unit)
    if ref.soft_min is not None or ref.soft_max is not None:
        low = ref.soft_min if ref.soft_min is not None else float("-inf")
        high = ref.soft_max if ref.soft_max is not None else float("inf")
        await position.add_property(idx, "EURange", ua.Range(Low=low, High=high))
    nodes.axes[obj.nodeid] = ref.id
    nodes.objects[ref.id] = obj
    return obj


async def _controller(nodes: Nodes, folder: Node, ref: ControllerRef) -> Node:
    idx = nodes.index
    obj = await folder.add_object(
        ua.NodeId(ref.id, idx), ua.QualifiedName(_name(ref.id, ref.name), idx)
    )
    await _variables(nodes, obj, ref.id, CONTROLLER_VARIABLES)
    plate = await obj.add_object(
        ua.NodeId(f"{ref.id}/Identification", idx), ua.QualifiedName("Identification", idx)
    )
    await plate.add_property(
        ua.NodeId(f"{ref.id}/Identification/Manufacturer", idx),
        ua.QualifiedName("Manufacturer", idx),
        MANUFACTURER,
    )
    await plate.add_property(
        ua.NodeId(f"{ref.id}/Identification/Model", idx), ua.QualifiedName("Model", idx), MODEL
    )
    await _variables(
        nodes, plate, f"{ref.id}/Identification", {"SoftwareRevision": ua.VariantType.String}
    )
    axes = await obj.add_folder(ua.NodeId(f"{ref.id}/Axes", idx), ua.QualifiedName("Axes", idx))
    for axis in ref.axes:
        await _axis(nodes, axes, axis)
    nodes.controllers[obj.nodeid] = ref.id
    nodes.objects[ref.id] = obj
    return obj


async def build(server: Server, topology: Topology) -> Nodes:
    """Add the cell's nodes to ``server`` (before it starts)."""
    idx = await server.register_namespace(NAMESPACE)
    nodes = Nodes(idx)
    root = await server.nodes.objects.add_object(
        ua.NodeId("RC233Gateway", idx), ua.QualifiedName("RC233Gateway", idx)
    )
    loops = await root.add_folder(ua.NodeId("Loops", idx), ua.QualifiedName("Loops", idx))
    for loop in topology.loops():
        obj = await loops.add_object(
            ua.NodeId(f"loop:{loop.name}", idx), ua.QualifiedName(loop.name, idx)
        )
        await _variables(nodes, obj, f"loop:{loop.name}", LOOP_VARIABLES)
        counters = await obj.add_object(
            ua.NodeId(f"loop:{loop.name}/Counters", idx), ua.QualifiedName("Counters", idx)
        )
        await _variables(
            nodes,
            counters,
            f"loop:{loop.name}",
            {f"Counters/{k}": v for k, v in COUNTER_VARIABLES.items()},
        )
        folder = await obj.add_folder(
            ua.NodeId(f"loop:{loop.name}/Controllers", idx), ua.QualifiedName("Controllers", idx)
        )
        for ctl in loop.controllers:
            await _controller(nodes, folder, ctl)
        nodes.loops[obj.nodeid] = loop.name
        nodes.objects[f"loop:{loop.name}"] = obj
    return nodes
