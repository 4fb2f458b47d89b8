"""
The notification settings are declared once: the file, Python and the docs agree with them.

:mod:`robot_wear_monitor.fleet.notify_settings` declares each field of the notification
configuration (and the pass interval) with its default, unit, description and check.  A bad
value is one error naming the field, the value (cut short, escaped) and the range, from a YAML
file as from Python; the configuration table of docs/notifications.md and the defaults that
docs/fleet.md and docs/dashboard.md state are the declared ones.
"""

import math

import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.fleet import notify_settings
from robot_wear_monitor.fleet.notify_config import notification_config_from_mapping
from robot_wear_monitor.fleet.notify_settings import (EmailConfig, NotificationConfig,
                                                      NotificationConfigError, NotifierSettings,
                                                      RetryPolicy, SMTP_PORTS, WebhookConfig)
from robot_wear_monitor.fleet.ranking import DEFAULT_REESCALATION_MARGIN
from robot_wear_monitor.fleet.states import DEFAULT_FORECAST_HORIZON_DAYS
from robot_wear_monitor.setting_fields import declared_settings, problem_of, setting_of
from wear_testing import docs_settings

#: Each owner and the prefix of its keys in the file.
SECTIONS = {NotificationConfig: '', RetryPolicy: 'retry.', WebhookConfig: 'webhooks[].',
            EmailConfig: 'email.'}
HOOK = {'webhooks': [{'url': 'https://hooks.example/x'}]}


def test_every_notification_setting_is_declared_with_a_text_and_a_valid_default():
    for owner in (*SECTIONS, NotifierSettings):
        declared = declared_settings(owner)
        assert declared, owner
        for name, setting in declared.items():
            assert setting.description and not setting.description.endswith('.'), name
            assert '[' not in setting.description, f'{name}: the unit goes in unit='
            assert setting.kind in ('float', 'int', 'str', 'bool'), name
            if setting.default is not None:
                assert problem_of(setting, setting.default) is None, (owner.__name__, name)
    # one owner: the fleet's defaults are the notification configuration's declared ones
    assert DEFAULT_FORECAST_HORIZON_DAYS == setting_of(NotificationConfig,
                                                       'forecast_horizon_days').default == 30
    assert DEFAULT_REESCALATION_MARGIN == setting_of(NotificationConfig,
                                                     'reescalation_margin').default == 5


def test_a_file_without_the_keys_has_the_declared_defaults():
    config = notification_config_from_mapping({**HOOK, 'email': {
        'host': 'mail.example', 'from': 'a@example.local', 'to': 'b@example.local'}})
    for owner, instance in ((NotificationConfig, config), (RetryPolicy, config.retry),
                            (WebhookConfig, config.webhooks[0]), (EmailConfig, config.email)):
        for name, setting in declared_settings(owner).items():
            if setting.default is not None:
                assert getattr(instance, name) == setting.default, (owner.__name__, name)
    assert config.email.port == SMTP_PORTS[True] == 587


@pytest.mark.parametrize('change, message', [
    ({'forecast_horizon_days': -1},
     'notify.yaml: forecast_horizon_days: must be >= 0 and <= 3650 days, got -1 days'),
    ({'forecast_horizon_days': float('nan')},
     'forecast_horizon_days: must be >= 0 and <= 3650 days, got nan days'),
    ({'forecast_horizon_days': 'soon'},
     "forecast_horizon_days: must be a number days, got 'soon'"),
    ({'reescalation_margin': 0},
     'reescalation_margin: must be > 0 and <= 100 wear units, got 0 wear units'),
    ({'first_pass_summary': 'yes'}, "first_pass_summary: must be true or false, got 'yes'"),
    ({'retry': {'passes': 2.5}}, 'retry.passes: must be an integer, got 2.5'),
    ({'retry': {'backoff_max_s': 1e9}},
     'retry.backoff_max_s: must be >= 0 and <= 3600 s, got 1000000000.0 s'),
    ({'webhooks': [{'url': 'https://a.example/', 'timeout_s': 601}]},
     'webhooks[0].timeout_s: must be > 0 and <= 600 s, got 601 s'),
    ({'email': {'host': 'mail.example', 'from': 'a@example.local', 'to': 'b@example.local',
                'timeout_s': -1}}, 'email.timeout_s: must be > 0 and <= 600 s, got -1 s'),
])
def test_a_bad_value_in_the_file_names_the_field_the_value_and_the_range(change, message):
    with pytest.raises(NotificationConfigError) as error:
        notification_config_from_mapping({**HOOK, **change}, source='notify.yaml')
    text = str(error.value)
    assert text.startswith('notify.yaml: ') and message in text and '\n' not in text


def test_a_hostile_value_is_echoed_cut_short_and_escaped():
    hostile = '\x1b[31mred\r\nforged line ' + 'x' * 500
    with pytest.raises(NotificationConfigError) as error:
        notification_config_from_mapping({**HOOK, 'retry': {'total_s': hostile}},
                                         source='notify.yaml')
    text = str(error.value)
    assert 'retry.total_s: must be a number s, got ' in text
    assert text.isprintable() and len(text) < 200 and '\\x1b' in text


