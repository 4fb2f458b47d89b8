"""
``robot-wear-monitor plan``: the friction experiment motion of one joint.

The motion is written as a JointTrajectory YAML (for ``ros2 topic pub``), a bag or a CSV.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_wear_monitor.cli.options import (add_json, add_params, emit_json, FINITE, GEAR_RATIO,
                                            params_from, parse_float_list, warn_deprecated)
from robot_wear_monitor.errors import InputError

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
    parser.add_argument('--target-std-error', type=FINITE, default=1.0e-3, metavar='E',
                        help='wanted standard error of each friction level, normalised '
                             '(default 0.001)')
    parser.add_argument('--noise-std', type=FINITE, default=0.01, metavar='S',
                        help="the joint's torque noise per sample, normalised (default 0.01)")
    parser.add_argument('--sample-rate', type=FINITE, default=None, metavar='HZ',
                        help='JointState rate the segmentation will see [Hz] (default 250)')
    parser.add_argument('--rate', type=FINITE, default=None, metavar='HZ', dest='legacy_rate',
                        help='deprecated spelling of --sample-rate (play --rate is a pace)')
    parser.add_argument('--point-rate', type=FINITE, default=50.0, metavar='HZ',
                        help='trajectory points per second (plus every phase end; default 50)')
    parser.add_argument('--dwell', type=FINITE, default=0.1, metavar='S',
                        help='standstill at each turn [s] (default 0.1)')
    parser.add_argument('--min-plateau', type=FINITE, default=0.2, metavar='S',
                        help="the segmentation's min_duration_s [s] (default 0.2)")
    parser.add_argument('--trim', type=FINITE, default=0.02, metavar='S',
                        help="the segmentation's trim_s [s] (default 0.02)")
    parser.add_argument('--min-samples', type=int, default=20,
                        help="the segmentation's min_samples (default 20)")
    parser.add_argument('--hold', metavar='NAME=RAD,...', default='',
                        help='other joints of the trajectory and the positions they hold [rad]')
    parser.add_argument('--controller', default='joint_trajectory_controller',
                        help='ros2_control controller name: the bag topic is '
                             '/<controller>/joint_trajectory')
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


def _sample_rate(args: argparse.Namespace) -> float:
    """Return the JointState rate [Hz] of ``--sample-rate`` or the deprecated ``--rate``."""
    if args.legacy_rate is None:
        return 250.0 if args.sample_rate is None else args.sample_rate
    warn_deprecated('plan', '--rate HZ', '--sample-rate HZ')
    if args.sample_rate is not None and args.sample_rate != args.legacy_rate:
        raise InputError('--rate and --sample-rate: give one (--rate is deprecated)')
    return args.legacy_rate


def main(args: argparse.Namespace) -> int:
    """Run ``plan``: print the plan's durations and write the trajectory of ``--out``."""
    # imported when the verb runs: --help and the parse load none of it, and numpy loads after the
    # one-BLAS-thread setting
    from robot_wear_monitor.experiment.planning import (PlanConfig, plan_experiment,
                                                        plan_summary, trajectory_points)
    from robot_wear_monitor.recordings import trajectories
    rate = _sample_rate(args)
    if args.speeds is not None:
        speeds = args.speeds
    else:
        # imported when the verb runs: --help and the parse load none of it, and numpy loads after
        # the one-BLAS-thread setting
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
        min_plateau_s=args.min_plateau, trim_s=args.trim, min_samples=args.min_samples,
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
