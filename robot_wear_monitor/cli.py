"""The ``robot-wear-monitor`` command line: the only place that parses argv.

Each subcommand has an ``_add_<name>_arguments(parser)`` and a ``_cmd_<name>(args) -> int``; the
work itself is done by keyword-only functions of the core modules.  A user mistake raises
:class:`~robot_wear_monitor.errors.InputError`, which ``main`` prints as one line on stderr with
exit code 2 (never a traceback).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Callable, Sequence

from robot_wear_monitor import __version__
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import load_parameter_set, ParameterSet

PROG = 'robot-wear-monitor'


# --------------------------------------------------------------------------- shared helpers

def parse_float_list(text: str) -> list[float]:
    """Parse '2.1,8.7,15.3' into floats (argparse type); reject empty items, NaN and inf."""
    items = [item.strip() for item in text.split(',')]
    values = []
    for item in items:
        try:
            value = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(f'not a number: {item!r} in {text!r}') from None
        if value != value or value in (float('inf'), float('-inf')):
            raise argparse.ArgumentTypeError(f'not a finite number: {item!r} in {text!r}')
        values.append(value)
    return values


def parse_range(text: str) -> list[float]:
    """Parse 'start:stop:step' (inclusive stop) or a comma list into floats (argparse type)."""
    if ':' not in text:
        return parse_float_list(text)
    parts = text.split(':')
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f'expected start:stop:step, got {text!r}')
    start, stop, step = parse_float_list(','.join(parts))
    if step <= 0 or stop < start:
        raise argparse.ArgumentTypeError(f'expected start <= stop and step > 0, got {text!r}')
    count = int(round((stop - start) / step)) + 1
    return [start + i * step for i in range(count)]


def _params_from(args: argparse.Namespace) -> ParameterSet:
    return load_parameter_set(getattr(args, 'params', None))


def _print_json(payload: object) -> None:
    json.dump(payload, sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write('\n')


def _add_params_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--params', metavar='FILE',
                        help='parameter-set YAML (default: the packaged IRB 6620 joint 2 set)')


# --------------------------------------------------------------------------- design / estimate /
# study (core: design.py, estimation.py, study.py)

def _add_design_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--n', type=int, required=True, help='number of speed levels N (>= 1)')
    parser.add_argument('--grid', type=parse_float_list, metavar='V1,V2,...',
                        help='choose the best N speeds from this grid [rad/s] (Table V); '
                             'default: continuous optimum within the design bounds (Table IV)')
    parser.add_argument('--temperature', type=float, metavar='DEGC',
                        help='design temperature [degC] (default: from the parameter set)')
    parser.add_argument('--wear', type=float, metavar='W',
                        help='design wear level (default: from the parameter set)')
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _cmd_design(args: argparse.Namespace) -> int:
    import numpy as np

    from robot_wear_monitor.estimation.design import best_grid_design, optimal_design
    params = _params_from(args)
    if args.n < 1:
        raise InputError(f'--n: the number of speed levels must be >= 1, got {args.n}')
    if args.grid is not None:
        result = best_grid_design(n=args.n, grid_rad_s=args.grid, params=params,
                                  temperature_degc=args.temperature, wear=args.wear)
    else:
        result = optimal_design(n=args.n, params=params, temperature_degc=args.temperature,
                                wear=args.wear)
    speeds = [round(float(v), 6) for v in result.speeds_rad_s]
    if args.json:
        _print_json({'n': result.n, 'speeds': speeds, 'cost': float(result.cost)})
        return 0
    t = params.design_temperature_degc if args.temperature is None else args.temperature
    w = params.design_wear if args.wear is None else args.wear
    where = 'grid' if args.grid is not None else 'continuous'
    point = (f'w = {w:g} (T integrated out)' if result.n == 1
             else f'T = {t:g} degC, w = {w:g}')
    print(f'optimal {where} design, N = {result.n}, at {point}')
    print(f'  {"speeds [rad/s]":<22}{", ".join(f"{v:.2f}" for v in speeds)}')
    print(f'  {"cost [F^-1]_22 [w^2]":<22}{result.cost:.3f}')
    print(f'  {"std of w-hat >= [w]":<22}{np.sqrt(result.cost):.3f}')
    return 0


def _add_plan_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--joint', required=True, help='name of the tested joint')
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                       help='motor-side speeds [rad/s] (e.g. from design)')
    which.add_argument('--n', type=int, help='use the optimal N-speed design of the parameter '
                                             'set (Table IV; --grid: Table V)')
    parser.add_argument('--grid', type=parse_float_list, metavar='V1,V2,...',
                        help='with --n: choose the N speeds from this grid [rad/s]')
    parser.add_argument('--center', type=float, required=True, metavar='RAD',
                        help='centre of the position window, joint side [rad]')
    parser.add_argument('--half-range', type=float, required=True, metavar='RAD',
                        help='half width of the window the constant-speed passes stay in [rad]')
    parser.add_argument('--gear-ratio', type=float, required=True, metavar='R',
                        help='motor speed / joint speed (1 for a direct drive)')
    parser.add_argument('--max-acceleration', type=float, required=True, metavar='RAD_S2',
                        help='joint acceleration limit [rad/s^2]')
    parser.add_argument('--max-jerk', type=float, metavar='RAD_S3',
                        help='joint jerk limit [rad/s^3] (default: trapezoidal ramps)')
    parser.add_argument('--max-speed', type=float, metavar='RAD_S',
                        help='joint speed limit [rad/s] (default: the fastest planned speed)')
    parser.add_argument('--position-limits', type=parse_float_list, metavar='LOW,HIGH',
                        help='joint position limits [rad], checked against the whole motion')
    parser.add_argument('--target-std-error', type=float, default=1.0e-3, metavar='E',
                        help='wanted standard error of each friction level, normalised '
                             '(default 0.001)')
    parser.add_argument('--noise-std', type=float, default=0.01, metavar='S',
                        help="the joint's torque noise per sample, normalised (default 0.01)")
    parser.add_argument('--rate', type=float, default=250.0, metavar='HZ',
                        help='JointState rate the segmentation will see [Hz] (default 250)')
    parser.add_argument('--point-rate', type=float, default=50.0, metavar='HZ',
                        help='trajectory points per second (plus every phase end; default 50)')
    parser.add_argument('--dwell', type=float, default=0.1, metavar='S',
                        help='standstill at each turn [s] (default 0.1)')
    parser.add_argument('--min-plateau', type=float, default=0.2, metavar='S',
                        help="the segmentation's min_duration_s [s] (default 0.2)")
    parser.add_argument('--trim', type=float, default=0.02, metavar='S',
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
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _parse_hold(text: str) -> tuple[tuple[str, ...], tuple[float, ...]]:
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


def _cmd_plan(args: argparse.Namespace) -> int:
    from pathlib import Path

    from robot_wear_monitor.experiment.planning import (PlanConfig, plan_experiment,
                                                        plan_summary, trajectory_points)
    from robot_wear_monitor.recordings import trajectories
    if args.speeds is not None:
        speeds = args.speeds
    else:
        from robot_wear_monitor.estimation.design import best_grid_design, optimal_design
        if args.n < 1:
            raise InputError(f'--n: the number of speed levels must be >= 1, got {args.n}')
        params = _params_from(args)
        result = (best_grid_design(n=args.n, grid_rad_s=args.grid, params=params)
                  if args.grid is not None else optimal_design(n=args.n, params=params))
        speeds = [round(float(v), 4) for v in result.speeds_rad_s]
    if args.position_limits is not None and len(args.position_limits) != 2:
        raise InputError('--position-limits: expected LOW,HIGH')
    names, held = _parse_hold(args.hold)
    config = PlanConfig(
        joint=args.joint, speeds_rad_s=tuple(speeds), center_rad=args.center,
        half_range_rad=args.half_range, gear_ratio=args.gear_ratio,
        max_acceleration_rad_s2=args.max_acceleration, max_jerk_rad_s3=args.max_jerk,
        max_speed_rad_s=args.max_speed,
        position_limits_rad=(tuple(args.position_limits) if args.position_limits else None),
        rate_hz=args.rate, noise_std=args.noise_std, target_std_error=args.target_std_error,
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
    if args.json:
        _print_json(summary)
        return 0
    print(f'friction experiment of {args.joint}: {len(speeds)} speeds, plateau '
          f'{summary["plateau_s"]:.3f} s per pass ({summary["samples_per_pass"]} samples at '
          f'{args.rate:g} Hz, std error of each level {summary["std_error"]:.2g})')
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


def _add_estimate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--speeds', type=parse_float_list, required=True, metavar='V1,V2,...',
                        help='motor-side speed levels [rad/s]')
    parser.add_argument('--friction', type=parse_float_list, required=True, metavar='F1,F2,...',
                        help='friction levels (normalised torque), one per speed')
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _cmd_estimate(args: argparse.Namespace) -> int:
    import numpy as np

    from robot_wear_monitor.estimation.estimator import estimate_wear
    from robot_wear_monitor.estimation.intervals import wear_intervals
    from robot_wear_monitor.monitoring.diagnostics import meaningful_std
    params = _params_from(args)
    if len(args.speeds) != len(args.friction):
        raise InputError(f'--speeds has {len(args.speeds)} values but --friction has '
                         f'{len(args.friction)}: give one friction level per speed')
    estimates = estimate_wear(args.speeds, args.friction, params=params)
    est = estimates[0]
    interval = wear_intervals(args.speeds, args.friction, params=params,
                              estimates=estimates)[0]
    wear_std = meaningful_std(std=float(est.wear_std), value=float(est.wear),
                              low=interval.wear_low, high=interval.wear_high,
                              open_above=interval.wear_high_at_grid_end)
    alarm = est.wear >= params.wear_threshold

    def finite(value: float) -> float | None:
        return float(value) if np.isfinite(value) else None

    if args.json:
        _print_json({
            'temperature': float(est.temperature_degc), 'wear': float(est.wear),
            'covariance': [[finite(x) for x in row] for row in est.covariance],
            'wear_std': finite(wear_std),
            'temperature_std': finite(est.temperature_std_degc),
            'wear_interval': [finite(interval.wear_low), finite(interval.wear_high)],
            'wear_interval_open_above': interval.wear_high_at_grid_end,
            'temperature_interval': [finite(interval.temperature_low),
                                     finite(interval.temperature_high)],
            'alarm': bool(alarm), 'warning': bool(est.wear >= params.wear_warning),
            'chi2': float(est.chi2), 'dof': int(est.dof), 'p_value': finite(est.p_value),
            'temperature_at_bound': est.temperature_at_bound,
            'wear_at_bound': est.wear_at_bound, 'n_levels': est.n_levels,
            'speeds': [float(v) for v in est.speeds_rad_s],
            'wear_threshold': params.wear_threshold})
        return 0
    t_note = ' (on a bound)' if est.temperature_at_bound else ''
    w_note = ' (on w = 0)' if est.wear_at_bound else ''
    if est.n_levels == 1:
        t_note = ' (posterior mean, N = 1)'
    p_text = 'n/a (dof = 0)' if not np.isfinite(est.p_value) else f'{est.p_value:.3f}'
    above = '+' if interval.wear_high_at_grid_end else ''
    w_std = f' +- {wear_std:.2f}' if np.isfinite(wear_std) else ''
    rows = [('temperature [degC]', f'{est.temperature_degc:8.2f}  95 % '
             f'[{interval.temperature_low:.1f}, {interval.temperature_high:.1f}]{t_note}'),
            ('wear w [-]', f'{est.wear:8.2f}  95 % [{interval.wear_low:.1f}, '
             f'{interval.wear_high:.1f}{above}]{w_std}{w_note}'),
            ('alarm', f'{"YES" if alarm else "no"} (threshold w >= {params.wear_threshold:g})'),
            ('chi2 / dof', f'{est.chi2:8.3f} / {est.dof}'),
            ('p-value', p_text)]
    print(f'wear estimate from N = {est.n_levels} level(s) at '
          f'{", ".join(f"{v:g}" for v in est.speeds_rad_s)} rad/s')
    for name, value in rows:
        print(f'  {name:<20}{value}')
    return 0


def _add_study_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--n', type=int, required=True, help='number of speed levels N (>= 1)')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        help='speed levels [rad/s] (default: the optimal design for N)')
    parser.add_argument('--temperatures', type=parse_range, default=parse_range('30:50:1'),
                        metavar='START:STOP:STEP',
                        help='true temperatures [degC] (default 30:50:1)')
    parser.add_argument('--wear', type=float, default=35.0, help='true wear level (default 35)')
    parser.add_argument('--runs', type=int, default=1000, help='Monte Carlo runs per temperature')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--plot', metavar='PNG', help='draw bias and variance like Fig. 8')


def _cmd_study(args: argparse.Namespace) -> int:
    from robot_wear_monitor.estimation.design import optimal_design
    from robot_wear_monitor.estimation.study import plot_study, run_study
    params = _params_from(args)
    if args.n < 1:
        raise InputError(f'--n: the number of speed levels must be >= 1, got {args.n}')
    if args.speeds is not None and len(args.speeds) != args.n:
        raise InputError(f'--speeds has {len(args.speeds)} values but --n is {args.n}')
    speeds = (args.speeds if args.speeds is not None
              else optimal_design(n=args.n, params=params).speeds_rad_s)
    result = run_study(speeds_rad_s=speeds, temperatures_degc=args.temperatures,
                       wear=args.wear, runs=args.runs, seed=args.seed, params=params)
    if args.plot:
        plot_study([result], path=args.plot)
    if args.json:
        _print_json(result.to_dict())
        return 0
    print(f'Monte Carlo study, N = {result.n} at {", ".join(f"{v:.2f}" for v in speeds)} rad/s, '
          f'true w = {result.wear:g}, {result.runs} runs per temperature, seed {result.seed}')
    print(f'  {"T [degC]":>8} {"mean w":>8} {"bias":>8} {"variance":>9} {"MSE":>9} '
          f'{"CRB":>9} {"T at bound":>10}')
    for i, t in enumerate(result.temperatures_degc):
        print(f'  {t:8.2f} {result.mean[i]:8.3f} {result.bias[i]:8.3f} '
              f'{result.variance[i]:9.3f} {result.mse[i]:9.3f} {result.crb[i]:9.3f} '
              f'{result.temperature_at_bound[i]:10.2f}')
    if args.plot:
        print(f'figure written to {args.plot}')
    return 0


# --------------------------------------------------------------------------- simulate
# (simulation.py, bags.py)

def _add_simulate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', required=True, metavar='BAG', help='output bag directory')
    parser.add_argument('--experiments', type=int, default=100,
                        help='number of experiments k of the accelerated wear test (100)')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        default=[2.1, 28.5, 35.1, 41.7],
                        help='motor-side speeds [rad/s] (default: Table V, N = 4)')
    parser.add_argument('--wear-final', type=float, default=60.0,
                        help='wear at the last experiment (default 60)')
    parser.add_argument('--sample-rate', type=float, default=250.0, metavar='HZ',
                        help='JointState rate [Hz] (default 250)')
    parser.add_argument('--interval', type=float, default=3600.0, metavar='S',
                        help='time between experiments [s] (default 3600)')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                        help='bag storage (default mcap)')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing bag')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    _add_params_argument(parser)


def _cmd_simulate(args: argparse.Namespace) -> int:
    from robot_wear_monitor.recordings.bags import write_joint_state_bag
    from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                          JointSimConfig, simulate_scenario,
                                                          truth_path_for, write_truth_json)
    params = _params_from(args)
    config = accelerated_wear_scenario(
        n_experiments=args.experiments, speeds_rad_s=args.speeds, params=params,
        seed=args.seed, wear_final=args.wear_final, experiment_interval_s=args.interval,
        joint=JointSimConfig(sample_rate_hz=args.sample_rate))
    scenario = simulate_scenario(config=config, model=params.model, seed=args.seed)
    bag = write_joint_state_bag(args.out, stamps_s=scenario.time_s, names=scenario.joint_names,
                                position=scenario.position_rad,
                                velocity=scenario.velocity_rad_s, effort=scenario.effort,
                                storage=args.storage, overwrite=args.overwrite)
    truth = write_truth_json(truth_path_for(bag), scenario)
    print(f'{bag}: {scenario.n_samples} JointState messages on /joint_states '
          f'({len(scenario.truth)} experiments, joint {scenario.joint}, gear ratio '
          f'{scenario.config.gear_ratio:g}, torque scale {scenario.config.torque_scale:g}); '
          f'truth: {truth} (replay ... --truth {truth})')
    return 0


def _add_segment_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('data', metavar='DATA',
                        help='ROS 2 bag folder, or a raw CSV(.gz) with t_s,q_rad,dq_rad_s,'
                             'tau_measured_Nm columns (KUKA runs)')
    parser.add_argument('--joint', action='extend', type=_joint_names, metavar='NAME[,NAME]',
                        help='joint in the bag; several as NAME,NAME or repeated --joint, or '
                             '"all" (default: the node config\'s joint, joint_2)')
    parser.add_argument('--topic', default='/joint_states', help='JointState topic')
    parser.add_argument('--gear-ratio', type=float, default=None,
                        help='motor speed / joint speed (bag default: the node config, 150; '
                             'CSV default 1)')
    parser.add_argument('--torque-scale', type=float, default=None,
                        help='effort per normalised torque (bag default: the node config, 10; '
                             'CSV default 1)')
    parser.add_argument('--config', metavar='YAML',
                        help='node parameter file for a bag (default: the packaged '
                             'wear_monitor.yaml; per-joint values as <joint>: {...})')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        help='experiments at these motor speeds only [rad/s] (default: the '
                             'speeds found in the data)')
    parser.add_argument('--out', metavar='CSV', help='write the levels here (default stdout)')


_SEGMENT_COLUMNS = ['speed', 'friction', 'friction_std_error', 'tau_forward', 'tau_backward',
                    'n_forward', 'n_backward', 'position_min_rad', 'position_max_rad',
                    'start_time_s', 'end_time_s', 'experiment', 'joint']


def _cmd_segment(args: argparse.Namespace) -> int:
    import csv
    import io
    from pathlib import Path

    from robot_wear_monitor.atomic_files import write_text_atomic
    path = Path(args.data)
    if path.is_file() and path.name.endswith(('.csv', '.csv.gz')):
        rows, report = _segment_raw_csv(args, path)
    else:
        rows, report = _segment_bag(args, path)
    text = io.StringIO()
    writer = csv.writer(text)
    writer.writerow(_SEGMENT_COLUMNS)
    for level, k, joint in rows:
        writer.writerow([f'{level.speed_rad_s:.6g}', f'{level.friction:.6g}',
                         f'{level.friction_std_error:.3g}', f'{level.tau_forward:.6g}',
                         f'{level.tau_backward:.6g}', level.n_forward, level.n_backward,
                         f'{level.position_min_rad:.6g}', f'{level.position_max_rad:.6g}',
                         f'{level.start_time_s:.6f}', f'{level.end_time_s:.6f}', k, joint])
    if args.out:
        write_text_atomic(args.out, text.getvalue())
    else:
        sys.stdout.write(text.getvalue())
    for line in report:
        print(line, file=sys.stderr)
    return 0


def _segment_raw_csv(args: argparse.Namespace, path) -> tuple[list, list[str]]:
    """Segment one KUKA-style raw run (the raw-run settings); levels without experiments."""
    from robot_wear_monitor.experiment.segmentation import ExperimentAssembler, segment_batch
    from robot_wear_monitor.recordings.tables import kuka_segmenter_config, read_raw_csv
    t, q, v, e = read_raw_csv(path)
    overrides = {k: val for k, val in (('gear_ratio', args.gear_ratio),
                                       ('torque_scale', args.torque_scale)) if val is not None}
    config = kuka_segmenter_config(**overrides)
    result = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    rows = [(level, '', config.joint) for level in result.levels]
    if args.speeds:
        assembler = ExperimentAssembler(speeds_rad_s=args.speeds)
        done = [x for level in result.levels for x in assembler.add(level)] + assembler.flush()
        rows = [(level, k, config.joint) for k, x in enumerate(done) for level in x.levels]
    rejected = dict(result.rejections)
    return rows, [f'{len(result.levels)} friction levels; rejected: '
                  + (', '.join(f'{k} {n}' for k, n in sorted(rejected.items())) or 'none')]


def _segment_bag(args: argparse.Namespace, path) -> tuple[list, list[str]]:
    """Segment the joints of a bag as the replay does (discovery, chunks, per-joint report)."""
    from robot_wear_monitor.monitoring.joints import FrictionExperimentFleet
    from robot_wear_monitor.monitoring.replay import (explain_recording, joint_summary,
                                                      NoExperimentError, replay_parameters)
    from robot_wear_monitor.recordings.bags import iter_joint_chunks
    joint, joints = _joint_selection(args.joint)
    experiment, _ = replay_parameters(config_file=args.config, joint=joint, joints=joints,
                                      gear_ratio=args.gear_ratio,
                                      torque_scale=args.torque_scale)
    if args.speeds:
        from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                               validate_parameters)
        experiment = validate_parameters(
            FRICTION_EXPERIMENT_NODE, {**experiment, 'experiment_speeds_rad_s': args.speeds},
            source='--speeds')
    fleet = FrictionExperimentFleet(experiment, source='segment parameters')
    stream = iter_joint_chunks(path, joints=fleet.selection, topic=args.topic,
                               require_joints=False)
    found: dict[str, list] = {}
    for chunk in stream:
        for name, samples in chunk.items():
            service = fleet.service(name)
            found.setdefault(name, []).extend(service.add_recording(
                time_s=samples.time_s, position_rad=samples.position_rad,
                velocity_rad_s=samples.velocity_rad_s, effort=samples.effort))
    for service, done in fleet.finish():
        found.setdefault(service.joint, []).append(done)
    rows, report = [], list(stream.notes)
    for name, service in fleet.services.items():
        experiments = found.get(name, [])
        for level in service.levels:
            k = next((i for i, x in enumerate(experiments)
                      if x.start_time_s <= level.start_time_s
                      and level.end_time_s <= x.end_time_s), '')
            rows.append((level, k, name))
        summary = joint_summary(service, stream)
        report.append(_joint_summary_line(summary, estimates=False))
        if summary['rejected']:
            report.append('    rejected: ' + ', '.join(
                f'{k} {n}' for k, n in summary['rejected'].items()))
    if not rows:
        raise NoExperimentError(f'no friction level: {explain_recording(fleet, stream)}')
    return rows, report


# --------------------------------------------------------------------------- replay / demo
# (replay.py, service.py, report.py)

def _add_replay_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', metavar='BAG', help='recorded ROS 2 bag (MCAP or sqlite3)')
    parser.add_argument('--out', required=True, metavar='OUT_BAG', help='output bag directory')
    parser.add_argument('--json', metavar='SUMMARY', help='write the JSON summary here')
    parser.add_argument('--plot', metavar='PNG', help='draw the wear trend (like Fig. 11)')
    parser.add_argument('--joint', action='extend', type=_joint_names, metavar='NAME[,NAME]',
                        help='joint to monitor; several as NAME,NAME or repeated --joint, or '
                             '"all" (every joint of the recording): outputs under <joint>/ '
                             '(default: the node config\'s joint)')
    parser.add_argument('--gear-ratio', type=float, metavar='R',
                        help='motor speed / joint speed (default: from the node config)')
    parser.add_argument('--torque-scale', type=float, metavar='S',
                        help='effort per normalised torque (default: from the node config)')
    _add_params_argument(parser)
    parser.add_argument('--config', metavar='YAML',
                        help='node parameter file (default: the packaged wear_monitor.yaml; '
                             'per-joint values as <joint>: {gear_ratio: ...})')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                        help='storage of OUT_BAG (default mcap)')
    parser.add_argument('--history', metavar='FILE', help='also keep the SQLite wear history')
    parser.add_argument('--truth', metavar='JSON',
                        help='truth of a simulated bag (simulate writes BAG.truth.json), added '
                             'to the summary and the plot; nothing beside the bag is read '
                             'unless named here')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing OUT_BAG')
    parser.add_argument('--strict', action='store_true',
                        help='refuse a recording whose end is cut (default: read up to the cut)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def _cmd_replay(args: argparse.Namespace) -> int:
    from pathlib import Path

    from robot_wear_monitor.atomic_files import write_json_atomic
    from robot_wear_monitor.experiment.simulation import read_truth_json
    from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
    if Path(args.out).exists() and not args.overwrite:
        raise InputError(f'{args.out}: already exists (use --overwrite to replace it)')
    truth = read_truth_json(args.truth) if args.truth else None
    joint, joints = _joint_selection(args.joint)
    experiment, estimator = replay_parameters(
        config_file=args.config, joint=joint, joints=joints, gear_ratio=args.gear_ratio,
        torque_scale=args.torque_scale, params_file=args.params)
    result = replay_bag(args.bag, out_bag=args.out, experiment_parameters=experiment,
                        estimator_parameters=estimator, storage=args.storage,
                        history_file=args.history, overwrite=args.overwrite,
                        progress=not args.no_progress, truth=truth, recover=not args.strict)
    if result.recovery is not None and not result.recovery.complete:
        print(f'warning: {args.bag}: unfinished recording ({result.recovery.reason}): read '
              f'{result.recovery.messages} complete messages up to bag time '
              f'{result.recovery.last_stamp_s:.3f} s; what followed is lost (--strict '
              f'refuses such a recording)', file=sys.stderr)
    for partial in result.removed_partials:
        print(f'removed {partial}: the unfinished output of a replay that was killed',
              file=sys.stderr)
    for note in result.notes:
        print(f'note: {note}', file=sys.stderr)
    summary = result.summary()
    if args.json:
        write_json_atomic(args.json, summary)
    if args.plot:
        _plot_replay(result, args.plot, bag=args.bag, threshold=estimator['wear_threshold'])
    first = summary['first_alarm']
    skipped = result.rejections.get('friction_levels_already_in_history', 0)
    print(f'{len(result.updates)} experiments from {result.message_count} messages; '
          + (f'{skipped} already in the history (skipped, not estimated again); '
             if skipped else '')
          + ('no alarm' if first is None else
             f'alarm at experiment {first["index"]} (w-hat {first["wear"]:.1f})')
          + f'; wrote {args.out}')
    if joints:
        for entry in result.joints:
            print(_joint_summary_line(entry))
    return 0


def _joint_names(text: str) -> list[str]:
    """Parse one ``--joint`` value: a name or comma-separated names."""
    names = [name.strip() for name in text.split(',')]
    if not all(names):
        raise argparse.ArgumentTypeError(f'empty joint name in {text!r}')
    return names


def _joint_selection(names: Sequence[str] | None) -> tuple[str | None, list[str] | None]:
    """Return (joint, joints) of ``--joint``: one name keeps the single-joint layout."""
    if not names:
        return None, None
    if len(names) == 1 and names[0] != 'all':
        return names[0], None
    if 'all' in names and len(names) > 1:
        raise InputError('--joint: "all" stands alone')
    return None, list(names)


def _joint_summary_line(entry: dict, *, estimates: bool = True) -> str:
    """Return one line on a joint: samples, passes, levels per speed, experiments, or why not."""
    speeds = ', '.join(f'{k} rad/s x{v}' for k, v in entry['levels_per_speed_rad_s'].items())
    other = entry['levels_at_other_speeds_rad_s']
    alarm = entry['first_alarm']
    line = (f'  {entry["joint"]}: {entry["samples"]} samples, {entry["passes"]} passes, '
            f'{entry["levels"]} levels' + (f' ({speeds})' if speeds else '')
            + f', {entry["experiments"]} experiments'
            + (f', {entry["estimates"]} estimates' if estimates else '')
            + (f', alarm at experiment {alarm["index"]}' if alarm else ''))
    if other:
        line += ('; levels at no configured speed: '
                 + ', '.join(f'{k} rad/s x{v}' for k, v in other.items()))
    if entry['no_experiment']:
        line += f'; no experiment: {entry["no_experiment"]}'
    return line


def _plot_replay(result, path: str, *, bag: str, threshold: float) -> None:
    """Draw the wear trend of the replay, one figure per joint with estimates."""
    from dataclasses import replace
    from pathlib import Path

    from robot_wear_monitor.reporting.report import plot_wear_trend
    joints = [entry['joint'] for entry in result.joints if entry['estimates']]
    if len(joints) <= 1:
        plot_wear_trend(result, path, threshold=threshold,
                        title=f'Wear estimate, {Path(bag).name}, joint {result.joint}')
        return
    target = Path(path)
    for joint in joints:
        part = replace(result, updates=[u for u in result.updates if u.joint == joint],
                       joint=joint)
        plot_wear_trend(part, target.with_name(f'{target.stem}_{joint}{target.suffix}'),
                        threshold=threshold,
                        title=f'Wear estimate, {Path(bag).name}, joint {joint}')


def _add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', metavar='DIR', default='wear_demo',
                        help='report folder (default ./wear_demo)')
    parser.add_argument('--experiments', type=int, default=100,
                        help='number of simulated experiments (default 100)')
    parser.add_argument('--seed', type=int, default=0, help='random seed (default 0)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def _cmd_demo(args: argparse.Namespace) -> int:
    from robot_wear_monitor.reporting.demo import describe, run_demo
    if args.experiments < 1:
        raise InputError(f'--experiments must be >= 1, got {args.experiments}')
    summary = run_demo(out_dir=args.out, n_experiments=args.experiments, seed=args.seed,
                       progress=not args.no_progress,
                       log=lambda text: print(text, file=sys.stderr))
    print(describe(summary, args.out))
    return 0


# --------------------------------------------------------------------------- live graph
# (nodes/monitoring_graph.py: the only rclpy imports stay under nodes/)

def _add_live_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--params-file', metavar='YAML',
                        help='ROS 2 parameter file of both nodes (default: the packaged '
                             'config/wear_monitor.yaml)')
    parser.add_argument('--joint', help='joint to monitor (overrides the params file)')
    parser.add_argument('--history', metavar='FILE',
                        help='SQLite wear history (overrides the params file)')
    parser.add_argument('--parameter-set', metavar='FILE',
                        help='friction-model parameter-set YAML (overrides the params file)')


def _ros_args(args: argparse.Namespace) -> list[str]:
    return list(getattr(args, 'ros_args', None) or [])


def _cmd_live(args: argparse.Namespace) -> int:
    from pathlib import Path

    from robot_wear_monitor.monitoring.node_config import (default_node_config_file,
                                                           FRICTION_EXPERIMENT_NODE,
                                                           load_node_parameters,
                                                           WEAR_ESTIMATOR_NODE)
    params_file = Path(args.params_file) if args.params_file else default_node_config_file()
    overrides = []
    if args.joint:
        overrides.append(('joint', args.joint))
    if args.history:
        overrides.append(('history_file', args.history))
    if args.parameter_set:
        overrides.append(('parameter_set_file', args.parameter_set))
    # Refuse a bad file here with one line, before any node starts.
    load_node_parameters(FRICTION_EXPERIMENT_NODE, params_file,
                         overrides={k: v for k, v in overrides if k == 'joint'})
    load_node_parameters(WEAR_ESTIMATOR_NODE, params_file, overrides=dict(overrides))
    try:
        from .nodes.monitoring_graph import ros_arguments, run_monitoring_graph
    except ImportError as error:
        raise InputError(f'rclpy is not installed ({error}); pip install '
                         f'"robot_wear_monitor[ros]" or source a ROS 2 Jazzy setup') from None
    print(f'{PROG} live: friction_experiment_node + wear_estimator_node, parameters from '
          f'{params_file}; Ctrl-C stops', file=sys.stderr, flush=True)
    return run_monitoring_graph(args=ros_arguments(params_file=params_file, overrides=overrides,
                                                   extra=_ros_args(args)))


def _add_play_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', metavar='BAG', help='recorded ROS 2 bag (MCAP or sqlite3)')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='multiple of the recorded pace (default 1.0)')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC',
                        help='topics to play (default: every recorded topic)')
    parser.add_argument('--wait-for-subscribers', type=int, default=1, metavar='N',
                        help='subscribers each topic waits for before playing (default 1)')
    parser.add_argument('--wait-timeout', type=float, default=10.0, metavar='S',
                        help='seconds to wait for them, then play anyway (default 10)')


def _cmd_play(args: argparse.Namespace) -> int:
    if not args.rate > 0:
        raise InputError(f'--rate must be > 0, got {args.rate}')
    try:
        from .nodes.monitoring_graph import run_player
    except ImportError as error:
        raise InputError(f'rclpy is not installed ({error}); pip install '
                         f'"robot_wear_monitor[ros]" or source a ROS 2 Jazzy setup') from None
    return run_player(args.bag, rate=args.rate, topics=args.topics,
                      wait_for_subscribers=args.wait_for_subscribers,
                      wait_timeout_s=args.wait_timeout, args=_ros_args(args),
                      say=lambda text: print(text, flush=True))


# --------------------------------------------------------------------------- audit (audit.py)

def _add_level_source_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of raw-run and bag inputs that are segmented into levels."""
    parser.add_argument('--joint', help='joint name to segment (bag input)')
    parser.add_argument('--topic', default='/joint_states', help='joint-state topic (bag input)')
    parser.add_argument('--raw-sign', action='store_true',
                        help='raw runs: keep the torque sign (default: flipped, friction > 0)')
    parser.add_argument('--gear-ratio', type=float, default=1.0,
                        help='bag input: motor speed = gear ratio x joint speed (default 1)')
    parser.add_argument('--torque-scale', type=float, default=1.0,
                        help='bag input: normalised torque = effort / scale (default 1)')


