"""
Option builders of the verbs that read a fleet's history and notify: fleet, notify, dashboard.

Each option is made from its declared setting (:mod:`robot_wear_monitor.setting_fields`), so
its default, its help (with the unit) and its range are the declaration's, and a flag means
the same in every verb that takes it:

* ``--forecast-horizon-days DAYS`` (``fleet``): the notification configuration's
  ``forecast_horizon_days``; ``--reescalation-margin W`` (``fleet``): its
  ``reescalation_margin`` (:class:`~robot_wear_monitor.fleet.notify_settings.
  NotificationConfig`);
* ``--interval-s S`` (``notify``) and ``--notify-interval-s S`` (``dashboard``): the time
  between two notification passes (:class:`~robot_wear_monitor.fleet.notify_settings.
  NotifierSettings`; the dashboard's ``DashboardSettings.notify_interval_s`` is the same
  setting);
* ``--host``, ``--port``, ``--limit-concurrency``, ``--header-timeout-s``, ``--workers``
  (``dashboard``):
  :class:`~robot_wear_monitor.dashboard.server_limits.ServerSettings`.

:data:`DECLARED_OPTIONS` lists them (flag, owner, setting): the tests compare the verbs' defaults
and the docs' tables with the declarations through it.
"""

from __future__ import annotations

import argparse
from typing import Any, Callable

from robot_wear_monitor.cli.options import add_setting_option
from robot_wear_monitor.dashboard.server_limits import ServerSettings
from robot_wear_monitor.fleet.notify_settings import NotificationConfig, NotifierSettings
from robot_wear_monitor.setting_fields import problem_of, setting_of
from robot_wear_monitor.text import shorten

#: The options made here: verb -> (flag, owner, setting name).
DECLARED_OPTIONS: dict[str, tuple[tuple[str, Any, str], ...]] = {
    'fleet': (('--forecast-horizon-days', NotificationConfig, 'forecast_horizon_days'),
              ('--reescalation-margin', NotificationConfig, 'reescalation_margin')),
    'notify': (('--interval-s', NotifierSettings, 'interval_s'),),
    'dashboard': (('--host', ServerSettings, 'host'), ('--port', ServerSettings, 'port'),
                  ('--limit-concurrency', ServerSettings, 'limit_concurrency'),
                  ('--header-timeout-s', ServerSettings, 'header_timeout_s'),
                  ('--workers', ServerSettings, 'workers'),
                  ('--notify-interval-s', NotifierSettings, 'interval_s'))}

_METAVARS = {'forecast_horizon_days': 'DAYS', 'reescalation_margin': 'W', 'interval_s': 'S',
             'host': 'H', 'port': 'P', 'limit_concurrency': 'N', 'header_timeout_s': 'S',
             'workers': 'N'}


def _text_type(owner: Any, name: str) -> Callable[[str], str]:
    """Return the argparse type of a declared text setting: its check, else the text."""
    declared = setting_of(owner, name)

    def parse(text: str) -> str:
        problem = problem_of(declared, text)
        if problem:
            raise argparse.ArgumentTypeError(f'{problem}, got {shorten(repr(text))}')
        return text
    return parse


def add_declared_option(parser: Any, flag: str, owner: Any, name: str, **kwargs: Any) -> None:
    """
    Add ``flag`` for the declared setting ``name`` of ``owner``, defaulting to its default.

    The help is the description with the unit and the default; the type is the setting's
    kind and check (a bad value: argparse's one line naming the option, exit 2).
    """
    declared = setting_of(owner, name)
    metavar = kwargs.pop('metavar', _METAVARS.get(name))
    if declared.kind == 'str':
        parser.add_argument(flag, type=_text_type(owner, name), default=declared.default,
                            metavar=metavar, help=f'{declared.text} (default: '
                                                  f'{declared.default})', **kwargs)
        return
    shown = f'{declared.default:g}' if isinstance(declared.default, float) \
        else str(declared.default)
    add_setting_option(parser, flag, owner, name, default=declared.default, default_text=shown,
                       metavar=metavar, **kwargs)


def add_declared_options(parser: Any, verb: str) -> None:
    """Add every option of :data:`DECLARED_OPTIONS` of ``verb``."""
    for flag, owner, name in DECLARED_OPTIONS[verb]:
        add_declared_option(parser, flag, owner, name)
