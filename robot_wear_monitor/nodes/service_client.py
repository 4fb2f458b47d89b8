"""
Call the monitor's std_srvs/Trigger services from Python: ``ros2 service call`` without ros2cli.

A pip-only host has rclpy but no ``ros2`` command; :func:`call_trigger` finds the first of the
candidate service names that the graph offers, calls it once and returns the node's answer.
"""

from __future__ import annotations

from dataclasses import dataclass
import time
from typing import Sequence

#: The name of the short-lived client node.
CLIENT_NODE = 'robot_wear_monitor_call'


@dataclass(frozen=True)
class TriggerAnswer:
    """What the service said: its ``success`` and ``message``, and the service's full name."""

    service: str
    success: bool
    message: str


class ServiceNotFound(Exception):
    """None of the candidate services appeared on the graph in time."""


def call_trigger(*, candidates: Sequence[str], timeout_s: float,
                 args: Sequence[str] = ()) -> TriggerAnswer:
    """
    Call the first of ``candidates`` (full service names) the graph offers; return its answer.

    ``timeout_s`` bounds the wait for the service and, again, for the answer [s]; ``args`` are
    ROS arguments for ``rclpy.init`` (``--ros-args ...``).

    :raises ServiceNotFound: no candidate appeared within ``timeout_s`` (the message lists them and
        the Trigger services that the graph does offer).
    :raises TimeoutError: the service did not answer within ``timeout_s``.

    """
    # deferred import: optional extra 'ros'
    import rclpy
    from std_srvs.srv import Trigger

    context = rclpy.Context()
    rclpy.init(args=[CLIENT_NODE, *args], context=context)
    node = rclpy.create_node(CLIENT_NODE, context=context)
    try:
        deadline = time.monotonic() + timeout_s
        found = None
        offered: list[str] = []
        while found is None and time.monotonic() < deadline:
            offered = [name for name, types in node.get_service_names_and_types()
                       if 'std_srvs/srv/Trigger' in types]
            found = next((name for name in candidates if name in offered), None)
            if found is None:
                time.sleep(0.1)
        if found is None:
            raise ServiceNotFound(
                f'no service {" or ".join(candidates)} within {timeout_s:g} s (is the node '
                f'running on this ROS domain?); Trigger services offered: '
                f'{", ".join(sorted(offered)) or "none"}')
        client = node.create_client(Trigger, found)
        if not client.wait_for_service(timeout_sec=max(deadline - time.monotonic(), 0.1)):
            raise ServiceNotFound(f'{found}: the service went away before the call')
        future = client.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=timeout_s,
                                         executor=rclpy.executors.SingleThreadedExecutor(
                                             context=context))
        if not future.done() or future.result() is None:
            raise TimeoutError(f'{found}: no answer within {timeout_s:g} s')
        response = future.result()
        return TriggerAnswer(service=found, success=bool(response.success),
                             message=str(response.message))
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
