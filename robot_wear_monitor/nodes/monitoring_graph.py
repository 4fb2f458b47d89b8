"""
The live monitoring graph without ros2cli: both nodes in one process, and the bag player.

``robot-wear-monitor live`` and ``robot-wear-monitor play`` call these for a pip-only install
(ros2cli, launch and rosbag2 are not on PyPI); on a ROS 2 host ``ros2 launch robot_wear_monitor
wear_monitor_launch.py`` and ``ros2 bag play`` do the same.
"""

from __future__ import annotations

import os
from typing import Callable, Sequence

from robot_wear_monitor.nodes.spinning import spin_nodes

GRAPH_LOGGER = 'robot_wear_monitor'


def ros_arguments(*, params_file: str | os.PathLike,
                  overrides: Sequence[tuple[str, str]] = (),
                  extra: Sequence[str] = ()) -> list[str]:
    """Return the ``rclpy.init`` arguments: params file, ``-p name:=value``, extra ROS args."""
    args = [GRAPH_LOGGER, '--ros-args', '--params-file', str(params_file)]
    for name, value in overrides:
        args += ['-p', f'{name}:={value}']
    return args + list(extra)


#: The exit status of ``live`` after SIGINT (Ctrl-C): 128 + 2, the shell's convention.
INTERRUPTED_STATUS = 130


def run_monitoring_graph(*, args: Sequence[str]) -> int:
    """
    Spin friction_experiment_node and wear_estimator_node in one executor until shutdown.

    Returns :data:`INTERRUPTED_STATUS` (130) after SIGINT (Ctrl-C), like every verb
    interrupted; 0 after SIGTERM (a service manager's stop); 2 when a node refuses its
    parameters.
    """
    # deferred import: optional extra 'ros' (the nodes import rclpy)
    from robot_wear_monitor.nodes.friction_experiment_node import FrictionExperimentNode
    from robot_wear_monitor.nodes.wear_estimator_node import WearEstimatorNode
    return spin_nodes([FrictionExperimentNode, WearEstimatorNode], logger_name=GRAPH_LOGGER,
                      args=list(args), sigint_status=INTERRUPTED_STATUS)


def run_player(bag: str | os.PathLike, *, rate: float, topics: Sequence[str] | None,
               wait_for_subscribers: int, wait_timeout_s: float, args: Sequence[str] = (),
               say: Callable[[str], None] = print) -> int:
    """
    Play ``bag`` on the graph (see :func:`~robot_wear_monitor.nodes.bag_player.play_bag`).

    Returns 0 when played, 130 when interrupted; a bad bag raises BagError (exit 2 in the CLI).
    """
    # deferred import: optional extra 'ros'
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from robot_wear_monitor.nodes.bag_player import play_bag
    rclpy.init(args=[GRAPH_LOGGER, *args])
    try:
        play_bag(bag, rate=rate, topics=topics, wait_for_subscribers=wait_for_subscribers,
                 wait_timeout_s=wait_timeout_s, say=say)
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        say('interrupted')
        return 130
    finally:
        rclpy.try_shutdown()
