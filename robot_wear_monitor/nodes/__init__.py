"""The rclpy nodes of the wear monitor: thin shells over ``robot_wear_monitor.service``.

Only the modules of this package import rclpy and the ROS message packages.  Importing the
package itself imports nothing from ROS, so the core stays usable without it.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

from ..messages import MessageKit, rclpy_kit
from ..node_config import ParameterSpec


def message_kit() -> MessageKit:
    """Return the :class:`MessageKit` of the rclpy message classes the nodes use."""
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import Bool, Float64, Header

    classes = {
        'builtin_interfaces/msg/Time': Time,
        'std_msgs/msg/Header': Header,
        'std_msgs/msg/Bool': Bool,
        'std_msgs/msg/Float64': Float64,
        'sensor_msgs/msg/JointState': JointState,
        'sensor_msgs/msg/Temperature': Temperature,
        'diagnostic_msgs/msg/DiagnosticArray': DiagnosticArray,
        'diagnostic_msgs/msg/DiagnosticStatus': DiagnosticStatus,
        'diagnostic_msgs/msg/KeyValue': KeyValue,
    }
    return rclpy_kit(classes.__getitem__)


def declare_parameters(node: Any, specs: Sequence[ParameterSpec]) -> dict[str, Any]:
    """Declare ``specs`` on an rclpy node (with descriptions) and return their raw values."""
    from rcl_interfaces.msg import ParameterDescriptor

    values = {}
    for spec in specs:
        default = spec.default
        if spec.type == 'double_array':
            default = [float(v) for v in default]
        descriptor = ParameterDescriptor(description=spec.description, read_only=spec.read_only)
        parameter = node.declare_parameter(spec.name, default, descriptor)
        value = parameter.value
        values[spec.name] = list(value) if spec.type == 'double_array' else value
    return values


def spin_node(node_factory: Callable[[], Any], *, logger_name: str, args=None) -> int:
    """Init rclpy, build the node and spin it until shutdown (the Jazzy try/finally pattern).

    Returns 0 after a normal shutdown and 2 when the node refuses its parameters
    (an :class:`~robot_wear_monitor.errors.InputError`, logged as fatal).
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException

    from ..errors import InputError

    rclpy.init(args=args)
    try:
        node = node_factory()
    except InputError as error:
        rclpy.logging.get_logger(logger_name).fatal(str(error))
        rclpy.try_shutdown()
        return 2
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
