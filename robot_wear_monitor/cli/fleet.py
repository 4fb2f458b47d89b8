"""
``robot-wear-monitor fleet``: every robot joint of a history, worst first.

The ranking and its texts are :mod:`robot_wear_monitor.fleet.ranking`; this verb reads the
options and prints a text table (default: it fits the terminal, or 100 columns; ``--wide``: one
line per joint, :mod:`robot_wear_monitor.fleet.fleet_table`), ``--json`` (a list of objects) or
``--csv``.  The table's times are in ``--display-timezone``; JSON and CSV stay UTC.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import io
import math
import shutil
import time

from robot_wear_monitor.cli.fleet_options import add_declared_options
from robot_wear_monitor.cli.options import (add_display_timezone, add_history, add_json,
                                            add_local, add_robot, display_zone, emit_json,
                                            shown_location)
from robot_wear_monitor.cli.outputs import to_terminal, write_text_output
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import open_history

HELP = 'every robot joint of a wear history, worst first (alarm, forecast crossing, wear)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``fleet``."""
    add_history(parser, help_text="the fleet's wear history", required=True)
    add_robot(parser, help_text="show only this robot's joints")
    parser.add_argument('--csv', nargs='?', const='-', metavar='PATH',
                        help='print the rows as CSV (or write them to PATH)')
    parser.add_argument('--now', metavar='TIME',
                        help='judge staleness at this time: ISO 8601 (e.g. '
                             '2026-11-24T12:00:00Z) or seconds since the epoch '
                             '(default: the clock)')
    # --forecast-horizon-days, --reescalation-margin: the notification configuration's
    add_declared_options(parser, 'fleet')
    parser.add_argument('--wide', action='store_true',
                        help='one line per joint with every column, however wide (default: '
                             'the table fits the terminal, at least 80 columns, or 100 when '
                             'not a terminal; long texts on a detail line below each joint)')
    add_local(parser)
    add_display_timezone(parser)
    add_json(parser, what='the rows (a list of objects)')


def parse_time(text: str, *, option: str = '--now') -> float:
    """Return seconds since the epoch of an ISO 8601 time (UTC when no zone) or a number."""
    try:
        value = float(text)
    except ValueError:
        pass
    else:
        if not math.isfinite(value):
            raise InputError(f'{option}: not a finite time: {text[:40]!r}')
        return value
    try:
        moment = datetime.datetime.fromisoformat(text.replace('Z', '+00:00'))
    except ValueError:
        raise InputError(f'{option}: not an ISO 8601 time or a number: {text[:40]!r}') from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=datetime.timezone.utc)
    return moment.timestamp()


def main(args: argparse.Namespace) -> int:
    """Run ``fleet``: the ranked rows as a table, ``--json`` or ``--csv``."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.fleet.fleet_table import DEFAULT_WIDTH, fleet_table
    from robot_wear_monitor.fleet.ranking import fleet_csv_rows, fleet_view, plural
    from robot_wear_monitor.fleet.states import DAY_S, STATES
    now_s = parse_time(args.now) if args.now else time.time()
    zone = display_zone(args)
    # checked by the options' types: the notification configuration's declared ranges
    with open_history(args.history, init=False) as history:
        rows = fleet_view(history.fleet(robot=args.robot), now_s=now_s,
                          reescalation_margin=args.reescalation_margin,
                          forecast_horizon_s=args.forecast_horizon_days * DAY_S)
        # the owner, comment and work order of each acknowledgement (the table's detail lines)
        acknowledgements = {} if args.json or args.json_out or args.csv else {
            (row.state.robot, row.state.joint): history.acknowledgement(
                joint=row.state.joint, robot=row.state.robot)
            for row in rows if row.state.acknowledged}
    if args.robot and not rows:
        raise InputError(f'{shown_location(args.history)}: no estimates of robot '
                         f'{args.robot!r}')
    if emit_json(args, [row.as_json() for row in rows]):
        return 0
    if args.csv:
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator='\n').writerows(fleet_csv_rows(
            rows, local=args.local, terminal=to_terminal(args.csv)))
        if write_text_output(args.csv, buffer.getvalue()):
            print(f'{len(rows)} rows written to {args.csv}')
        return 0
    if not rows:
        print(f'{shown_location(args.history)}: no estimates yet')
        return 0
    robots = len({row.state.robot for row in rows})
    counts = [(name, sum(1 for row in rows if row.condition == name)) for name in STATES]
    print(f'{plural(robots, "robot")}, {plural(len(rows), "joint")}: '
          + ', '.join(f'{count} {name}' for name, count in counts if count) + ' (worst first)')
    print(fleet_table(rows, local=args.local, zone=zone, wide=args.wide,
                      width=shutil.get_terminal_size((DEFAULT_WIDTH, 24)).columns,
                      acknowledgements=acknowledgements))
    return 0
