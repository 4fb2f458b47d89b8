"""
``robot-wear-monitor acknowledge``: take a latched alarm on, or edit its acknowledgement.

The same write as the dashboard's API (``POST /api/robots/R/joints/J/acknowledge`` and
``.../acknowledgement/edit``): :meth:`~robot_wear_monitor.history.WearHistory.acknowledge_alarm`
and :meth:`~robot_wear_monitor.history.WearHistory.edit_acknowledgement`, the event stored with
the source ``cli``.  The same rules: a planned maintenance date before today (UTC) is refused
unless ``--allow-past-date`` (:func:`~robot_wear_monitor.dashboard.planned_dates.checked_date`);
``--edit`` changes only the options given (the others are kept); an unknown robot or joint,
no latched alarm, or an alarm acknowledged already (without ``--edit``) is an error on stderr
with exit code 2.
"""

from __future__ import annotations

import argparse
from typing import Any, Callable

from robot_wear_monitor.cli.history import alarm_log_rows
from robot_wear_monitor.cli.options import (add_history, add_json, add_robot, emit_json,
                                            shown_location)
from robot_wear_monitor.dashboard.planned_dates import checked_date
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import open_history, WearHistory
from robot_wear_monitor.text import shorten

HELP = ("acknowledge a joint's latched alarm (who takes it on, the planned maintenance date, "
        'the work order) or edit the acknowledgement, as the dashboard does')


def add_person_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--history``, ``--robot``, ``--joint`` and ``--by``: where and who (write verbs)."""
    add_history(parser, help_text="the fleet's wear history", required=True)
    add_robot(parser, help_text="the joint's robot (default: the history's only robot)")
    parser.add_argument('--joint', metavar='NAME', required=True, help='the joint')
    parser.add_argument('--by', metavar='NAME', required=True,
                        help='who does it (1-128 printable characters; stored as the user)')


def add_work_order(parser: argparse.ArgumentParser) -> None:
    """Add ``--work-order``: the maintenance system's work order."""
    parser.add_argument('--work-order', metavar='TEXT',
                        help="the maintenance system's work order (at most 128 printable "
                             "characters; '' clears it with --edit)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``acknowledge``."""
    add_person_options(parser)
    parser.add_argument('--owner', metavar='NAME',
                        help='who takes the maintenance on (default: --by)')
    parser.add_argument('--comment', metavar='TEXT',
                        help='free text (at most 2000 characters)')
    parser.add_argument('--planned-maintenance', metavar='YYYY-MM-DD',
                        help="the planned maintenance date ('' clears it with --edit)")
    add_work_order(parser)
    parser.add_argument('--allow-past-date', action='store_true',
                        help='record a planned maintenance date that has passed (a late '
                             'entry; else refused, as the API refuses it)')
    parser.add_argument('--edit', action='store_true',
                        help='edit the current acknowledgement: only the options given '
                             'change, the others are kept')
    add_json(parser, what='the stored event (the keys of /api/alarms)')


def _acknowledgement(history: Any, args: argparse.Namespace) -> Callable[[], Any]:
    """Return the write of ``args`` on ``history`` (acknowledge or edit), source ``cli``."""
    where = {'joint': args.joint, 'robot': args.robot, 'user': args.by, 'source': 'cli'}
    if args.edit:
        def kept() -> str:
            current = history.acknowledgement(joint=args.joint, robot=args.robot)
            return current.planned_maintenance if current is not None else ''
        return checked_date(lambda: history.edit_acknowledgement(
            **where, owner=args.owner, comment=args.comment,
            planned_maintenance=args.planned_maintenance, work_order=args.work_order),
            planned=args.planned_maintenance, allow_past=args.allow_past_date, kept=kept)
    return checked_date(lambda: history.acknowledge_alarm(
        **where, owner=args.by if args.owner is None else args.owner,
        comment=args.comment or '', planned_maintenance=args.planned_maintenance or '',
        work_order=args.work_order or ''),
        planned=args.planned_maintenance, allow_past=args.allow_past_date)


def print_event(args: argparse.Namespace, event: dict[str, Any], *, what: str) -> None:
    """Print a stored event: its JSON (``--json``) or one line of what was stored."""
    if emit_json(args, event):
        return
    fields = [f'{name.replace("_", " ")} {shorten(event[name], 80)}'
              for name in ('owner', 'planned_maintenance', 'work_order') if event.get(name)]
    if event.get('changes'):
        fields.append(f'changed: {shorten(event["changes"], 200)}')
    print(f'{what}: robot {shorten(event["robot"], 60)} joint {shorten(event["joint"], 60)} '
          f'by {shorten(event["user"], 60)} (source cli, event {event["id"]})'
          + ''.join(f'; {text}' for text in fields))


def chosen_robot(history: WearHistory, args: argparse.Namespace) -> str:
    """Return ``--robot``, or the history's only robot (an error naming how many otherwise)."""
    if args.robot is not None:
        return str(args.robot)
    robots = history.robots()
    if len(robots) != 1:
        raise InputError(f'{shown_location(args.history)}: give --robot (the history holds '
                         f'{len(robots)} robots)')
    return str(robots[0])


def main(args: argparse.Namespace) -> int:
    """Run ``acknowledge``: store the acknowledgement (or its edit) and print the event."""
    with open_history(args.history, init=False) as history:
        args.robot = chosen_robot(history, args)
        event = alarm_log_rows([_acknowledgement(history, args)()])[0]
    print_event(args, event, what='acknowledgement edited' if args.edit else 'acknowledged')
    return 0
