"""Tests of the alarm rule: validation, the decision on one estimate or a batch, the latch."""

import math

import numpy as np
import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.alarm import (AlarmLatch, AlarmPolicy,
                                                 DEFAULT_ALARM_PROBABILITY, DEFAULT_ALARM_RULE,
                                                 WEAR_HEALTHY, WEAR_THRESHOLD)
from robot_wear_monitor.estimation.trend import TrendConfig


def test_the_defaults_have_one_owner():
    policy = AlarmPolicy()
    assert (policy.threshold, policy.healthy, policy.rule, policy.probability) == (
        WEAR_THRESHOLD, WEAR_HEALTHY, DEFAULT_ALARM_RULE, DEFAULT_ALARM_PROBABILITY)
    assert TrendConfig().threshold == WEAR_THRESHOLD


def test_evidence_policy_needs_agreeing_estimates():
    policy = AlarmPolicy(threshold=35.0, healthy=25.0, evidence_to_raise=3.0, rule='estimate')
    latch = AlarmLatch(policy)
    # one imprecise estimate over the threshold: llr = 10 * 6 / 100 = 0.6
    assert not latch.update(wear=36.0, wear_std=10.0)
    assert latch.evidence == pytest.approx(0.6)
    # a precise one: llr = 10 * 7 / 4**2 = 4.375, evidence 4.975 >= 3
    assert latch.update(wear=37.0, wear_std=4.0)
    # healthy estimates drain evidence but never below 0
    latch2 = AlarmLatch(policy)
    latch2.update(wear=5.0, wear_std=5.0)
    assert latch2.evidence == 0.0
    assert policy.log_likelihood_ratio(wear=40.0, wear_std=float('nan')) == 0.0
    with pytest.raises(ValueError):
        AlarmPolicy(threshold=25.0, healthy=25.0)


def test_policy_validation():
    with pytest.raises(InputError):
        AlarmPolicy(probability=1.0)
    with pytest.raises(InputError):
        AlarmPolicy(rule='threshold')
    with pytest.raises(InputError):
        AlarmPolicy(evidence_to_raise=-1.0)


def test_the_decision_of_a_batch_is_the_decision_of_each_estimate():
    trend = AlarmPolicy(rule='trend', probability=0.5)
    np.testing.assert_array_equal(
        trend.decide(probability_above_threshold=[0.2, 0.5, math.nan]), [False, True, False])
    paper = AlarmPolicy(rule='estimate')
    wear = np.array([[10.0, 34.9, 35.0], [36.0, math.nan, 80.0]])
    np.testing.assert_array_equal(paper.decide(wear=wear), wear >= 35.0)
    assert not paper.decide(wear=34.9) and paper.decide(wear=35.0)
    with_evidence = AlarmPolicy(rule='estimate', evidence_to_raise=2.0)
    np.testing.assert_array_equal(with_evidence.decide(wear=[40.0, 40.0], evidence=[1.0, 2.0]),
                                  [False, True])
    with pytest.raises(InputError, match='needs the evidence'):
        with_evidence.decide(wear=40.0)


@pytest.mark.parametrize('rule', ['trend', 'estimate'])
def test_the_latch_raises_once_where_the_rule_first_decides(rule):
    rng = np.random.default_rng(5)
    wear = np.concatenate([rng.uniform(0.0, 30.0, 20), rng.uniform(30.0, 60.0, 20)])
    probability = np.clip(wear / 60.0, 0.0, 0.99)
    policy = AlarmPolicy(rule=rule, probability=0.6)
    latch = AlarmLatch(policy)
    raised = [latch.update(wear=w, wear_std=3.0, probability_above_threshold=p)
              for w, p in zip(wear, probability)]
    decided = policy.decide(wear=wear, probability_above_threshold=probability)
    assert sum(raised) == 1 and raised.index(True) == int(np.argmax(decided))
    assert latch.active and latch.reset() and not latch.active and latch.evidence == 0.0
    assert not latch.reset()
