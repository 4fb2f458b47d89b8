"""``robot-wear-monitor estimate``: temperature and wear from friction levels, eqs. (16)-(19)."""

from __future__ import annotations

import argparse
import math

from robot_wear_monitor.cli.options import (add_json, add_params, emit_json, params_from,
                                            parse_float_list)
from robot_wear_monitor.errors import InputError

HELP = 'estimate temperature and wear from friction levels, eqs. (16)-(19)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``estimate``."""
    parser.add_argument('--speeds', type=parse_float_list, required=True, metavar='V1,V2,...',
                        help='motor-side speed levels [rad/s]')
    parser.add_argument('--friction', type=parse_float_list, required=True, metavar='F1,F2,...',
                        help='friction levels (normalised torque), one per speed')
    add_params(parser)
    add_json(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``estimate``: print T-hat [degC] and w-hat with 95 % intervals and the alarm."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.estimation.plausibility import UNIT_CAUSE
    from robot_wear_monitor.estimation.wear_report import wear_report
    params = params_from(args)
    if len(args.speeds) != len(args.friction):
        raise InputError(f'--speeds has {len(args.speeds)} values but --friction has '
                         f'{len(args.friction)}: give one friction level per speed')
    report = wear_report(speeds_rad_s=args.speeds, frictions=args.friction, params=params)
    # levels in another unit than the set's are a user mistake: named, and exit 2 (the JSON
    # and the text are still printed)
    status = 2 if report.plausibility.likely_cause.startswith(UNIT_CAUSE) else 0
    if emit_json(args, report.to_dict()):
        return status
    est, interval, wear_std = report.estimate, report.interval, report.wear_std
    t_note = ' (on a bound)' if est.temperature_at_bound else ''
    w_note = ' (on w = 0)' if est.wear_at_bound else ''
    if est.n_levels == 1:
        t_note = (' (posterior mean, N = 1)' if report.wear_determined
                  else f' (N = 1){t_note}')
    p_text = ('n/a (dof = 0)' if not math.isfinite(est.p_value) else f'{est.p_value:.3f}'
              if est.p_value >= 1e-3 else f'{est.p_value:.2g}')
    above = '+' if interval.wear_high_at_grid_end else ''
    w_std = f' +- {wear_std:.2f}' if math.isfinite(wear_std) else ''
    if report.wear_determined:
        wear_row = (f'{est.wear:8.2f}  95 % [{interval.wear_low:.1f}, '
                    f'{interval.wear_high:.1f}{above}]{w_std}{w_note}')
        alarm_row = (f'{"YES" if report.alarm else "no"} (threshold w >= '
                     f'{params.wear_threshold:g})' if report.plausibility.valid else
                     'CANNOT JUDGE (the estimate is invalid, see below)')
    else:
        wear_row = (f'not determined (parameter set {params.name!r} has no wear model: '
                    'identify --no-wear-model; temperature only)')
        alarm_row = 'none (no wear model)'
    rows = [('temperature [degC]', f'{est.temperature_degc:8.2f}  95 % '
             f'[{interval.temperature_low:.1f}, {interval.temperature_high:.1f}]{t_note}'),
            ('wear w [-]', wear_row),
            ('alarm', alarm_row),
            ('chi2 / dof', f'{est.chi2:8.3f} / {est.dof}'),
            ('p-value', p_text)]
    print(f'{"wear" if report.wear_determined else "temperature"} estimate from N = '
          f'{est.n_levels} level(s) at '
          f'{", ".join(f"{v:g}" for v in est.speeds_rad_s)} rad/s')
    for name, value in rows:
        print(f'  {name:<20}{value}')
    if not report.plausibility.valid:
        print('INVALID: ' + report.plausibility.text())
    return status