@pytest.mark.parametrize('make, message', [
    (lambda: NotificationConfig(forecast_horizon_days=-1.0, source='python'),
     'python: forecast_horizon_days: must be >= 0 and <= 3650, got -1.0 [days]'),
    (lambda: NotificationConfig(reescalation_margin=math.inf),
     'reescalation_margin: expected a finite number (must be > 0 and <= 100), got inf '
     '[wear units]'),
    (lambda: RetryPolicy(attempts=0), 'retry.attempts: must be >= 1 and <= 20, got 0'),
    (lambda: WebhookConfig(name='ops', url='https://a.example/', timeout_s=math.nan),
     'webhook timeout_s: expected a finite number (must be > 0 and <= 600), got nan [s]'),
    (lambda: EmailConfig(host='mail.example', port=70000, sender='a@example.local',
                         to=('b@example.local',)),
     'email.port: must be >= 1 and <= 65535, got 70000'),
])
def test_a_configuration_made_in_python_is_checked_by_the_same_declarations(make, message):
    with pytest.raises(NotificationConfigError) as error:
        make()
    assert message in str(error.value)


@pytest.mark.parametrize('value', [0.0, 0.5, math.nan, 86401.0])
def test_the_pass_interval_is_checked_where_it_is_made(value):
    with pytest.raises(InputError, match=r'notifier: interval_s: .*must be >= 1 and <= 86400'):
        NotifierSettings(interval_s=value)
    assert NotifierSettings().interval_s == 60.0


def test_the_configuration_table_of_the_docs_is_the_declarations():
    rows = docs_settings.table(docs_settings.DOCS / 'notifications.md',
                               '| key | default | meaning |')
    checked = {'default': 0, 'unit': 0, 'range': 0}
    for owner, prefix in SECTIONS.items():
        for name, setting in declared_settings(owner).items():
            key = prefix + name
            keys_cell, defaults_cell, meaning = docs_settings.row_of(rows, key)
            keys = [k.strip('`') for k in keys_cell.split(', ')]
            defaults = defaults_cell.split(', ')
            stated = defaults[keys.index(key)] if len(defaults) == len(keys) else defaults[0]
            if setting.default is None:  # the SMTP port: by STARTTLS when the file gives none
                assert stated == f'{SMTP_PORTS[True]} ({SMTP_PORTS[False]} without STARTTLS)', \
                    (key, stated)
            else:
                assert docs_settings.same_default(setting, stated), (key, stated)
                checked['default'] += 1
            if setting.unit not in ('', '-'):
                assert setting.unit in docs_settings.stated_units(meaning), (key, setting.unit)
                checked['unit'] += 1
            for stated_range in docs_settings.stated_ranges(meaning):
                docs_settings.check_range(setting, stated_range)
                checked['range'] += 1
    assert checked['default'] >= 11 and checked['unit'] >= 7 and checked['range'] >= 4, checked


def test_the_options_of_notify_and_the_pages_state_the_declared_defaults():
    interval = setting_of(NotifierSettings, 'interval_s')
    rows = docs_settings.table(docs_settings.DOCS / 'notifications.md', '| option | meaning |')
    meaning = docs_settings.row_of(rows, '--interval-s')[1]
    assert docs_settings.same_default(interval, docs_settings.stated_default(meaning))
    assert f'[{interval.unit}]' in meaning
    [stated_range] = docs_settings.stated_ranges(meaning)
    docs_settings.check_range(interval, stated_range)
    horizon = setting_of(NotificationConfig, 'forecast_horizon_days').default
    margin = setting_of(NotificationConfig, 'reescalation_margin').default
    fleet = ' '.join((docs_settings.DOCS / 'fleet.md').read_text().split())
    assert f'`--forecast-horizon-days`, default {horizon:g}:' in fleet
    assert f'`--reescalation-margin W`, default {margin:g} wear units' in fleet
    dashboard = ' '.join((docs_settings.DOCS / 'dashboard.md').read_text().split())
    assert f'`reescalation_margin` of the `--notify` configuration, default {margin:g} ' \
           'wear' in dashboard
    assert f'`forecast_horizon_days`, {horizon:g} without one' in dashboard


def test_the_settings_module_loads_no_yaml_or_ssl():
    """The command line reads the defaults from it at start-up: declarations only."""
    import ast
    source = ast.parse(open(notify_settings.__file__).read())
    imported = {alias.name for node in ast.walk(source) if isinstance(node, ast.Import)
                for alias in node.names}
    imported |= {node.module for node in ast.walk(source) if isinstance(node, ast.ImportFrom)}
    assert imported <= {'__future__', 'dataclasses', 'typing', 'robot_wear_monitor.errors',
                        'robot_wear_monitor.setting_fields'}, imported
