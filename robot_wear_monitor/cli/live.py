"""
``robot-wear-monitor live``: both monitoring nodes on the live ROS 2 graph in one process.

Needs rclpy; the only rclpy imports stay under :mod:`robot_wear_monitor.nodes`
(:mod:`robot_wear_monitor.nodes.monitoring_graph`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

from robot_wear_monitor.cli.options import (add_history, add_robot, PROG, require_rclpy,
                                            ros_args, warn_deprecated)
from robot_wear_monitor.errors import InputError

HELP = 'run both monitoring nodes on the live ROS 2 graph in one process (needs rclpy)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``live``."""
    parser.add_argument('--config', metavar='YAML',
                        help='ROS 2 parameter file of both nodes (default: the packaged '
                             'config/wear_monitor.yaml)')
    parser.add_argument('--params-file', metavar='YAML', dest='legacy_config',
                        help='deprecated spelling of --config')
    parser.add_argument('--joint', help='joint to monitor (overrides the config)')
    add_history(parser, help_text='wear history (overrides the config)')
    add_robot(parser, help_text='robot_id of the estimator: its key in a fleet history and '
                                'in /diagnostics (overrides the config)')
    parser.add_argument('--params', metavar='FILE',
                        help='friction-model parameter-set YAML (overrides the config)')
    parser.add_argument('--parameter-set', metavar='FILE', dest='legacy_params',
                        help='deprecated spelling of --params')


def _renamed(new: str | None, old: str | None, *, spelling: tuple[str, str]) -> str | None:
    """Return the value of an option given by its new or its deprecated spelling."""
    if old is None:
        return new
    warn_deprecated('live', spelling[0], spelling[1])
    if new is not None and new != old:
        raise InputError(f'{spelling[0]} and {spelling[1]}: give one ({spelling[0]} is '
                         'deprecated)')
    return old


def main(args: argparse.Namespace) -> int:
    """Run ``live`` until Ctrl-C; a bad parameter file is refused before any node starts."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.monitoring.node_config import (default_node_config_file,
                                                           FRICTION_EXPERIMENT_NODE,
                                                           load_node_parameters,
                                                           WEAR_ESTIMATOR_NODE)
    config = _renamed(args.config, args.legacy_config, spelling=('--params-file', '--config'))
    parameter_set = _renamed(args.params, args.legacy_params,
                             spelling=('--parameter-set', '--params'))
    params_file = Path(config) if config else default_node_config_file()
    overrides = []
    if args.joint:
        overrides.append(('joint', args.joint))
    if args.history:
        overrides.append(('history_file', args.history))
    if args.robot:
        overrides.append(('robot_id', args.robot))
    if parameter_set:
        overrides.append(('parameter_set_file', parameter_set))
    # Refuse a bad file here with one line, before any node starts.
    load_node_parameters(FRICTION_EXPERIMENT_NODE, params_file,
                         overrides={k: v for k, v in overrides if k == 'joint'})
    load_node_parameters(WEAR_ESTIMATOR_NODE, params_file, overrides=dict(overrides))
    require_rclpy()  # one line naming the ros extra, not a traceback
    # deferred import: optional extra 'ros' (rclpy), not for --help
    from robot_wear_monitor.nodes.monitoring_graph import ros_arguments, run_monitoring_graph
    print(f'{PROG} live: friction_experiment_node + wear_estimator_node, parameters from '
          f'{params_file}; Ctrl-C stops', file=sys.stderr, flush=True)
    return run_monitoring_graph(args=ros_arguments(params_file=params_file, overrides=overrides,
                                                   extra=ros_args(args)))
