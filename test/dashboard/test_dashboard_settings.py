"""
The dashboard's settings are declared once: DashboardSettings, ServerSettings and their docs.

``DashboardSettings`` (what the app serves) and ``ServerSettings`` (how ``dashboard`` listens)
declare each setting with its default, unit, description and check: a bad value made in Python
is one error naming the setting, the value and the range (the same range the command line's
options check), and the options table of docs/dashboard.md states the declared defaults and
ranges.
"""

import math

import pytest
from robot_wear_monitor.dashboard.server_limits import (HEADER_TIMEOUT_S, LIMIT_CONCURRENCY,
                                                        ServerSettings)
from robot_wear_monitor.dashboard.state import DashboardSettings
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.fleet.notify_settings import NotifierSettings
from robot_wear_monitor.setting_fields import declared_settings, problem_of, setting_of
from wear_testing import docs_settings


def test_every_dashboard_setting_is_declared_with_a_text_and_a_valid_default():
    for owner in (DashboardSettings, ServerSettings):
        for name, setting in declared_settings(owner).items():
            assert setting.description and not setting.description.endswith('.'), name
            assert '[' not in setting.description, f'{name}: the unit goes in unit='
            if setting.default is not None:
                assert problem_of(setting, setting.default) is None, (owner.__name__, name)
    # the server process's notification interval is the notifier's own setting
    mine, owner = setting_of(DashboardSettings, 'notify_interval_s'), setting_of(
        NotifierSettings, 'interval_s')
    assert (mine.default, mine.unit, mine.check) == (owner.default, owner.unit, owner.check)
    server = ServerSettings()
    assert (server.limit_concurrency, server.header_timeout_s) == (LIMIT_CONCURRENCY,
                                                                   HEADER_TIMEOUT_S)


@pytest.mark.parametrize('changes, message', [
    ({'notify_interval_s': 0}, 'notify_interval_s: must be >= 1 and <= 86400, got 0 [s]'),
    ({'notify_interval_s': math.nan},
     'notify_interval_s: expected a finite number (must be >= 1 and <= 86400), got nan [s]'),
    ({'notify_interval_s': '60'}, "notify_interval_s: expected a finite number, got '60' [s]"),
    ({'max_failures': 0}, 'max_failures: must be >= 1 and <= 1000, got 0'),
    ({'window_s': -5.0}, 'window_s: must be >= 1 and <= 86400, got -5.0 [s]'),
    ({'poll_interval_ms': 10}, 'poll_interval_ms: must be >= 100 and <= 600000, got 10 [ms]'),
    ({'https': 'yes'}, "https: expected true or false, got 'yes'"),
])
def test_a_bad_dashboard_setting_names_itself_the_value_and_the_range(changes, message):
    with pytest.raises(InputError) as error:
        DashboardSettings(history=':memory:', **changes)
    assert str(error.value) == f'dashboard settings: {message}'


@pytest.mark.parametrize('changes, message', [
    ({'port': 0}, 'port: must be >= 1 and <= 65535, got 0'),
    ({'port': 8080.5}, 'port: expected an integer, got 8080.5'),
    ({'limit_concurrency': 0}, 'limit_concurrency: must be >= 1, got 0'),
    ({'header_timeout_s': 0.1}, 'header_timeout_s: must be >= 0.5 and <= 600, got 0.1 [s]'),
    ({'host': '  '}, "host: must not be empty, got '  '"),
    ({'port': '\x1b[2J' + '8' * 300}, "port: expected an integer, got '\\x1b[2J888"),
])
def test_a_bad_server_setting_names_itself_the_value_and_the_range(changes, message):
    with pytest.raises(InputError) as error:
        ServerSettings(**changes)
    text = str(error.value)
    assert text.startswith(f'dashboard server: {message}') and text.isprintable()
    assert len(text) < 160  # the value is cut short


def test_the_options_table_of_the_docs_is_the_declarations():
    from robot_wear_monitor.cli.fleet_options import DECLARED_OPTIONS
    rows = docs_settings.table(docs_settings.DOCS / 'dashboard.md', '| option | meaning |')
    ranges = 0
    for flag, owner, name in DECLARED_OPTIONS['dashboard']:
        declared = setting_of(owner, name)
        meaning = docs_settings.row_of(rows, flag)[1]
        assert docs_settings.same_default(declared, docs_settings.stated_default(meaning)), \
            (flag, meaning)
        if declared.unit not in ('', '-'):
            assert f'[{declared.unit}]' in meaning, (flag, declared.unit)
        for stated in docs_settings.stated_ranges(meaning):
            docs_settings.check_range(declared, stated)
            ranges += 1
    assert ranges >= 4
    # the prose states the same limits
    text = ' '.join((docs_settings.DOCS / 'dashboard.md').read_text().split())
    assert f'`--header-timeout-s` ({HEADER_TIMEOUT_S:g} s)' in text
    assert f'`--limit-concurrency` ({LIMIT_CONCURRENCY})' in text
    security = ' '.join((docs_settings.DOCS / 'security.md').read_text().split())
    assert f'`server.header_timeout_protocol`, {HEADER_TIMEOUT_S:g} s)' in security
    assert f'`--limit-concurrency` (503 past {LIMIT_CONCURRENCY})' in security
