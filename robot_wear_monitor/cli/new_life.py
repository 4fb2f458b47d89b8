"""
``robot-wear-monitor new-life``: record maintenance or a replacement, the joint's new life.

The same write as the dashboard's reset (``POST /api/robots/R/joints/J/reset``):
:meth:`~robot_wear_monitor.history.WearHistory.reset_alarm`, with or without a latched alarm
(a preventive replacement is a new life too), the event stored with the source ``cli``.  The
old life stays in the history.  An unknown robot or joint, or a joint reset already with no
experiment since, is an error on stderr with exit code 2.
"""

from __future__ import annotations

import argparse

from robot_wear_monitor.cli.acknowledge import (add_person_options, add_work_order,
                                                chosen_robot, print_event)
from robot_wear_monitor.cli.history import alarm_log_rows
from robot_wear_monitor.cli.options import add_json
from robot_wear_monitor.history import open_history

HELP = ('record maintenance or a replacement of a joint (with or without an alarm): its new '
        "life starts, as the dashboard's reset")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``new-life``."""
    add_person_options(parser)
    parser.add_argument('--reason', metavar='TEXT', required=True,
                        help='what was done (non-empty, at most 2000 characters)')
    add_work_order(parser)
    add_json(parser, what='the stored event (the keys of /api/alarms)')


def main(args: argparse.Namespace) -> int:
    """Run ``new-life``: store the reset and print the event."""
    with open_history(args.history, init=False) as history:
        args.robot = chosen_robot(history, args)
        event = alarm_log_rows([history.reset_alarm(
            joint=args.joint, robot=args.robot, user=args.by, reason=args.reason,
            work_order=args.work_order or '', source='cli')])[0]
    print_event(args, event, what='new life')
    return 0
