"""``robot-wear-monitor simulate``: friction experiments of a wearing joint into a ROS 2 bag."""

from __future__ import annotations

import argparse
from dataclasses import replace
import math
from pathlib import Path
from typing import Any, Callable

from robot_wear_monitor.atomic_files import write_json_atomic
from robot_wear_monitor.cli.options import (add_params, check_option, FINITE, params_from,
                                            parse_float_list)
from robot_wear_monitor.errors import InputError

HELP = 'simulate friction experiments of a wearing joint into a ROS 2 bag'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``simulate``."""
    parser.add_argument('--out', required=True, metavar='BAG', help='output bag directory')
    parser.add_argument('--experiments', type=int, default=100,
                        help='number of experiments k of the accelerated wear test (100)')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        default=[2.1, 28.5, 35.1, 41.7],
                        help='motor-side speeds [rad/s] (default: Table V, N = 4)')
    parser.add_argument('--wear-final', type=FINITE, default=60.0,
                        help='wear at the last experiment (default 60)')
    parser.add_argument('--sample-rate', type=FINITE, default=250.0, metavar='HZ',
                        help='JointState rate [Hz] (default 250)')
    parser.add_argument('--interval', type=FINITE, default=3600.0, metavar='S',
                        help='time between experiments [s] (default 3600)')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                        help='bag storage (default mcap)')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing bag')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    parser.add_argument('--start-time', metavar='TIME',
                        help='time of the first sample: ISO 8601 (UTC when no zone) or seconds '
                             'since the epoch (default 2024-01-01T00:00:00Z); consecutive '
                             'recordings of one robot start where the previous one ended')
    parser.add_argument('--joints', metavar='all|NAME[,NAME]',
                        help='the joints to test, one after another in each interval, each '
                             'with its own wear: "all" (the 6 joints of the simulated arm) or '
                             'names (default: joint_2 alone)')
    parser.add_argument('--start-wear', type=FINITE, metavar='W',
                        help='the true wear of every tested joint at the first experiment '
                             '(default about 1, a new joint)')
    parser.add_argument('--continue-from', metavar='TRUTH.json',
                        help="an earlier recording's truth file (<bag>.truth.json): each "
                             "joint's wear starts where it ended, and the first experiment one "
                             '--interval after its last sample (unless --start-time)')
    add_params(parser)


#: The most experiments one ``simulate`` writes (a 10^5-experiment bag is about 90 GB).
MAX_EXPERIMENTS = 100_000


def _simulate(simulate_scenario: Callable[..., Any], *, config: Any, params: Any,
              args: argparse.Namespace) -> Any:
    """Return the simulated scenario; an error names the option a user changes, not a field."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.experiment.planning import PlanError
    try:
        return simulate_scenario(config=config, model=params.model, seed=args.seed)
    except PlanError as error:
        # the plan follows from the speeds and the sample rate (a plateau needs enough samples)
        raise InputError(f'--speeds/--sample-rate: the experiment cannot be planned at '
                         f'{args.sample_rate:g} Hz: {error.detail} (raise --sample-rate or '
                         f'lower --speeds)') from None
    except InputError as error:
        text = str(error)
        if text.startswith('ScenarioConfig.experiment_interval_s:'):
            detail = text.split(':', 1)[1].strip()
            raise InputError(f'--interval {args.interval:g} s: {detail} (raise --interval)') \
                from None
        raise


