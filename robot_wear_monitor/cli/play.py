"""
``robot-wear-monitor play``: a recorded bag on the live ROS 2 graph, like ros2 bag play.

Needs rclpy; the only rclpy imports stay under :mod:`robot_wear_monitor.nodes`.
"""

from __future__ import annotations

import argparse

from robot_wear_monitor.cli.options import FINITE, require_rclpy, ros_args
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.text import escaped

HELP = 'play a recorded bag on the live ROS 2 graph, like ros2 bag play (needs rclpy)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``play``."""
    parser.add_argument('bag', metavar='BAG', help='recorded ROS 2 bag (MCAP or sqlite3)')
    parser.add_argument('--rate', type=FINITE, default=1.0,
                        help='multiple of the recorded pace (default 1.0)')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC',
                        help='topics to play (default: every recorded topic)')
    parser.add_argument('--wait-for-subscribers', type=int, default=1, metavar='N',
                        help='subscribers each topic waits for before playing (default 1)')
    parser.add_argument('--wait-timeout', type=FINITE, default=10.0, metavar='S',
                        help='seconds to wait for them, then play anyway (default 10)')


def main(args: argparse.Namespace) -> int:
    """Run ``play``: publish the bag's messages at the recorded pace x ``--rate``."""
    if not args.rate > 0:
        raise InputError(f'--rate must be > 0, got {args.rate}')
    require_rclpy()  # one line naming the ros extra, not a traceback
    # deferred import: optional extra 'ros' (rclpy), not for --help
    from robot_wear_monitor.nodes.monitoring_graph import run_player
    return run_player(args.bag, rate=args.rate, topics=args.topics,
                      wait_for_subscribers=args.wait_for_subscribers,
                      wait_timeout_s=args.wait_timeout, args=ros_args(args),
                      say=lambda text: print(escaped(text), flush=True))  # bag's topics
