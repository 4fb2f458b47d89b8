"""
Running nodes: rclpy's context, one executor, the stop on SIGINT/SIGTERM and the exit status.

rclpy is imported inside :func:`spin_nodes`, so that importing :mod:`robot_wear_monitor.nodes`
needs no ROS.
"""

from __future__ import annotations

import signal
import threading
from types import ModuleType
from typing import Any, Callable, Sequence

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.nodes.parameters import help_requested, node_help


def import_rclpy() -> ModuleType:
    """
    Return rclpy, imported here (the verbs that need it ask first, for a one-line error).

    :raises ImportError: neither the ``ros`` extra nor a sourced ROS 2 setup provides it.
    """
    # deferred import: optional extra 'ros'
    import rclpy
    return rclpy


def spin_node(node_factory: Callable[[], Any], *, logger_name: str, args=None) -> int:
    """
    Init rclpy, build the node and spin it until shutdown (the Jazzy try/finally pattern).

    Returns 0 after a normal shutdown (SIGINT, SIGTERM) and 2 when the node refuses its
    parameters (an :class:`~robot_wear_monitor.errors.InputError`, logged as one fatal line).
    """
    return spin_nodes([node_factory], logger_name=logger_name, args=args)


def spin_nodes(node_factories: Sequence[Callable[[], Any]], *, logger_name: str,
               args=None, sigint_status: int = 0) -> int:
    """
    Init rclpy, build the nodes and spin them in one executor until shutdown.

    All nodes share one SingleThreadedExecutor: rclpy's MultiThreadedExecutor costs more per
    callback than it saves here, and lost /joint_states messages at 1 kHz (measured).  An
    estimate (15-60 ms, after the estimator's warm-up) holds the friction node's drain of
    /joint_states back by at most that long, well within the queue (1000 messages: 1 s at
    1 kHz, 0.25 s at 4 kHz, with the 0.05 s drain period).  BLAS runs on one thread
    (:mod:`robot_wear_monitor.blas_threads`).
    ``args`` are the process arguments (``--ros-args ...`` included) as for ``rclpy.init``.
    Returns 0 after a normal shutdown (SIGTERM, the context shut down), ``sigint_status``
    after SIGINT (Ctrl-C; the node executables: 0, what ``ros2 launch`` expects of a node it
    stops; ``robot-wear-monitor live``: 130, the shell's convention) and 2 when a node refuses
    its parameters (nothing is spun then; the nodes already built are destroyed).

    SIGINT and SIGTERM stop the spin (within :data:`SIGNAL_POLL_S`) and the nodes are destroyed
    *before* the context shuts down.  rclpy's own signal handler shuts the context down first,
    and destroying a Fast DDS publisher of a shut-down context crashed the process now and then
    (SIGSEGV in ``Publisher.destroy``, 1 run in 8 of the two-joint graph test).  A second
    signal during the shutdown interrupts it as Python does by default.
    """
    if help_requested(args):  # answer --help without starting anything
        print(node_help(logger_name))
        return 0
    # deferred import: optional extra 'ros'
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions
    from robot_wear_monitor.blas_threads import use_single_blas_thread

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
        except KeyboardInterrupt:  # SIGINT under Python's own handler (not the main thread)
            return sigint_status
        except ExternalShutdownException:
            pass
        finally:
            executor.shutdown()
        return sigint_status if stop.signal == signal.SIGINT else 0
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
        #: the signal that stopped the spin (None: none yet)
        self.signal: int | None = None
        self._previous: dict[int, Any] = {
            number: signal.signal(number, self._on_signal)
            for number in (signal.SIGINT, signal.SIGTERM)} if install else {}

    def _on_signal(self, number: int, frame: Any) -> None:
        self.requested = True
        self.signal = number
        signal.signal(number, self._previous.get(number) or signal.SIG_DFL)  # a 2nd one interrupts

    def restore(self) -> None:
        """Put the signal handlers back as they were before."""
        for number, handler in self._previous.items():
            signal.signal(number, handler if handler is not None else signal.SIG_DFL)
