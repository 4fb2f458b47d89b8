"""
``robot-wear-monitor plan``: the friction experiment motion of one joint.

The motion is written as a JointTrajectory YAML (for ``ros2 topic pub``), a bag or a CSV.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from robot_wear_monitor.cli.options import (add_json, add_params, add_setting_option, emit_json,
                                            FINITE, GEAR_RATIO, params_from, parse_float_list,
                                            warn_deprecated)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.plan_config import PlanConfig
from robot_wear_monitor.monitoring.runner_config import RunnerConfig
from robot_wear_monitor.setting_fields import setting_of

HELP = 'plan the friction experiment motion of one joint (JointTrajectory YAML/bag, CSV)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``plan``."""
    parser.add_argument('--joint', required=True, help='name of the tested joint')
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                       help='motor-side speeds [rad/s] (e.g. from design)')
    which.add_argument('--n', type=int, help='use the optimal N-speed design of the parameter '
                                             'set (Table IV; --grid: Table V)')
    parser.add_argument('--grid', type=parse_float_list, metavar='V1,V2,...',
                        help='with --n: choose the N speeds from this grid [rad/s]')
    parser.add_argument('--center', type=FINITE, required=True, metavar='RAD',
                        help='centre of the position window, joint side [rad]')
    parser.add_argument('--half-range', type=FINITE, required=True, metavar='RAD',
                        help='half width of the window the constant-speed passes stay in [rad]')
    parser.add_argument('--gear-ratio', type=GEAR_RATIO, required=True, metavar='R',
                        help='motor speed = R x joint speed (1 for a direct drive; required: '
                             'the plan moves the robot, no default is safe)')
    parser.add_argument('--max-acceleration', type=FINITE, required=True, metavar='RAD_S2',
                        help='joint acceleration limit [rad/s^2]')
    parser.add_argument('--max-jerk', type=FINITE, metavar='RAD_S3',
                        help='joint jerk limit [rad/s^3] (default: trapezoidal ramps)')
    parser.add_argument('--max-speed', type=FINITE, metavar='RAD_S',
                        help='joint speed limit [rad/s] (default: the fastest planned speed)')
    parser.add_argument('--position-limits', type=parse_float_list, metavar='LOW,HIGH',
                        help='joint position limits [rad], checked against the whole motion')
    add_setting_option(parser, '--target-std-error', PlanConfig, 'target_std_error',
                       default=_default('target_std_error'), metavar='E')
    add_setting_option(parser, '--noise-std', PlanConfig, 'noise_std',
                       default=_default('noise_std'), metavar='S')
    add_setting_option(parser, '--sample-rate', PlanConfig, 'rate_hz', metavar='HZ')
    parser.add_argument('--rate', type=FINITE, default=None, metavar='HZ', dest='legacy_rate',
                        help='deprecated spelling of --sample-rate (play --rate is a pace)')
    add_setting_option(parser, '--point-rate', RunnerConfig, 'point_rate_hz',
                       default=setting_of(RunnerConfig, 'point_rate_hz').default, metavar='HZ')
    add_setting_option(parser, '--dwell', PlanConfig, 'dwell_s', default=_default('dwell_s'),
                       metavar='S')
    add_setting_option(parser, '--min-duration', PlanConfig, 'min_duration_s', metavar='S')
    parser.add_argument('--min-plateau', type=FINITE, default=None, metavar='S',
                        dest='legacy_min_plateau',
                        help='deprecated spelling of --min-duration (one name per setting)')
    add_setting_option(parser, '--trim', PlanConfig, 'trim_s', default=_default('trim_s'),
                       metavar='S')
    add_setting_option(parser, '--min-samples', PlanConfig, 'min_samples',
                       default=_default('min_samples'), metavar='N')
    parser.add_argument('--hold', metavar='NAME=RAD,...', default='',
                        help='other joints of the trajectory and the positions they hold [rad]')
    parser.add_argument('--controller',
                        default=setting_of(RunnerConfig, 'controller').default,
                        help='ros2_control controller name: the bag topic is '
                             '/<controller>/joint_trajectory (default: %(default)s)')
    parser.add_argument('--out', metavar='FILE',
                        help='write the trajectory: .yaml (JointTrajectory for ros2 topic pub), '
                             '.csv (time, position, velocity) or a bag folder (any other name)')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing bag')
    add_params(parser)
    add_json(parser)


def parse_hold(text: str) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """Parse ``--hold NAME=RAD,...`` into (names, positions [rad])."""
    names, values = [], []
    for item in filter(None, (part.strip() for part in text.split(','))):
        name, sep, value = item.partition('=')
        try:
            number = float(value)
        except ValueError:
            number = float('nan')
        if not sep or not name.strip() or number != number or abs(number) == float('inf'):
            raise InputError(f'--hold: expected NAME=RAD items, got {item!r}')
        names.append(name.strip())
        values.append(number)
    return tuple(names), tuple(values)


def _default(name: str) -> Any:
    """Return the default of a :class:`PlanConfig` setting (its one owner)."""
    return setting_of(PlanConfig, name).default


