"""``robot-wear-monitor history``: the stored wear history; its levels as a CSV for audit."""

from __future__ import annotations

import argparse

from robot_wear_monitor.cli.options import add_json, add_robot, emit_json, PROG
from robot_wear_monitor.errors import InputError

HELP = 'show the stored wear history and export its friction levels for audit'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``history``."""
    parser.add_argument('database', metavar='DB',
                        help='wear history: an SQLite file, or postgresql://USER@HOST:PORT/DB')
    add_robot(parser, help_text='robot to show (default: the only robot stored)')
    parser.add_argument('--joint', help='joint to show (default: the only joint stored)')
    parser.add_argument('--last', type=int, metavar='K', help='show only the last K estimates')
    parser.add_argument('--csv', metavar='LEVELS', help='export the friction levels as a CSV '
                        'table for `robot-wear-monitor audit`')
    add_json(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``history``: a table of the estimates (or ``--json``), ``--csv`` the levels."""
    import math
    from pathlib import Path

    from robot_wear_monitor.monitoring.diagnostics import json_number
    from robot_wear_monitor.monitoring.history import (is_postgresql_url, open_history,
                                                       write_levels_csv)

    if not is_postgresql_url(args.database) and not Path(args.database).is_file():
        raise InputError(f'{args.database}: no such wear history database')
    if args.last is not None and args.last < 1:
        raise InputError(f'--last must be >= 1, got {args.last}')
    with open_history(args.database, init=False) as history:
        robots = history.robots()
        robot = args.robot
        if robot is None:
            if len(robots) > 1:
                raise InputError(f'{args.database}: holds robots {", ".join(robots)}; '
                                 'choose one with --robot')
            robot = robots[0] if robots else history.robot
        elif robot not in robots:
            raise InputError(f'{args.database}: no estimates of robot {robot!r} '
                             f'(stored: {", ".join(robots) or "none"})')
        joints = history.joints(robot=robot)
        joint = args.joint
        if joint is None:
            if len(joints) != 1:
                raise InputError(f'{args.database}: holds joints {", ".join(joints) or "none"}; '
                                 'choose one with --joint')
            joint = joints[0]
        elif joint not in joints:
            raise InputError(f'{args.database}: no estimates for joint {joint!r} '
                             f'(stored: {", ".join(joints) or "none"})')
        state = history.restore(joint=joint, robot=robot)
        records = history.records(joint=joint, robot=robot, limit=args.last)
    if args.csv:
        write_levels_csv(args.csv, records=records)
    payload = {
        'robot': robot, 'joint': joint, 'alarm_active': state.alarm_active, 'csv': args.csv,
        'estimates': [{'id': r.id, 'stamp_s': r.stamp_s, 'speeds': list(r.speeds_rad_s),
                       'frictions': list(r.frictions), 'wear': json_number(r.wear),
                       'wear_std': json_number(r.wear_std),
                       'temperature_degc': json_number(r.temperature_degc),
                       'p_value': json_number(r.p_value), 'alarm': r.alarm_active}
                      for r in records]}
    if emit_json(args, payload):
        return 0
    print(f'robot {robot}, joint {joint}: {len(records)} estimate(s) shown; alarm '
          f'{"LATCHED" if state.alarm_active else "clear"}')
    header = ('id', 'stamp [s]', 'w', 'std w', 'T [degC]', 'p-value')
    print('{:>5} {:>14} {:>7} {:>7} {:>9} {:>8}  alarm'.format(*header))

    def cell(value: float, spec: str) -> str:  # '-' where the estimate reported none
        return format(value, spec) if math.isfinite(value) else '-'
    for r in records:
        print(f'{r.id:>5} {r.stamp_s:>14.1f} {cell(r.wear, ".2f"):>7} '
              f'{cell(r.wear_std, ".2f"):>7} {cell(r.temperature_degc, ".2f"):>9} '
              f'{cell(r.p_value, ".3g"):>8}  {"yes" if r.alarm_active else ""}')
    if args.csv:
        print(f'levels written to {args.csv} (run: {PROG} audit {args.csv})')
    return 0