def _add_audit_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('data', metavar='DATA',
                        help='friction-level CSV (speed, friction, ...), a raw run or a folder '
                             'of raw runs (t_s, q_rad, dq_rad_s, tau_measured_Nm), or a bag')
    parser.add_argument('--model', default='speed', metavar='speed|nominal|complete',
                        help='model to audit: speed (4), nominal (5) or complete (8) '
                             '(default speed)')
    _add_params_argument(parser)
    parser.add_argument('--group', metavar='COLUMN',
                        help='identify the speed model separately per value of this column '
                             '(default for raw runs of several joints: joint)')
    parser.add_argument('--json', metavar='REPORT', dest='json_report',
                        help="write the JSON report to this file ('-' for stdout)")
    parser.add_argument('--plots', metavar='DIR', help='write the residual figures here')
    parser.add_argument('--fdr', type=float, default=0.01,
                        help='false-discovery rate of each step (default 0.01)')
    parser.add_argument('--max-effects', type=int, default=4,
                        help='add at most this many effects (default 4)')
    parser.add_argument('--folds', type=int, default=5, help='cross-validation folds (default 5)')
    parser.add_argument('--out-params', metavar='FILE',
                        help='write the parameter set extended by the added terms (YAML, '
                             'section added_terms; nominal and complete models) for estimate, '
                             'replay, design and the nodes (--params FILE)')
    _add_level_source_arguments(parser)