def main(args: argparse.Namespace) -> int:
    """Run ``simulate``: write the bag and its truth JSON beside it."""
    # deferred import: start-up time (numpy, rosbags: not for --help)
    from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                          JointSimConfig, simulate_scenario,
                                                          truth_path_for, write_truth_json)
    from robot_wear_monitor.recordings.bags import write_joint_state_bag
    check_option(args.experiments, option='--experiments', low=1, high=MAX_EXPERIMENTS)
    check_option(args.wear_final, option='--wear-final', low=0.0, high=1000.0)
    check_option(args.sample_rate, option='--sample-rate', low=0.0, high=10_000.0, unit='Hz',
                 low_open=True)
    check_option(args.interval, option='--interval', low=0.0, high=1e7, unit='s',
                 low_open=True)
    for speed in args.speeds or ():
        check_option(speed, option='--speeds', low=0.0, high=10_000.0, unit='rad/s',
                     low_open=True)
    if Path(args.out).exists() and not args.overwrite:  # before minutes of simulation
        raise InputError(f'{args.out}: already exists (use --overwrite to replace it)')
    params = params_from(args)
    params.require('wear', 'temperature', 'load', purpose='simulating a wearing joint')
    config = accelerated_wear_scenario(
        n_experiments=args.experiments, speeds_rad_s=args.speeds, params=params,
        seed=args.seed, wear_final=args.wear_final, experiment_interval_s=args.interval,
        joint=JointSimConfig(sample_rate_hz=args.sample_rate))
    if args.start_time is not None:
        # deferred import: start-up time (cli.fleet: not for --help)
        from robot_wear_monitor.cli.fleet import parse_time
        start_s = parse_time(args.start_time, option='--start-time')
        if not math.isfinite(start_s) or not 0.0 <= start_s < 4.1e9:
            raise InputError(f'--start-time: must be between 1970 and 2099, got '
                             f'{args.start_time[:40]}')
        config = replace(config, start_time_s=start_s)
    if args.joints is not None or args.start_wear is not None or args.continue_from:
        return _plant(args, config=config, params=params)
    scenario = _simulate(simulate_scenario, config=config, params=params, args=args)
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


def _plant(args: argparse.Namespace, *, config: Any, params: Any) -> int:
    """Run ``simulate --joints/--start-wear/--continue-from``: several joints, wear continued."""
    # deferred import: start-up time (numpy, rosbags: not for --help)
    from robot_wear_monitor.experiment.plant_simulation import (continuation, plant_truth,
                                                                simulate_joints)
    from robot_wear_monitor.experiment.simulation import truth_path_for
    from robot_wear_monitor.recordings.bags import write_joint_state_bag
    names = config.joint.joint_names
    if args.joints is None:
        joints = [config.joint.joint]
    elif args.joints.strip() == 'all':
        joints = list(names)
    else:
        joints = [name.strip() for name in args.joints.split(',') if name.strip()]
        if not joints or len(set(joints)) != len(joints):
            raise InputError('--joints: give "all" or distinct joint names, NAME[,NAME]')
    start_wear: dict[str, float] = {}
    start_s = config.start_time_s
    if args.start_wear is not None:
        check_option(args.start_wear, option='--start-wear', low=0.0, high=1000.0)
        start_wear = {joint: args.start_wear for joint in joints}
    if args.continue_from:
        if args.start_wear is not None:
            raise InputError('--start-wear and --continue-from: give one of them')
        final, end_s = continuation(args.continue_from)
        missing = [joint for joint in joints if joint not in final]
        if missing:
            raise InputError(f'--continue-from {args.continue_from[:200]}: no wear of '
                             f'{", ".join(missing)[:200]} (it holds '
                             f'{", ".join(sorted(final))[:200]})')
        start_wear = {joint: final[joint] for joint in joints}
        if args.start_time is None:
            start_s = end_s + args.interval
    try:
        scenario = simulate_joints(
            joints=joints, n_experiments=args.experiments, speeds_rad_s=args.speeds,
            params=params, seed=args.seed, wear_final=args.wear_final,
            experiment_interval_s=args.interval, base=config.joint, start_time_s=start_s,
            start_wear=start_wear)
    except InputError as error:
        if str(error).startswith('ScenarioConfig.experiment_interval_s:'):
            raise InputError(f'--interval {args.interval:g} s: '
                             f'{str(error).split(":", 1)[1].strip()} (raise --interval)') \
                from None
        raise
    bag = write_joint_state_bag(args.out, stamps_s=scenario.time_s, names=scenario.joint_names,
                                position=scenario.position_rad,
                                velocity=scenario.velocity_rad_s, effort=scenario.effort,
                                storage=args.storage, overwrite=args.overwrite)
    truth = write_json_atomic(truth_path_for(bag), plant_truth(scenario))
    starts = ', '.join(f'{joint} from w {start_wear.get(joint, 1.0):.1f}' for joint in joints)
    print(f'{bag}: {scenario.n_samples} JointState messages on /joint_states '
          f'({args.experiments} experiments of each of {len(joints)} joints: {starts}); '
          f'truth: {truth} (replay ... --joint all)')
    return 0
