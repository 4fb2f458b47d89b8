"""``robot-wear-monitor study``: Monte Carlo bias/variance of the wear estimator (Fig. 8)."""

from __future__ import annotations

import argparse

from robot_wear_monitor.cli.options import (add_json, add_params, bounded, emit_json,
                                            params_from, parse_float_list, parse_range,
                                            SPEED_COUNT, WEAR)
from robot_wear_monitor.errors import InputError

HELP = 'Monte Carlo bias/variance study of the wear estimator (Sec. IV-C, Fig. 8)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``study``."""
    parser.add_argument('--n', type=SPEED_COUNT, required=True,
                        help='number of speed levels N (1-20)')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        help='speed levels [rad/s] (default: the optimal design for N)')
    parser.add_argument('--temperatures', type=parse_range, default=parse_range('30:50:1'),
                        metavar='START:STOP:STEP',
                        help='true temperatures [degC] (default 30:50:1)')
    parser.add_argument('--wear', type=WEAR, default=35.0, help='true wear level (default 35)')
    parser.add_argument('--runs', type=bounded(1, 100_000, integer=True), default=1000,
                        help='Monte Carlo runs per temperature (1-100000)')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    add_params(parser)
    add_json(parser)
    parser.add_argument('--plot', metavar='PNG', help='draw bias and variance like Fig. 8')


def main(args: argparse.Namespace) -> int:
    """Run ``study``: print bias, variance, MSE and CRB of w-hat per true temperature."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.estimation.design import optimal_design
    from robot_wear_monitor.estimation.study import plot_study, run_study
    params = params_from(args)
    params.require('wear', purpose='the Monte Carlo study of the estimator')
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
    if emit_json(args, result.to_dict()):
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