def _cmd_audit(args: argparse.Namespace) -> int:
    from robot_wear_monitor.audit.data import load_audit_data, MODELS
    from robot_wear_monitor.audit.run import run_audit

    if args.model not in MODELS:
        raise InputError(f'unknown --model {args.model!r} (expected {", ".join(MODELS)})')
    if args.out_params and args.model == 'speed':
        raise InputError('--out-params needs --model nominal or complete (a parameter set holds '
                         'model (5) and (7), not the speed model (4))')
    if not 0 < args.fdr < 1:
        raise InputError(f'--fdr must be between 0 and 1, got {args.fdr}')
    if args.max_effects < 0 or args.folds < 2:
        raise InputError('--max-effects must be >= 0 and --folds >= 2')
    params = _params_from(args) if args.model != 'speed' or args.params else None
    table = load_audit_data(args.data, model=args.model, joint=args.joint, topic=args.topic,
                            flip_sign=not args.raw_sign, gear_ratio=args.gear_ratio,
                            torque_scale=args.torque_scale)
    group = args.group
    if group is None and args.model == 'speed' and 'joint' in table.text:
        group = 'joint'
    result = run_audit(table=table, model=args.model, params=params, group=group,
                       fdr=args.fdr, max_effects=args.max_effects, n_folds=args.folds)
    report = result.to_dict()
    if args.out_params:
        from robot_wear_monitor.audit.export import write_parameter_set
        write_parameter_set(args.out_params, result.extended_params,
                            header=_audit_params_header(args, result))
        report['out_params'] = args.out_params
    if args.plots:
        from robot_wear_monitor.audit.report import plot_audit
        report['figures'] = [str(p) for p in plot_audit(result=result, table=table,
                                                        out_dir=args.plots)]
    if args.json_report == '-':
        _print_json(report)
        return 0
    print(result.summary())
    if args.out_params:
        print(f'extended parameter set written to {args.out_params} (use: {PROG} estimate '
              f'--params {args.out_params} ...)')
    if args.json_report:
        try:
            with open(args.json_report, 'w', encoding='utf-8') as stream:
                json.dump(report, stream, indent=2, allow_nan=False)
                stream.write('\n')
        except OSError as error:
            raise InputError(f'{args.json_report}: cannot write: {error.strerror}') from None
    return 0


