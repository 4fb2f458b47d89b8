"""
``robot-wear-monitor history``: the stored wear history; its levels as a CSV for audit.

``--alarms``: the fleet's alarm log instead (raised, acknowledged and reset events of every
robot, newest first, with who and why) as a table, ``--csv`` or ``--json``, for audits.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
from pathlib import Path
from typing import Any, Sequence

from robot_wear_monitor.cli.options import (add_display_timezone, add_json, add_local,
                                            add_robot, display_zone, emit_json, PROG,
                                            shown_location)
from robot_wear_monitor.cli.outputs import to_terminal, write_text_output
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import is_postgresql_url, open_history, write_levels_csv
from robot_wear_monitor.history.alarms import event_time_s, note_text
from robot_wear_monitor.json_values import finite_or_none
from robot_wear_monitor.text import iso_time, LINE_LIMIT, shorten, shown_time

HELP = 'show the stored wear history and export its friction levels for audit'

#: The columns of ``history --alarms --csv`` (and the keys of its ``--json`` rows).
ALARM_LOG_COLUMNS = ('id', 'time', 'robot', 'joint', 'event', 'wear', 'user', 'owner',
                     'planned_maintenance', 'note', 'note_text', 'work_order', 'source',
                     'changes')


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``history``."""
    parser.add_argument('database', metavar='DB',
                        help='wear history: an SQLite file, or postgresql://USER@HOST:PORT/DB')
    add_robot(parser, help_text='robot to show (default: the only robot stored)')
    parser.add_argument('--joint', help='joint to show (default: the only joint stored)')
    parser.add_argument('--last', type=int, metavar='K', help='show only the last K estimates '
                        '(with --alarms: the newest K events)')
    parser.add_argument('--csv', metavar='LEVELS', nargs='?', const='-',
                        help='export the friction levels as a CSV table for '
                        '`robot-wear-monitor audit`; with --alarms: print the alarm log as CSV '
                        '(or write it to the file LEVELS)')
    parser.add_argument('--alarms', action='store_true',
                        help="show the fleet's alarm log: raised, acknowledged (edited, "
                        'withdrawn) and reset events of every robot (or --robot, --joint), '
                        'newest first, with user, owner, planned maintenance, note and work '
                        'order')
    add_local(parser)
    add_display_timezone(parser)
    add_json(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``history``: a table of the estimates (or ``--json``), ``--csv`` the levels."""
    if not is_postgresql_url(args.database) and not Path(args.database).is_file():
        raise InputError(f'{shown_location(args.database)}: no such wear history database')
    if args.last is not None and args.last < 1:
        raise InputError(f'--last must be >= 1, got {args.last}')
    display_zone(args)  # --local with --display-timezone: exit 2 before anything is read
    if args.alarms:
        return alarm_log_main(args)
    if args.csv == '-':
        raise InputError('--csv needs the file to write the levels to: --csv LEVELS')
    where = shown_location(args.database)
    with open_history(args.database, init=False) as history:
        robots = history.robots()
        robot = args.robot
        if robot is None:
            if len(robots) > 1:
                raise InputError(f'{where}: holds robots {", ".join(robots)}; '
                                 'choose one with --robot')
            robot = robots[0] if robots else history.robot
        elif robot not in robots:
            raise InputError(f'{where}: no estimates of robot {robot!r} '
                             f'(stored: {", ".join(robots) or "none"})')
        joints = history.joints(robot=robot)
        joint = args.joint
        if joint is None:
            if len(joints) != 1:
                raise InputError(f'{where}: holds joints {", ".join(joints) or "none"}; '
                                 'choose one with --joint')
            joint = joints[0]
        elif joint not in joints:
            raise InputError(f'{where}: no estimates for joint {joint!r} '
                             f'(stored: {", ".join(joints) or "none"})')
        state = history.restore(joint=joint, robot=robot)
        records = history.records(joint=joint, robot=robot, limit=args.last)
    if args.csv:
        write_levels_csv(args.csv, records=records)
    rows = [_row(r) for r in records]
    payload = {
        'robot': robot, 'joint': joint, 'alarm_active': state.alarm_active, 'csv': args.csv,
        'estimates': [{'id': r.id, 'stamp_s': r.stamp_s, 'time': iso_time(r.stamp_s),
                       'speeds': list(r.speeds_rad_s), 'frictions': list(r.frictions),
                       'wear': finite_or_none(r.wear), 'wear_std': finite_or_none(std),
                       'wear_interval': [finite_or_none(r.wear_low), finite_or_none(r.wear_high)],
                       'temperature_degc': finite_or_none(r.temperature_degc),
                       'p_value': finite_or_none(r.p_value), 'alarm': r.alarm_active,
                       'valid': r.valid, 'invalid_reason': r.invalid_reason or None,
                       'threshold': finite_or_none(r.threshold),
                       'warning_level': finite_or_none(r.warning_level)}
                      for r, std in rows]}
    if emit_json(args, payload):
        return 0
    print(f'robot {shorten(robot, LINE_LIMIT)}, joint {shorten(joint, LINE_LIMIT)}: '
          f'{len(records)} estimate(s) '
          f'shown; alarm {"LATCHED" if state.alarm_active else "clear"}; times '
          f'{times_in(args)}')
    header = ('id', 'time', 'w', '95 % interval of w', 'std w', 'T [degC]', 'p-value')

    def cell(value: float, spec: str) -> str:  # '-' where the estimate reported none
        return format(value, spec) if math.isfinite(value) else '-'
    zone = display_zone(args)
    lines = [(str(r.id), shown_time(r.stamp_s, local=args.local, zone=zone),
              cell(r.wear, '.2f'),
              f'[{cell(r.wear_low, ".1f")}, {cell(r.wear_high, ".1f")}]'
              if math.isfinite(r.wear_low) else '-',
              cell(std, '.2f'), cell(r.temperature_degc, '.2f'), cell(r.p_value, '.3g'),
              'INVALID: ' + shorten(r.invalid_reason, LINE_LIMIT) if not r.valid
              else 'yes' if r.alarm_active else '') for r, std in rows]
    print(estimate_table(header, lines))
    if args.csv:
        print(f'levels written to {args.csv}; ' + audit_hint(args.csv, records))
    return 0


#: The minimum widths of the estimate table's columns (id .. p-value) and their alignment.
ESTIMATE_WIDTHS = (5, 20, 7, 18, 7, 9, 8)
ESTIMATE_RIGHT = (True, False, True, False, True, True, True)


def estimate_table(header: Sequence[str], lines: Sequence[Sequence[str]]) -> str:
    """
    Return the estimate table: each column as wide as its widest text, ``alarm`` last.

    The widths come from the formatted texts, so a longer cell (a local time with its UTC
    offset, ``2024-01-01T01:00:12+01:00``) widens its column instead of shifting the row.
    """
    widths = [max(least, len(h), *(len(line[i]) for line in lines))
              for i, (least, h) in enumerate(zip(ESTIMATE_WIDTHS, header))]

    def row(cells: Sequence[str], last: str) -> str:
        text = ' '.join(c.rjust(w) if right else c.ljust(w)
                        for c, w, right in zip(cells, widths, ESTIMATE_RIGHT))
        return f'{text}  {last}'
    return '\n'.join([row(header, 'alarm')] + [row(line[:-1], line[-1]) for line in lines])


def _row(record: Any) -> tuple[Any, float]:
    """Return (record, the std of w-hat the estimate reported: NaN where it reports none)."""
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.estimation.wear_report import meaningful_std
    return record, meaningful_std(std=record.wear_std, value=record.wear, low=record.wear_low,
                                  high=record.wear_high, open_above=False)


def audit_hint(csv: str, records: Any) -> str:
    """Return what to run on the exported levels (audit needs 6 or more distinct speeds)."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.audit.run import MIN_SPEEDS
    speeds = sorted(float(v) for r in records for v in r.speeds_rad_s)
    distinct = sum(1 for i, v in enumerate(speeds) if i == 0 or v > speeds[i - 1] * 1.02)
    if distinct >= MIN_SPEEDS:
        return f'run: {PROG} audit {csv}'
    return (f'the audit needs levels at {MIN_SPEEDS} or more distinct speeds and these '
            f"have {distinct} (the designed experiment's): plan extra experiments at other "
            f'speeds (`{PROG} plan --speeds ...`) to audit the model on this joint')


def times_in(args: argparse.Namespace) -> str:
    """Return the zone the text's times are in, in words ('UTC', 'local', the zone's name)."""
    if getattr(args, 'display_timezone', None):
        return shorten(args.display_timezone, 60)
    return 'local' if args.local else 'UTC'


def alarm_log_rows(events: Any, *, local: bool = False) -> list[dict[str, Any]]:
    """
    Return the alarm events as rows of :data:`ALARM_LOG_COLUMNS` (plus raw times, ids).

    ``time``/``event_time_s``: the event's time in the log (a raise's experiment stamp, an
    acknowledgement's or a reset's wall time); ``note_text``: the note in words.
    """
    return [{'id': e.id, 'time': iso_time(event_time_s(e), local=local), 'robot': e.robot,
             'joint': e.joint, 'event': e.event,
             'wear': None if e.wear is None else finite_or_none(e.wear), 'user': e.user,
             'owner': e.owner, 'planned_maintenance': e.planned_maintenance, 'note': e.note,
             'note_text': note_text(e), 'event_time_s': finite_or_none(event_time_s(e)),
             'work_order': e.work_order, 'source': e.source, 'changes': e.changes,
             'stamp_s': finite_or_none(e.stamp_s), 'wall_time_s': finite_or_none(e.wall_time_s),
             'estimate_id': e.estimate_id} for e in events]


def alarm_log_main(args: argparse.Namespace) -> int:
    """Run ``history --alarms``: the fleet's alarm log as a table, ``--csv`` or ``--json``."""
    # deferred import: start-up time (csv_cells: not for --help)
    from robot_wear_monitor.csv_cells import csv_text
    if args.csv and (args.json or args.json_out):
        raise InputError('--alarms: give --csv or --json, not both')
    with open_history(args.database, init=False) as history:
        events = history.alarm_log(robot=args.robot, joint=args.joint, limit=args.last)
    rows = alarm_log_rows(events, local=args.local)
    if emit_json(args, {'robot': args.robot, 'joint': args.joint, 'alarms': rows}):
        return 0
    if args.csv:
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator='\n')
        writer.writerow(ALARM_LOG_COLUMNS)
        terminal = to_terminal(args.csv)
        for row in rows:
            writer.writerow(['' if row[c] is None else
                             format(row[c], '.6g') if c == 'wear' else
                             row[c] if isinstance(row[c], int) else
                             csv_text(str(row[c]), terminal=terminal)
                             for c in ALARM_LOG_COLUMNS])
        if write_text_output(args.csv, buffer.getvalue()):
            print(f'{len(rows)} alarm events written to {args.csv}')
        return 0
    print(f'{len(rows)} alarm event(s), newest first; times {times_in(args)}')
    zone = display_zone(args)
    header = ('id', 'time', 'robot', 'joint', 'event', 'wear', 'user', 'owner', 'planned',
              'work_order', 'note')
    lines = [(str(r['id']), shown_time(r['event_time_s'], local=args.local, zone=zone),
              shorten(r['robot'], 40),
              shorten(r['joint'], 40), r['event'],
              '-' if r['wear'] is None else f'{r["wear"]:.1f}', shorten(r['user'], 40),
              shorten(r['owner'], 40), r['planned_maintenance'] or '-',
              shorten(r['work_order'], 40) or '-',
              shorten(r['note_text'], 160)) for r in rows]
    widths = [max(len(h), *(len(line[i]) for line in lines)) if lines else len(h)
              for i, h in enumerate(header)]
    print('  '.join(h.ljust(w) for h, w in zip(header, widths)).rstrip())
    for line in lines:
        print('  '.join(c.ljust(w) for c, w in zip(line, widths)).rstrip())
    return 0
