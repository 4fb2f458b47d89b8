"""
The rclpy nodes of the wear monitor: thin shells over the services of ``monitoring/``.

Only the modules of this package import rclpy and the ROS message packages.  Importing the
package itself imports nothing from ROS, so the core stays usable without it.

The node runtime lives in modules of its own; this package only hands their names on:

* :mod:`~robot_wear_monitor.nodes.messages`: :func:`message_kit`, the rclpy message classes;
* :mod:`~robot_wear_monitor.nodes.parameters`: :func:`declare_parameters`,
  :func:`declare_joint_parameters`, :func:`help_requested`, :func:`node_help`;
* :mod:`~robot_wear_monitor.nodes.node_helpers`: :func:`node_time_s`,
  :func:`log_rejection_report`;
* :mod:`~robot_wear_monitor.nodes.spinning`: :func:`spin_node`, :func:`spin_nodes`,
  :data:`SIGNAL_POLL_S`.
"""

from robot_wear_monitor.nodes.messages import message_kit
from robot_wear_monitor.nodes.node_helpers import log_rejection_report, node_time_s
from robot_wear_monitor.nodes.parameters import (declare_joint_parameters, declare_parameters,
                                                 help_requested, node_help)
from robot_wear_monitor.nodes.spinning import SIGNAL_POLL_S, spin_node, spin_nodes

__all__ = ['declare_joint_parameters', 'declare_parameters', 'help_requested',
           'log_rejection_report', 'message_kit', 'node_help', 'node_time_s', 'SIGNAL_POLL_S',
           'spin_node', 'spin_nodes']