def _audit_params_header(args: argparse.Namespace, result) -> str:
    """Return the comment lines of an ``audit --out-params`` file (provenance, defaults)."""
    lines = [f'Parameter set extended by {PROG} audit {args.data} --model {args.model}.',
             f'Base: {result.extended_params.name} from '
             f'{args.params or "the packaged set"}; model ({5 if args.model == "nominal" else 8})'
             ' re-identified jointly with the added terms on '
             f'{result.n_levels} levels;',
             f'held-out RMS error {result.rms_before:.4g} -> {result.rms_after:.4g} '
             f'(noise floor {result.noise_floor:.4g}).']
    lines += [f'Added: {e.name} [{", ".join(e.variables)}]' for e in result.effects]
    if not result.effects:
        lines.append('No effect added: the set is the re-identified model alone.')
    lines += [f'Not measured online: {name}, evaluated at {value!r} ({how}).'
              for name, (value, how) in result.offline.items()]
    return '\n'.join(lines)


# --------------------------------------------------------------------------- history (history.py)

def _add_history_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('database', metavar='DB', help='wear history SQLite file of the estimator')
    parser.add_argument('--joint', help='joint to show (default: the only joint stored)')
    parser.add_argument('--last', type=int, metavar='K', help='show only the last K estimates')
    parser.add_argument('--csv', metavar='LEVELS', help='export the friction levels as a CSV '
                        'table for `robot-wear-monitor audit`')
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _cmd_history(args: argparse.Namespace) -> int:
    from pathlib import Path

    from robot_wear_monitor.monitoring.history import WearHistory, write_levels_csv
    from robot_wear_monitor.monitoring.diagnostics import json_number

    if not Path(args.database).is_file():
        raise InputError(f'{args.database}: no such wear history database')
    if args.last is not None and args.last < 1:
        raise InputError(f'--last must be >= 1, got {args.last}')
    with WearHistory(args.database) as history:
        joints = history.joints()
        joint = args.joint
        if joint is None:
            if len(joints) != 1:
                raise InputError(f'{args.database}: holds joints {", ".join(joints) or "none"}; '
                                 'choose one with --joint')
            joint = joints[0]
        elif joint not in joints:
            raise InputError(f'{args.database}: no estimates for joint {joint!r} '
                             f'(stored: {", ".join(joints) or "none"})')
        state = history.restore(joint=joint)
        records = history.records(joint=joint, limit=args.last)
    if args.csv:
        write_levels_csv(args.csv, records=records)
    if args.json:
        _print_json({
            'joint': joint, 'alarm_active': state.alarm_active, 'csv': args.csv,
            'estimates': [{'id': r.id, 'stamp_s': r.stamp_s, 'speeds': list(r.speeds_rad_s),
                           'frictions': list(r.frictions), 'wear': json_number(r.wear),
                           'wear_std': json_number(r.wear_std),
                           'temperature_degc': json_number(r.temperature_degc),
                           'p_value': json_number(r.p_value), 'alarm': r.alarm_active}
                          for r in records]})
        return 0
    print(f'joint {joint}: {len(records)} estimate(s) shown; alarm '
          f'{"LATCHED" if state.alarm_active else "clear"}')
    header = ('id', 'stamp [s]', 'w', 'std w', 'T [degC]', 'p-value')
    print('{:>5} {:>14} {:>7} {:>7} {:>9} {:>8}  alarm'.format(*header))
    for r in records:
        print(f'{r.id:>5} {r.stamp_s:>14.1f} {r.wear:>7.2f} {r.wear_std:>7.2f} '
              f'{r.temperature_degc:>9.2f} {r.p_value:>8.3g}  {"yes" if r.alarm_active else ""}')
    if args.csv:
        print(f'levels written to {args.csv} (run: {PROG} audit {args.csv})')
    return 0


