"""
The trend's settings are declared once on TrendConfig: its checks and the docs' table.

Every field of :class:`~robot_wear_monitor.estimation.trend.TrendConfig` but the wear grid is a
declared setting (default, unit, description, check); a bad value is one InputError naming the
setting, the value and the range; the table of docs/service.md and the horizon docs/nodes.md
states are the declared ones; the trend's threshold is the alarm policy's setting.
"""

import math

import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.alarm import AlarmPolicy
from robot_wear_monitor.estimation.trend import TrendConfig
from robot_wear_monitor.setting_fields import declared_settings, problem_of, setting_of
from wear_testing import docs_settings


def test_every_trend_setting_is_declared_with_a_text_and_a_valid_default():
    declared = declared_settings(TrendConfig)
    fields = {f.name for f in TrendConfig.__dataclass_fields__.values()}
    assert set(declared) == fields - {'wear_grid'}
    for name, setting in declared.items():
        assert setting.description and not setting.description.endswith('.'), name
        assert '[' not in setting.description, f'{name}: the unit goes in unit='
        if setting.default is not None:
            assert problem_of(setting, setting.default) is None, name
    threshold, alarm = setting_of(TrendConfig, 'threshold'), setting_of(AlarmPolicy,
                                                                        'threshold')
    assert (threshold.default, threshold.unit, threshold.check) == (alarm.default, alarm.unit,
                                                                    alarm.check)
    assert setting_of(TrendConfig, 'experiment_interval_s').optional


@pytest.mark.parametrize('changes, message', [
    ({'forecast_horizon': -3}, 'trend: forecast_horizon: must be >= 1, got -3 [experiments]'),
    ({'forecast_horizon': 2.5},
     'trend: forecast_horizon: expected an integer, got 2.5 [experiments]'),
    ({'rate_step': math.nan},
     'trend: rate_step: expected a finite number (must be > 0), got nan'),
    ({'likelihood_power': 1.5},
     'trend: likelihood_power: must be > 0 and <= 1, got 1.5'),
    ({'rate_jump_probability': 1.0},
     'trend: rate_jump_probability: must be in [0, 1), got 1.0'),
    ({'experiment_interval_s': 0.0},
     'trend: experiment_interval_s: must be > 0, got 0.0 [s]'),
    ({'rate_points': 2}, 'trend: rate_points: must be >= 3, got 2'),
    ({'initial_rate_mean': -0.02},
     'trend: initial_rate_mean: must be > 0, got -0.02 [w/experiment]'),
])
def test_a_bad_trend_setting_names_itself_the_value_and_the_range(changes, message):
    with pytest.raises(InputError) as error:
        TrendConfig(**changes)
    assert str(error.value) == message
    assert TrendConfig(experiment_interval_s=None).experiment_interval_s is None


_RANGES = {'> 0': (0.0, False, math.inf, False), '>= 1': (1.0, True, math.inf, False),
           '>= 3': (3.0, True, math.inf, False), '[0, 1)': (0.0, True, 1.0, False),
           '(0, 1]': (0.0, False, 1.0, True)}


def test_the_trend_table_of_the_docs_is_the_declarations():
    rows = docs_settings.table(docs_settings.DOCS / 'service.md',
                               '| setting | default | unit | range | meaning |')
    declared = declared_settings(TrendConfig)
    assert [row[0].strip('`') for row in rows] == list(declared)
    for name, default, unit, stated_range, meaning in rows:
        setting = declared[name.strip('`')]
        if setting.default is None:
            assert default == 'unset', name
        else:
            assert docs_settings.same_default(setting, default), (name, default)
        assert unit == (setting.unit or 'count'), (name, unit)
        docs_settings.check_range(setting, _RANGES[stated_range])
        assert meaning == setting.description, name
    horizon = setting_of(TrendConfig, 'forecast_horizon').default
    nodes = ' '.join((docs_settings.DOCS / 'nodes.md').read_text().split())
    assert f'beyond the {horizon}-experiment horizon' in nodes