def _min_duration(args: argparse.Namespace) -> float:
    """Return ``--min-duration`` or the deprecated ``--min-plateau`` [s] (default: the owner's)."""
    if args.legacy_min_plateau is None:
        return _default('min_duration_s') if args.min_duration is None else args.min_duration
    warn_deprecated('plan', '--min-plateau S', '--min-duration S')
    if args.min_duration is not None and args.min_duration != args.legacy_min_plateau:
        raise InputError('--min-plateau and --min-duration: give one (--min-plateau is '
                         'deprecated)')
    return args.legacy_min_plateau


def _sample_rate(args: argparse.Namespace) -> float:
    """Return the JointState rate [Hz] of ``--sample-rate`` or the deprecated ``--rate``."""
    if args.legacy_rate is None:
        return _default('rate_hz') if args.sample_rate is None else args.sample_rate
    warn_deprecated('plan', '--rate HZ', '--sample-rate HZ')
    if args.sample_rate is not None and args.sample_rate != args.legacy_rate:
        raise InputError('--rate and --sample-rate: give one (--rate is deprecated)')
    return args.legacy_rate


def main(args: argparse.Namespace) -> int:
    """Run ``plan``: print the plan's durations and write the trajectory of ``--out``."""
    # deferred import: start-up time (numpy, rosbags: not for --help)
    from robot_wear_monitor.experiment.planning import (plan_experiment, plan_summary,
                                                        trajectory_points)
    from robot_wear_monitor.recordings import trajectories
    rate = _sample_rate(args)
    if args.speeds is not None:
        speeds = args.speeds
    else:
        # deferred import: start-up time (numpy, scipy: not for --help)
        from robot_wear_monitor.estimation.design import best_grid_design, optimal_design
        if args.n < 1:
            raise InputError(f'--n: the number of speed levels must be >= 1, got {args.n}')
        params = params_from(args)
        result = (best_grid_design(n=args.n, grid_rad_s=args.grid, params=params)
                  if args.grid is not None else optimal_design(n=args.n, params=params))
        speeds = [round(float(v), 4) for v in result.speeds_rad_s]
    if args.position_limits is not None and len(args.position_limits) != 2:
        raise InputError('--position-limits: expected LOW,HIGH')
    names, held = parse_hold(args.hold)
    config = PlanConfig(
        joint=args.joint, speeds_rad_s=tuple(speeds), center_rad=args.center,
        half_range_rad=args.half_range, gear_ratio=args.gear_ratio,
        max_acceleration_rad_s2=args.max_acceleration, max_jerk_rad_s3=args.max_jerk,
        max_speed_rad_s=args.max_speed,
        position_limits_rad=(tuple(args.position_limits) if args.position_limits else None),
        rate_hz=rate, noise_std=args.noise_std, target_std_error=args.target_std_error,
        min_duration_s=_min_duration(args), trim_s=args.trim, min_samples=args.min_samples,
        dwell_s=args.dwell, joint_names=((args.joint,) + names) if names else (),
        hold_positions_rad=held)
    plan = plan_experiment(config=config)
    points = trajectory_points(plan, point_rate_hz=args.point_rate)
    written = None
    if args.out:
        out = Path(args.out)
        if out.suffix.lower() in ('.yaml', '.yml'):
            written = trajectories.write_trajectory_yaml(out, points)
        elif out.suffix.lower() == '.csv':
            written = trajectories.write_trajectory_csv(out, plan)
        else:
            written = trajectories.write_trajectory_bag(out, points, controller=args.controller,
                                                        overwrite=args.overwrite)
    summary = plan_summary(plan)
    summary.update(points=len(points.time_from_start_s), out=str(written) if written else None,
                   topic=trajectories.controller_topic(args.controller))
    if emit_json(args, summary):
        return 0
    print(f'friction experiment of {args.joint}: {len(speeds)} speeds, plateau '
          f'{summary["plateau_s"]:.3f} s per pass ({summary["samples_per_pass"]} samples at '
          f'{rate:g} Hz, std error of each level {summary["std_error"]:.2g})')
    print(f'  {"speed [rad/s]":>14} {"joint [rad/s]":>14} {"window [rad]":>20} '
          f'{"duration [s]":>13}')
    for row in summary['per_speed']:
        low, high = row['window_rad']
        print(f'  {row["speed_rad_s"]:>14.4g} {row["joint_speed_rad_s"]:>14.4g} '
              f'{f"{low:.4f}..{high:.4f}":>20} {row["duration_s"]:>13.2f}')
    low, high = summary['position_range_rad']
    used = summary['limits_used']
    print(f'  total {plan.total_s:.2f} s; joint range used {low:.4f}..{high:.4f} rad; peak '
          f'speed {used["speed_rad_s"]:.3g} rad/s, acceleration '
          f'{used["acceleration_rad_s2"]:.3g} rad/s^2')
    if written:
        print(f'  {len(points.time_from_start_s)} trajectory points written to {written}')
    return 0