# --------------------------------------------------------------------------- identify
# (core: audit/identification.py, sharing audit/fitting.py with audit)

def _add_identify_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('baseline', metavar='BASELINE',
                        help='healthy-joint friction levels: a CSV with speed, friction, '
                             'temperature, load (optionally experiment), or raw runs / a bag '
                             'that the segmentation turns into levels')
    parser.add_argument('--wear-test', metavar='WEAR',
                        help='levels of an accelerated wear test (same columns plus '
                             'experiment, the time index k)')
    parser.add_argument('--critical-experiment', metavar='K',
                        help='experiment of the wear test identified with w = --critical-wear')
    parser.add_argument('--critical-wear', type=float, default=35.0, metavar='W',
                        help='wear level of experiment K (default 35, the paper\'s convention)')
    parser.add_argument('--from-params', metavar='FILE',
                        help='reference parameter set for the fields the data cannot determine '
                             '(default: the packaged IRB 6620 joint 2 set)')
    parser.add_argument('--name', help='name of the new set (default: identified_<BASELINE>)')
    parser.add_argument('--out', required=True, metavar='PARAMS.yaml',
                        help='write the parameter set here (atomically; loaded back to check)')
    parser.add_argument('--json', metavar='REPORT', dest='json_report',
                        help="write the JSON report to this file ('-' for stdout)")
    parser.add_argument('--plots', metavar='DIR', help='write the residual figures here')
    parser.add_argument('--temperature-bounds', type=parse_float_list, metavar='LOW,HIGH',
                        help='temperature bounds of the estimator [degC] (default: the '
                             'baseline\'s temperature range)')
    parser.add_argument('--temperature-column', metavar='COLUMN',
                        help='column holding the joint temperature [degC] (default temperature)')
    parser.add_argument('--load-column', metavar='COLUMN',
                        help='column holding the load torque (default load)')
    parser.add_argument('--temperature-topic', metavar='TOPIC',
                        help='bag input: the joint temperature [degC] recorded on this topic '
                             '(sensor_msgs/Temperature or std_msgs/Float64), per level at its '
                             'time')
    parser.add_argument('--load-topic', metavar='TOPIC',
                        help='bag input: the load torque tau_l (normalised) recorded on this '
                             'topic (std_msgs/Float64), per level at its time')
    parser.add_argument('--experiment-gap', type=float, default=10.0, metavar='S',
                        help='bag input: levels more than S seconds apart start a new '
                             'experiment (default 10)')
    parser.add_argument('--folds', type=int, default=5,
                        help='cross-validation folds of the held-out error (default 5)')
    _add_level_source_arguments(parser)


