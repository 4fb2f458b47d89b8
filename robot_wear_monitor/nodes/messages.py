"""
The rclpy message classes of the nodes, as a :class:`MessageKit`.

The ROS message packages are imported when :func:`message_kit` is called, not with the module,
so that importing :mod:`robot_wear_monitor.nodes` needs no ROS.
"""

from __future__ import annotations

import importlib
from typing import Any

from robot_wear_monitor.recordings.messages import MessageKit, rclpy_kit


def _import_message(type_name: str) -> Any:
    """Return the rclpy class of ``pkg/msg/Name`` (imported on first use)."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


def message_kit() -> MessageKit:
    """
    Return the :class:`MessageKit` of the rclpy message classes the nodes use.

    The types every node uses are imported at once; others (trajectory_msgs for the
    friction_experiment_runner) on first use, so that a node never needs a message package
    it does not publish.
    """
    # deferred import: optional extra 'ros'
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import (Bool, Float64, Float64MultiArray, Header, MultiArrayDimension,
                              MultiArrayLayout)

    classes = {
        'builtin_interfaces/msg/Time': Time,
        'std_msgs/msg/Header': Header,
        'std_msgs/msg/Bool': Bool,
        'std_msgs/msg/Float64': Float64,
        'std_msgs/msg/Float64MultiArray': Float64MultiArray,
        'std_msgs/msg/MultiArrayLayout': MultiArrayLayout,
        'std_msgs/msg/MultiArrayDimension': MultiArrayDimension,
        'sensor_msgs/msg/JointState': JointState,
        'sensor_msgs/msg/Temperature': Temperature,
        'diagnostic_msgs/msg/DiagnosticArray': DiagnosticArray,
        'diagnostic_msgs/msg/DiagnosticStatus': DiagnosticStatus,
        'diagnostic_msgs/msg/KeyValue': KeyValue,
    }

    def get_type(type_name: str) -> Any:
        if type_name not in classes:
            classes[type_name] = _import_message(type_name)
        return classes[type_name]
    return rclpy_kit(get_type)
