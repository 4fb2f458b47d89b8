"""``robot-wear-monitor design``: optimal speed levels for N friction levels, eqs. (22)-(25)."""

from __future__ import annotations

import argparse

from robot_wear_monitor.cli.options import (add_json, add_params, emit_json, params_from,
                                            parse_float_list, SPEED_COUNT, TEMPERATURE_DEGC,
                                            WEAR)
from robot_wear_monitor.errors import InputError

HELP = 'optimal speed levels for N friction levels, eqs. (22)-(25)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``design``."""
    parser.add_argument('--n', type=SPEED_COUNT, required=True,
                        help='number of speed levels N (1-20)')
    parser.add_argument('--grid', type=parse_float_list, metavar='V1,V2,...',
                        help='choose the best N speeds from this grid [rad/s] (Table V); '
                             'default: continuous optimum within the design bounds (Table IV)')
    parser.add_argument('--temperature', type=TEMPERATURE_DEGC, metavar='DEGC',
                        help='design temperature [degC] (default: from the parameter set)')
    parser.add_argument('--wear', type=WEAR, metavar='W',
                        help='design wear level (default: from the parameter set)')
    add_params(parser)
    add_json(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``design``: print the speeds [rad/s] and the cost of the optimal design."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    import numpy as np
    from robot_wear_monitor.estimation.design import best_grid_design, optimal_design
    params = params_from(args)
    params.require('wear', purpose='designing the experiment (22)-(25)')
    if args.n < 1:
        raise InputError(f'--n: the number of speed levels must be >= 1, got {args.n}')
    if args.grid is not None:
        result = best_grid_design(n=args.n, grid_rad_s=args.grid, params=params,
                                  temperature_degc=args.temperature, wear=args.wear)
    else:
        result = optimal_design(n=args.n, params=params, temperature_degc=args.temperature,
                                wear=args.wear)
    speeds = [round(float(v), 6) for v in result.speeds_rad_s]
    if emit_json(args, {'n': result.n, 'speeds': speeds, 'cost': float(result.cost)}):
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