def _cmd_identify(args: argparse.Namespace) -> int:
    import math
    from pathlib import Path
    import re

    from robot_wear_monitor.atomic_files import write_json_atomic
    from robot_wear_monitor.audit.identification import (attach_series, identify,
                                                         number_experiments,
                                                         plot_identification, prepare_levels,
                                                         write_parameter_set)
    from robot_wear_monitor.audit.model_audit import is_bag, load_audit_data

    if (args.wear_test is None) != (args.critical_experiment is None):
        raise InputError('--wear-test and --critical-experiment K go together (K is the '
                         'experiment of the wear test with w = --critical-wear)')
    if not (math.isfinite(args.critical_wear) and args.critical_wear > 0):
        raise InputError(f'--critical-wear must be > 0, got {args.critical_wear}')
    if args.folds < 2:
        raise InputError(f'--folds must be >= 2, got {args.folds}')
    bounds = None
    if args.temperature_bounds is not None:
        if len(args.temperature_bounds) != 2 or not (
                args.temperature_bounds[0] < args.temperature_bounds[1]):
            raise InputError('--temperature-bounds: expected LOW,HIGH with LOW < HIGH')
        bounds = (args.temperature_bounds[0], args.temperature_bounds[1])
    from_params = load_parameter_set(args.from_params)

    def levels(path: str, role: str):
        table = load_audit_data(path, model='speed', joint=args.joint, topic=args.topic,
                                flip_sign=not args.raw_sign, gear_ratio=args.gear_ratio,
                                torque_scale=args.torque_scale)
        topics = {'temperature': args.temperature_topic, 'load': args.load_topic}
        if any(topics.values()):
            if not is_bag(path):
                raise InputError(f'{role} {path}: --temperature-topic and --load-topic are '
                                 f'for bag input')
            from robot_wear_monitor.recordings.bags import read_scalar_topic
            for column, topic in topics.items():
                if topic:
                    time_s, values, _ = read_scalar_topic(path, topic=topic)
                    table = attach_series(table, column=column, time_s=time_s,
                                          values=values, source=f'topic {topic}')
        if is_bag(path):
            table = number_experiments(table, gap_s=args.experiment_gap)
        return prepare_levels(table, role=role, temperature_column=args.temperature_column,
                              load_column=args.load_column)

    baseline = levels(args.baseline, 'BASELINE')
    wear_test = levels(args.wear_test, 'WEAR') if args.wear_test else None
    stem = Path(args.baseline.rstrip('/')).name.split('.')[0]
    name = args.name or 'identified_' + (re.sub(r'[^A-Za-z0-9_]+', '_', stem) or 'set')
    result = identify(baseline=baseline, from_params=from_params, name=name,
                      wear_test=wear_test, critical_experiment=args.critical_experiment,
                      critical_wear=args.critical_wear, temperature_bounds_degc=bounds,
                      n_folds=args.folds)
    loaded = write_parameter_set(args.out, result)
    report = result.to_dict()
    report['out'] = str(args.out)
    report['loaded_back'] = loaded.name == result.params.name
    if args.plots:
        report['figures'] = [str(p) for p in plot_identification(
            result=result, baseline=baseline, wear_test=wear_test, out_dir=args.plots)]
    if args.json_report == '-':
        _print_json(report)
        return 0
    print(result.summary())
    print(f'parameter set {loaded.name!r} written to {args.out} (loaded back and validated)')
    if args.json_report:
        try:
            write_json_atomic(args.json_report, report)
        except OSError as error:
            raise InputError(f'{args.json_report}: cannot write: {error.strerror}') from None
    return 0


