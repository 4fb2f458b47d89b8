"""
The nodes' ROS parameters: declared on an rclpy node, validated, listed by ``--help``.

rclpy and its interfaces are imported inside the functions, so that importing
:mod:`robot_wear_monitor.nodes` needs no ROS.
"""

from __future__ import annotations

from dataclasses import replace
import sys
from typing import Any, Mapping, Sequence
import warnings

from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring.node_config import (DEPRECATED_PARAMETERS, joint_parameters,
                                                       NODE_PARAMETERS, ParameterSpec,
                                                       PER_JOINT_PARAMETERS, validate_parameters)


def declare_parameters(node: Any, specs: Sequence[ParameterSpec]) -> dict[str, Any]:
    """
    Declare ``specs`` on an rclpy node (with descriptions) and return their raw values.

    The parameters are declared read-only with dynamic typing, so that a value of the wrong
    type (``150`` for a double) reaches
    :func:`~robot_wear_monitor.monitoring.node_config.validate_parameters` and is refused there
    with the same one-line error as in the replay, instead of an rclpy
    exception with a traceback.
    """
    # deferred import: optional extra 'ros'
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.exceptions import ParameterException

    values = {}
    for spec in specs:
        default = spec.default
        if spec.type == 'double_array':
            default = [float(v) for v in default]
        elif spec.type == 'string_array':
            default = [str(v) for v in default]
        descriptor = ParameterDescriptor(description=spec.description, read_only=spec.read_only,
                                         dynamic_typing=True)
        try:
            parameter = node.declare_parameter(spec.name, default, descriptor)
        except ParameterException as error:
            raise ParameterError(f'{node.get_name()}: {spec.name}: {error}') from None
        value = parameter.value
        if value is None and spec.type.endswith('_array'):
            value = []  # rclpy reads an empty list (`-p name:=[]`, YAML []) as NOT_SET
        values[spec.name] = list(value) if isinstance(value, (list, tuple)) or (
            hasattr(value, 'tolist')) else value
    return values


def declare_deprecated_parameters(node: Any, node_name: str) -> dict[str, Any]:
    """
    Declare the node's deprecated parameter names; return those that were set, by old name.

    Each old name
    (:data:`~robot_wear_monitor.monitoring.node_config.DEPRECATED_PARAMETERS`) is declared
    without a value, so that a parameter file or ``-p`` that still uses it reaches
    :func:`~robot_wear_monitor.monitoring.node_config.validate_parameters`, which renames it
    (see :func:`validated_with_warnings`).
    """
    # deferred import: optional extra 'ros'
    from rcl_interfaces.msg import ParameterDescriptor
    values = {}
    for old, new in DEPRECATED_PARAMETERS.get(node_name, {}).items():
        descriptor = ParameterDescriptor(description=f'deprecated name of {new}',
                                         read_only=True, dynamic_typing=True)
        value = node.declare_parameter(old, None, descriptor).value
        if value is not None:
            values[old] = value
    return values


def validated_with_warnings(node: Any, node_name: str, raw: Mapping[str, Any], *,
                            source: str) -> dict[str, Any]:
    """
    Validate a node's raw parameters; log each deprecation warning on the node's logger.

    :raises ParameterError: as :func:`~robot_wear_monitor.monitoring.node_config.
        validate_parameters`.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always', FutureWarning)
        values = validate_parameters(node_name, raw, source=source)
    for warning in caught:
        node.get_logger().warning(str(warning.message))
    return values


def declare_joint_parameters(node: Any, node_name: str, specs: Sequence[ParameterSpec],
                             values: Mapping[str, Any], joint: str) -> dict[str, Any]:
    """
    Return one monitored joint's validated parameters, declaring ``<joint>.<name>`` first.

    Every per-joint parameter of the node
    (:data:`~robot_wear_monitor.monitoring.node_config.PER_JOINT_PARAMETERS`) is declared as
    ``<joint>.<name>`` with the node's own value as default, so a parameter file's
    ``<joint>: {gear_ratio: ...}`` (rclpy flattens it) or ``-p joint_3.gear_ratio:=120.0``
    reaches the joint, also for a joint first seen at run time (``joints: [all]``), and with
    ``joint`` alone as in the replay.
    """
    source = f'{node.get_name()} parameters'
    by_name = {spec.name: spec for spec in specs}
    joint_specs = [replace(by_name[name], name=f'{joint}.{name}', default=values[name])
                   for name in PER_JOINT_PARAMETERS[node_name]]
    raw = declare_parameters(node, joint_specs)
    return joint_parameters(node_name, {**values, **raw}, joint, source=source)


def help_requested(args: Sequence[str] | None) -> bool:
    """Return True when the process arguments before ``--ros-args`` ask for ``-h``/``--help``."""
    argv = list(sys.argv[1:] if args is None else args[1:] if args and not str(
        args[0]).startswith('-') else args)
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    return any(a in ('-h', '--help') for a in argv)


def node_help(node: str) -> str:
    """Return the ``--help`` text of a node executable: usage and its declared parameters."""
    lines = [f'usage: {node} [--ros-args --params-file FILE -p NAME:=VALUE ...]', '',
             f'The robot_wear_monitor node {node} (ROS 2 Jazzy).  Parameters (type, default):']
    for spec in NODE_PARAMETERS.get(node, ()):
        lines.append(f'  {spec.name} ({spec.type}, default {spec.default!r})')
        lines.append(f'      {spec.description}')
    lines += ['', 'Packaged parameter file: config/wear_monitor.yaml (robot-wear-monitor live '
              '--help runs the whole graph).']
    return '\n'.join(lines)
