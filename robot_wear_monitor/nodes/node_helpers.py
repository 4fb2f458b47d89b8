"""
What a node shell calls at run time besides its service.

Its clock time (ROS time, simulated under ``use_sim_time``) and its log of rejected inputs.
"""

from __future__ import annotations

from typing import Any


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
