"""
The rclpy nodes of the wear monitor: thin shells over the services of ``monitoring/``.

Only the modules of this package import rclpy and the ROS message packages.  Importing the
package itself imports nothing from ROS, so the core stays usable without it.
"""

from __future__ import annotations

import signal
import threading
from typing import Any, Callable, Mapping, Sequence

from robot_wear_monitor.monitoring.node_config import ParameterSpec
from robot_wear_monitor.recordings.messages import MessageKit, rclpy_kit


def _import_message(type_name: str) -> Any:
    """Return the rclpy class of ``pkg/msg/Name`` (imported on first use)."""
    import importlib
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


def message_kit() -> MessageKit:
    """
    Return the :class:`MessageKit` of the rclpy message classes the nodes use.

    The types every node uses are imported at once; others (trajectory_msgs for the
    friction_experiment_runner) on first use, so that a node never needs a message package
    it does not publish.
    """
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


def declare_parameters(node: Any, specs: Sequence[ParameterSpec]) -> dict[str, Any]:
    """
    Declare ``specs`` on an rclpy node (with descriptions) and return their raw values.

    The parameters are declared read-only with dynamic typing, so that a value of the wrong
    type (``150`` for a double) reaches
    :func:`~robot_wear_monitor.monitoring.node_config.validate_parameters` and is refused there
    with the same one-line error as in the replay, instead of an rclpy
    exception with a traceback.
    """
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.exceptions import ParameterException
    from robot_wear_monitor.model.params import ParameterError

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
    from dataclasses import replace

    from robot_wear_monitor.monitoring.node_config import (joint_parameters,
                                                           PER_JOINT_PARAMETERS)
    source = f'{node.get_name()} parameters'
    by_name = {spec.name: spec for spec in specs}
    joint_specs = [replace(by_name[name], name=f'{joint}.{name}', default=values[name])
                   for name in PER_JOINT_PARAMETERS[node_name]]
    raw = declare_parameters(node, joint_specs)
    return joint_parameters(node_name, {**values, **raw}, joint, source=source)


def node_time_s(node: Any) -> float:
    """Return the node's clock time [s] (ROS time: simulated under ``use_sim_time``)."""
    return node.get_clock().now().nanoseconds * 1e-9


def log_rejection_report(logger: Any, report: tuple[str, bool] | None) -> None:
    """
    Log a :class:`~robot_wear_monitor.monitoring.diagnostics.RejectionLog` report, if any.

    Malformed inputs are logged as WARN, the routine rejections of the protocol as INFO (one
    call site per severity: rclpy refuses a call site that changes its severity).
    """
    if report is None:
        return
    text, defective = report
    if defective:
        logger.warning(text)
    else:
        logger.info(text)


def help_requested(args: Sequence[str] | None) -> bool:
    """Return True when the process arguments before ``--ros-args`` ask for ``-h``/``--help``."""
    import sys
    argv = list(sys.argv[1:] if args is None else args[1:] if args and not str(
        args[0]).startswith('-') else args)
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    return any(a in ('-h', '--help') for a in argv)


def node_help(node: str) -> str:
    """Return the ``--help`` text of a node executable: usage and its declared parameters."""
    from robot_wear_monitor.monitoring.node_config import NODE_PARAMETERS
    lines = [f'usage: {node} [--ros-args --params-file FILE -p NAME:=VALUE ...]', '',
             f'The robot_wear_monitor node {node} (ROS 2 Jazzy).  Parameters (type, default):']
    for spec in NODE_PARAMETERS.get(node, ()):
        lines.append(f'  {spec.name} ({spec.type}, default {spec.default!r})')
        lines.append(f'      {spec.description}')
    lines += ['', 'Packaged parameter file: config/wear_monitor.yaml (robot-wear-monitor live '
              '--help runs the whole graph).']
    return '\n'.join(lines)


def spin_node(node_factory: Callable[[], Any], *, logger_name: str, args=None) -> int:
    """
    Init rclpy, build the node and spin it until shutdown (the Jazzy try/finally pattern).

    Returns 0 after a normal shutdown (SIGINT, SIGTERM) and 2 when the node refuses its
    parameters (an :class:`~robot_wear_monitor.errors.InputError`, logged as one fatal line).
    """
    return spin_nodes([node_factory], logger_name=logger_name, args=args)


def spin_nodes(node_factories: Sequence[Callable[[], Any]], *, logger_name: str,
               args=None) -> int:
    """
    Init rclpy, build the nodes and spin them in one executor until shutdown.

    All nodes share one SingleThreadedExecutor: rclpy's MultiThreadedExecutor costs more per
    callback than it saves here, and lost /joint_states messages at 1 kHz (measured).  An
    estimate (15-60 ms, after the estimator's warm-up) holds the 1 kHz callbacks back by at
    most that long, well within the /joint_states queue (1 s).  BLAS runs on one thread
    (:mod:`robot_wear_monitor.blas_threads`).
    ``args`` are the process arguments (``--ros-args ...`` included) as for ``rclpy.init``.
    Returns 0 after a normal shutdown and 2 when a node refuses its parameters (nothing is
    spun then; the nodes already built are destroyed).

    SIGINT and SIGTERM stop the spin (within :data:`SIGNAL_POLL_S`) and the nodes are destroyed
    *before* the context shuts down.  rclpy's own signal handler shuts the context down first,
    and destroying a Fast DDS publisher of a shut-down context crashed the process now and then
    (SIGSEGV in ``Publisher.destroy``, 1 run in 8 of the two-joint graph test).  A second
    signal during the shutdown interrupts it as Python does by default.
    """
    if help_requested(args):  # answer --help without starting anything
        print(node_help(logger_name))
        return 0
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions
    from robot_wear_monitor.blas_threads import use_single_blas_thread
    from robot_wear_monitor.errors import InputError

    use_single_blas_thread()
    # signal handlers can only be set in the main thread; elsewhere rclpy's handle the signals
    in_main_thread = threading.current_thread() is threading.main_thread()
    rclpy.init(args=args, signal_handler_options=(
        SignalHandlerOptions.NO if in_main_thread else None))
    stop = _StopOnSignal(install=in_main_thread)
    nodes: list[Any] = []
    try:
        try:
            for factory in node_factories:
                nodes.append(factory())
        except InputError as error:
            rclpy.logging.get_logger(logger_name).fatal(str(error))
            return 2
        executor = SingleThreadedExecutor()
        for node in nodes:
            executor.add_node(node)
        try:
            while not stop.requested and rclpy.ok():
                executor.spin_once(timeout_sec=SIGNAL_POLL_S)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            executor.shutdown()
        return 0
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        stop.restore()


SIGNAL_POLL_S = 0.1
"""Longest wait of the executor before it looks for a stop signal (s)."""


class _StopOnSignal:
    """Record SIGINT and SIGTERM instead of shutting the ROS context down at once."""

    def __init__(self, *, install: bool = True) -> None:
        self.requested = False
        self._previous: dict[int, Any] = {
            number: signal.signal(number, self._on_signal)
            for number in (signal.SIGINT, signal.SIGTERM)} if install else {}

    def _on_signal(self, number: int, frame: Any) -> None:
        self.requested = True
        signal.signal(number, self._previous.get(number) or signal.SIG_DFL)  # a 2nd one interrupts

    def restore(self) -> None:
        """Put the signal handlers back as they were before."""
        for number, handler in self._previous.items():
            signal.signal(number, handler if handler is not None else signal.SIG_DFL)
