"""Tests of the diagnostics helpers: the rejection log, numbers in key-values and JSON."""

import math

from robot_wear_monitor.estimation.wear_report import meaningful_std
from robot_wear_monitor.json_values import finite_or_none
from robot_wear_monitor.monitoring.diagnostics import RejectionLog
from robot_wear_monitor.text import fmt_number


def test_rejection_log_reports_each_rejection_once_and_at_most_once_per_period():
    log = RejectionLog(what='joint_states inputs', period_s=10.0)
    assert log.report({}, now_s=0.0) is None
    text, defective = log.report({'non_finite': 2, 'time_gap': 1}, now_s=1.0, detail='nan')
    assert text == ('rejected 3 joint_states inputs (non_finite 2, time_gap 1); 3 since start; '
                    'last: nan')
    assert defective
    assert log.report({'non_finite': 5, 'time_gap': 1}, now_s=5.0) is None  # too soon
    text, defective = log.report({'non_finite': 5, 'time_gap': 1}, now_s=11.5)
    assert text.startswith('rejected 3 joint_states inputs (non_finite 3); 6 since start')
    assert log.report({'non_finite': 5, 'time_gap': 1}, now_s=30.0) is None  # nothing new
    text, defective = log.report({'non_finite': 5, 'time_gap': 2, 'pass_too_short': 4},
                                 now_s=40.0, detail='ignored for routine reasons')
    assert not defective and 'last:' not in text and '(pass_too_short 4, time_gap 1)' in text


def test_numbers_in_key_values_and_json():
    assert fmt_number(35.0) == '35' and fmt_number(math.nan) == 'unknown'
    assert fmt_number(math.inf, missing='beyond') == 'beyond'
    assert fmt_number(1 / 3, 6) == '0.333333'
    assert finite_or_none(math.inf) is None and finite_or_none(2) == 2.0


def test_the_std_is_reported_only_where_it_agrees_with_the_interval():
    # w = 30 +- 1.96 * 2.5: the Wald interval [25.1, 34.9] agrees with [25, 35]
    assert meaningful_std(std=2.5, value=30.0, low=25.0, high=35.0) == 2.5
    assert math.isnan(meaningful_std(std=2.5, value=30.0, low=25.0, high=35.0,
                                     open_above=True))
    assert math.isnan(meaningful_std(std=4317.0, value=0.3, low=0.0, high=12.0))  # at w = 0
    assert math.isnan(meaningful_std(std=10.0, value=30.0, low=25.0, high=35.0))  # too wide
