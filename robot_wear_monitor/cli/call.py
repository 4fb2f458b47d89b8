"""
``robot-wear-monitor call``: the monitor's services without ros2cli (start, abort, reset-alarm).

``ros2 service call`` needs the ros2cli tools, which a pip-only host does not have; this verb
calls the same std_srvs/Trigger services with rclpy (:mod:`robot_wear_monitor.nodes.
service_client`) and prints the node's answer.
"""

from __future__ import annotations

import argparse

from robot_wear_monitor.cli.options import FINITE, require_rclpy, ros_args
from robot_wear_monitor.errors import InputError

HELP = ("call the monitor's services: start or abort the friction experiment, reset the wear "
        'alarm after maintenance (needs rclpy; like ros2 service call)')

#: action -> (node, service relative to the node)
ACTIONS = {
    'start': ('friction_experiment_runner', 'start'),
    'abort': ('friction_experiment_runner', 'abort'),
    'reset-alarm': ('wear_estimator_node', 'reset_alarm'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``call``."""
    parser.add_argument('action', choices=tuple(ACTIONS),
                        help="start / abort: the runner's friction experiment; reset-alarm: "
                             "clear a joint's latched wear alarm after maintenance")
    parser.add_argument('--robot', metavar='ROBOT',
                        help='the robot (its robot_id) when several share one ROS graph: its '
                             'nodes run in the namespace /ROBOT (ros2 run ... --ros-args -r '
                             '__ns:=/ROBOT); default: no namespace')
    parser.add_argument('--joint', metavar='NAME',
                        help='reset-alarm of a node that monitors several joints: the joint '
                             '(its service is <node>/<joint>/reset_alarm)')
    parser.add_argument('--node', metavar='NAME',
                        help="the node's name when it was renamed (default: "
                             'friction_experiment_runner or wear_estimator_node)')
    parser.add_argument('--timeout', type=FINITE, default=10.0, metavar='S',
                        help='seconds to wait for the service and for its answer (default 10)')


def service_candidates(*, action: str, robot: str | None = None, joint: str | None = None,
                       node: str | None = None) -> list[str]:
    """Return the full service names to try for ``action``, most specific first."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.monitoring.joints import output_topic
    default_node, service = ACTIONS[action]
    namespace = '/' + robot.strip('/') if robot and robot.strip('/') else ''
    base = f'{namespace}/{node or default_node}'
    names = []
    if joint is not None:
        if action != 'reset-alarm':
            raise InputError('--joint is for reset-alarm (the runner has one start service)')
        names.append(f'{base}/{output_topic(service, joint, per_joint=True)}')
    names.append(f'{base}/{service}')
    return names


def main(args: argparse.Namespace) -> int:
    """Run ``call``: exit 0 when the service reports success, 1 when it refuses, 2 if absent."""
    if not 0 < args.timeout <= 3600:
        raise InputError(f'--timeout must be in (0, 3600] s, got {args.timeout:g}')
    candidates = service_candidates(action=args.action, robot=args.robot, joint=args.joint,
                                    node=args.node)
    require_rclpy()  # one line naming the ros extra, not a traceback
    # deferred import: optional extra 'ros' (rclpy), not for --help
    from robot_wear_monitor.nodes.service_client import call_trigger, ServiceNotFound
    try:
        answer = call_trigger(candidates=candidates, timeout_s=args.timeout,
                              args=ros_args(args))
    except (ServiceNotFound, TimeoutError) as error:
        raise InputError(str(error)) from None
    print(f'{answer.service}: {"success" if answer.success else "refused"}: {answer.message}')
    return 0 if answer.success else 1