# --------------------------------------------------------------------------- entry point

_COMMANDS: dict[str, tuple[str, Callable, Callable]] = {
    'design': ('optimal speed levels for N friction levels, eqs. (22)-(25)',
               _add_design_arguments, _cmd_design),
    'plan': ('plan the friction experiment motion of one joint (JointTrajectory YAML/bag, CSV)',
             _add_plan_arguments, _cmd_plan),
    'estimate': ('estimate temperature and wear from friction levels, eqs. (16)-(19)',
                 _add_estimate_arguments, _cmd_estimate),
    'study': ('Monte Carlo bias/variance study of the wear estimator (Sec. IV-C, Fig. 8)',
              _add_study_arguments, _cmd_study),
    'simulate': ('simulate friction experiments of a wearing joint into a ROS 2 bag',
                 _add_simulate_arguments, _cmd_simulate),
    'segment': ('segment a bag or raw CSV into friction levels of eq. (3) (CSV out)',
                _add_segment_arguments, _cmd_segment),
    'replay': ('replay a recorded bag through the monitoring service',
               _add_replay_arguments, _cmd_replay),
    'demo': ('simulate an accelerated wear test, replay it and write a report',
             _add_demo_arguments, _cmd_demo),
    'audit': ('find and model what the friction model misses in measured friction levels',
              _add_audit_arguments, _cmd_audit),
    'history': ('show the stored wear history and export its friction levels for audit',
                _add_history_arguments, _cmd_history),
    'live': ('run both monitoring nodes on the live ROS 2 graph in one process (needs rclpy)',
             _add_live_arguments, _cmd_live),
    'play': ('play a recorded bag on the live ROS 2 graph, like ros2 bag play (needs rclpy)',
             _add_play_arguments, _cmd_play),
    'identify': ('identify a parameter set (models (5), (7), sigma) from friction levels',
                 _add_identify_arguments, _cmd_identify),
}


