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
import json
import math
import shutil
import sys
import time
from typing import Any, Iterable

from robot_wear_monitor.cli.fleet_options import add_declared_options
from robot_wear_monitor.cli.options import (add_display_timezone, add_history, add_json,
                                            add_local, add_robot, display_zone, shown_location,
                                            write_json_out)
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


def print_rows_json(rows: Iterable[dict[str, Any]]) -> int:
    """
    Print ``rows`` as one indented JSON list on stdout, each row written as it comes.

    The text of :func:`~robot_wear_monitor.cli.options.print_json` of the list (no NaN or
    inf), without holding the rows: return how many were written.
    """
    count = 0
    for row in rows:
        text = json.dumps(row, indent=2, allow_nan=False).replace('\n', '\n  ')
        sys.stdout.write(('[\n  ' if not count else ',\n  ') + text)
        count += 1
    sys.stdout.write('\n]\n' if count else '[]\n')
    return count


def main(args: argparse.Namespace) -> int:
    """Run ``fleet``: the ranked rows as a table, ``--json`` or ``--csv``."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.fleet.fleet_table import DEFAULT_WIDTH, fleet_table
    from robot_wear_monitor.fleet.indexed import fleet_clock, stream_views
    from robot_wear_monitor.fleet.ranking import fleet_csv_rows, plural
    from robot_wear_monitor.fleet.states import DAY_S, STATES
    now_s = parse_time(args.now) if args.now else time.time()
    zone = display_zone(args)
    # checked by the options' types: the notification configuration's declared ranges
    with open_history(args.history, init=False) as history:
        index = history.fleet_index()
        if args.robot and not index.has_robot(args.robot):
            raise InputError(f'{shown_location(args.history)}: no estimates of robot '
                             f'{args.robot!r}')
        clock = fleet_clock(index, now_s=now_s, reescalation_margin=args.reescalation_margin,
                            forecast_horizon_s=args.forecast_horizon_days * DAY_S)
        views = stream_views(index, clock, robot=args.robot)  # read a chunk at a time
        if args.json and not args.json_out:  # streamed: one JSON list, row by row
            print_rows_json(row.as_json() for row in views)
            return 0
        rows = list(views)
        # the owner, comment and work order of each acknowledgement (the table's detail lines)
        acknowledgements = {} if args.json or args.json_out or args.csv else {
            (row.state.robot, row.state.joint): history.acknowledgement(
                joint=row.state.joint, robot=row.state.robot)
            for row in rows if row.state.acknowledged}
    write_json_out(args.json_out, [row.as_json() for row in rows] if args.json_out else None)
    if args.json:
        print_rows_json(row.as_json() for row in rows)
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
