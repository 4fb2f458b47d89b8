"""
``robot-wear-monitor notify``: send the fleet's events by webhook and e-mail, once each.

The events, their keys and the once-only claims are
:mod:`robot_wear_monitor.fleet.notifications`; the configuration file is read by
:func:`~robot_wear_monitor.fleet.notify_config.load_notification_config`.  Without ``--once``
the verb runs a pass every ``--interval-s`` seconds until Ctrl-C (a pass that cannot read the
history is reported on stderr and the loop goes on); with ``--once`` it runs one pass (for
cron) and exits 0 when every send was delivered, 1 when one failed (it is retried on the next
pass), 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from typing import Any, TYPE_CHECKING

from robot_wear_monitor.cli.fleet_options import add_declared_options
from robot_wear_monitor.cli.options import (add_display_timezone, add_history, add_json,
                                            bounded, display_zone, emit_json, shown_location)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import open_history
from robot_wear_monitor.text import iso_time, shorten

if TYPE_CHECKING:
    from robot_wear_monitor.fleet.notifications import SentNotification

HELP = ("send the fleet's events (alarm raised, forecast crossing within a horizon, stale "
        'joint) by webhook and e-mail, once per event')

#: ``--log N``: rows of the notification log.
LOG_ROWS = bounded(1, 100000, integer=True)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``notify``."""
    add_history(parser, help_text="the fleet's wear history", required=True)
    parser.add_argument('--config', metavar='FILE',
                        help='the notification configuration (YAML; see '
                             'config/notifications.example.yaml); required but with --log')
    parser.add_argument('--once', action='store_true',
                        help='one pass, then exit (for cron): 0 all delivered, 1 a send '
                             'failed (retried on the next pass)')
    add_declared_options(parser, 'notify')  # --interval-s (the loop without --once)
    parser.add_argument('--now', metavar='TIME',
                        help='with --once: judge the events at this time: ISO 8601 or seconds '
                             'since the epoch (default: the clock)')
    parser.add_argument('--log', type=LOG_ROWS, nargs='?', const=50, default=None,
                        metavar='N', help="print the history's notification log instead "
                                          '(the last N rows, default 50, newest first: sent, '
                                          'failed with the error, retries); sends nothing')
    add_display_timezone(parser)
    add_json(parser, what='the sends of the pass (with --once) or the log (with --log)')


def _line(sent: SentNotification) -> str:
    what = f'{sent.kind} {shorten(sent.robot, 60)} {shorten(sent.joint, 60)}'
    when = iso_time(time.time())
    if sent.delivered:
        return f'{when} sent {what} via {sent.channel}'
    later = (f'tried again on the next pass ({sent.pass_number} of {sent.passes})'
             if sent.retried_later else f'given up after {sent.passes} passes')
    return (f'{when} FAILED {what} via {sent.channel} after {sent.attempts} tries: '
            f'{sent.error}; {later}')


def _log_status(row: dict[str, Any], keys: set[str]) -> str:
    """Return 'sent', 'failed' (a send whose tries failed) or 'failure' (the failure's row)."""
    key = str(row['event_key'])
    base, _, tail = key.partition('#')
    if tail.startswith('failed'):
        return 'failure'
    number = tail[len('pass'):] if tail.startswith('pass') else '1'
    return 'failed' if f'{base}#failed{number}' in keys else 'sent'


def _log_line(row: dict[str, Any]) -> str:
    payload = row.get('payload') or {}
    status = row['status']
    if status == 'failure':
        status = (f'FAILED pass {payload.get("pass", "?")} of {payload.get("passes", "?")} '
                  f'after {payload.get("attempts", "?")} tries: {payload.get("error", "")}')
    wall = row.get('wall_time_s')
    return '  '.join((iso_time(float(wall) if wall is not None else None),
                      shorten(str(row.get('channel')), 40), str(row.get('kind')),
                      shorten(str(row.get('robot')), 60),
                      shorten(str(row.get('joint')), 60),
                      shorten(status, 300)))


def main(args: argparse.Namespace) -> int:
    """Run ``notify``: one pass (``--once``) or a pass every ``--interval-s`` seconds."""
    # deferred import: start-up time (numpy, the channels: not for --help)
    from robot_wear_monitor.cli.fleet import parse_time
    from robot_wear_monitor.fleet.notifications import (load_notification_config,
                                                        notify_forever, notify_once)
    if args.log is not None:
        if args.once or args.now:
            raise InputError('--log reads the log only: not with --once or --now')
        with open_history(args.history, init=False) as history:
            rows = history.notifications(limit=int(args.log))
        keys = {str(row['event_key']) for row in rows}
        rows = [{**row, 'status': _log_status(row, keys)} for row in rows]
        if not emit_json(args, rows):
            for row in rows:
                print(_log_line(row))
        return 0
    if not args.config:
        raise InputError('--config FILE is required (the notification configuration)')
    config = load_notification_config(args.config)
    zone = display_zone(args)  # of the messages' texts; the payloads' times stay UTC
    if args.now and not args.once:
        raise InputError('--now goes with --once (the loop judges at the clock)')
    if args.json and not args.once:
        raise InputError('--json goes with --once (the loop prints a line per send)')
    if args.once:
        now_s = parse_time(args.now) if args.now else time.time()
        with open_history(args.history, init=False) as history:
            sent = notify_once(history=history, config=config, now_s=now_s, zone=zone)
        if not args.json:
            for item in sent:
                print(_line(item), file=sys.stdout if item.delivered else sys.stderr)
        emit_json(args, [item.as_json() for item in sent])
        return 0 if all(item.delivered for item in sent) else 1
    with open_history(args.history, init=False):
        pass  # a history that cannot be opened is exit 2 now, not a loop of errors
    print(f'notify: {shown_location(args.history)}: a pass every {args.interval_s:g} s to '
          f'{", ".join(config.channels)} (Ctrl-C stops)', flush=True)

    def report(sent: list[SentNotification]) -> None:
        for item in sent:
            print(_line(item), file=sys.stdout if item.delivered else sys.stderr, flush=True)

    def on_error(error: Exception) -> None:
        print(f'notify: pass failed: {str(error).splitlines()[0]}; next pass in '
              f'{args.interval_s:g} s', file=sys.stderr, flush=True)
    notify_forever(location=args.history, config=config, interval_s=args.interval_s,
                   stop=threading.Event(), report=report, on_error=on_error, zone=zone)
    return 0
