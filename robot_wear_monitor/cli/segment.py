"""
``robot-wear-monitor segment``: friction levels of eq. (3) from a bag or raw CSV (CSV out).

The segmentation itself is :mod:`robot_wear_monitor.monitoring.segment`; this verb prints the
CSV (or writes ``--out``) and one report line per joint on stderr.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.cli.level_options import add_raw_reading, RAW_STANDSTILL_DEFAULT
from robot_wear_monitor.cli.options import (add_config, add_gear_ratio_and_torque_scale,
                                            add_joints, add_robot, BAG_SCALE_DEFAULT,
                                            BAG_TORQUE_SCALE_DEFAULT, joint_selection,
                                            parse_float_list, STANDSTILL_SPEED)
from robot_wear_monitor.cli.outputs import to_terminal
from robot_wear_monitor.cli.replay import joint_summary_line
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.text import escaped

HELP = 'segment a bag or raw CSV into friction levels of eq. (3) (CSV out)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``segment``."""
    parser.add_argument('data', metavar='DATA',
                        help='ROS 2 bag folder, a raw CSV(.gz) with t_s,q_rad,dq_rad_s,'
                             'tau_measured_Nm columns, or a folder of such raw runs (any '
                             'names: one joint unless named joint<k>_... or with a joint '
                             'column)')
    add_joints(parser, help_text='joint in the bag; several as NAME,NAME or repeated --joint, '
                                 'or "all" (default: the node config\'s joint, joint_2); raw '
                                 'runs: the name of the joint of runs that name none '
                                 "(default: their folder's name)")
    parser.add_argument('--topic', default='/joint_states', help='JointState topic')
    add_gear_ratio_and_torque_scale(parser, gear_default=BAG_SCALE_DEFAULT,
                                    scale_default=BAG_TORQUE_SCALE_DEFAULT)
    add_config(parser, help_text='node parameter file for a bag (default: the packaged '
                                 'wear_monitor.yaml; per-joint values as <joint>: {...})')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        help='experiments at these motor speeds only [rad/s] (default: the '
                             'speeds found in the data)')
    parser.add_argument('--out', metavar='CSV', help='write the levels here (default stdout)')
    parser.add_argument('--standstill-speed', type=STANDSTILL_SPEED, metavar='RAD_S',
                        help='raw CSV: the speed below which a sample is standstill [rad/s] '
                             + RAW_STANDSTILL_DEFAULT)
    parser.add_argument('--position-bins', type=int, metavar='N',
                        help='raw CSV: one level per speed set-point by eq. (3) over N position '
                             'bins (forward and backward samples in one bin, at least 2 each '
                             'way), for logs too slow for pass pairs (e.g. 2 Hz); see '
                             'docs/segmentation.md')
    add_raw_reading(parser)
    add_robot(parser, help_text='add a robot column with this name (levels of several robots '
                                'in one table)')


def main(args: argparse.Namespace) -> int:
    """Run ``segment``: the level CSV on stdout or ``--out``, the report on stderr."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.monitoring.diagnostics import rejection_text
    from robot_wear_monitor.monitoring.segment import (levels_csv_text, segment_bag,
                                                       segment_raw_csv)
    from robot_wear_monitor.audit.data import is_bag
    from robot_wear_monitor.recordings.raw_runs import folder_runs
    path = Path(args.data)
    raw_file = path.name.endswith(('.csv', '.csv.gz')) and path.exists() and not path.is_dir()
    if raw_file or (path.is_dir() and not is_bag(path) and folder_runs(path)):
        joint, _ = joint_selection(args.joint)
        result = segment_raw_csv(path, gear_ratio=args.gear_ratio,
                                 torque_scale=args.torque_scale, speeds_rad_s=args.speeds,
                                 standstill_speed_rad_s=args.standstill_speed,
                                 position_bins=args.position_bins,
                                 speed_tolerance=args.speed_tolerance, raw_sign=args.raw_sign,
                                 joint=joint)
        report = list(result.notes) + [f'{result.n_levels} friction levels; '
                                       + (rejection_text(result.rejections)
                                          or 'nothing rejected')]
    else:
        if args.raw_sign or args.speed_tolerance is not None:
            raise InputError('--raw-sign and --speed-tolerance are for raw runs; a bag takes '
                             'the node parameters (speed_tolerance_fraction) from --config')
        if args.position_bins is not None:
            raise InputError('--position-bins is for a raw CSV; a bag is segmented by pass '
                             'pairs (time windows)')
        if args.standstill_speed is not None:
            raise InputError('--standstill-speed is for a raw CSV; a bag takes the node '
                             'parameter standstill_speed_rad_s from --config')
        # deferred import: start-up time (the replay, rosbags: bags only)
        from robot_wear_monitor.monitoring.replay import replay_parameters
        joint, joints = joint_selection(args.joint)
        experiment, _ = replay_parameters(config_file=args.config, joint=joint, joints=joints,
                                          gear_ratio=args.gear_ratio,
                                          torque_scale=args.torque_scale)
        result = segment_bag(path, experiment_parameters=experiment, topic=args.topic,
                             speeds_rad_s=args.speeds)
        report = list(result.notes)
        for summary in result.joints:
            report.append(joint_summary_line(summary, estimates=False))
            if rejection_text(summary['rejected']):
                report.append('    ' + rejection_text(summary['rejected']))
    text = levels_csv_text(result.rows, robot=args.robot,
                           terminal=not args.out and to_terminal('-'))
    if args.out:
        write_text_atomic(args.out, text)
    else:
        sys.stdout.write(text)
    for line in report:  # names from the recording: control characters escaped
        print(escaped(line), file=sys.stderr)
    return 0