def build_parser() -> argparse.ArgumentParser:
    """Return the argparse parser of ``robot-wear-monitor`` with all its subcommands."""
    parser = argparse.ArgumentParser(
        prog=PROG, description='Wear monitoring of a robot joint from constant-speed friction '
                               'data (Bittencourt & Axelsson).')
    parser.add_argument('--version', action='version', version=f'%(prog)s {__version__}')
    subparsers = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for name, (help_text, add_arguments, handler) in _COMMANDS.items():
        sub = subparsers.add_parser(name, help=help_text, description=help_text)
        add_arguments(sub)
        sub.set_defaults(handler=handler)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code (0 success, 2 bad input)."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args: list[str] = []
    if '--ros-args' in argv:  # ROS arguments go to rclpy untouched (live, play)
        cut = argv.index('--ros-args')
        argv, ros_args = argv[:cut], argv[cut:]
    args = parser.parse_args(argv)  # argparse exits with 2 and a usage line on bad syntax
    if ros_args and args.command not in ('live', 'play'):
        parser.error(f'--ros-args is only for live and play, not {args.command}')
    args.ros_args = ros_args
    from robot_wear_monitor.blas_threads import use_single_blas_thread
    use_single_blas_thread()
    try:
        return int(args.handler(args) or 0)
    except InputError as error:
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        print(f'{PROG} {args.command}: error: {message}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'{PROG} {args.command}: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
