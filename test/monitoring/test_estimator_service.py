"""Tests of the wear estimator service: alarm latch, diagnostics, restore, intervals and trend."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from robot_wear_monitor.estimation.alarm import AlarmPolicy
from robot_wear_monitor.experiment.levels import FrictionExperiment, FrictionLevel
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring import node_config
from robot_wear_monitor.monitoring.estimator_service import (EstimatorConfig,
                                                             WearEstimatorService)
from robot_wear_monitor.recordings import messages
from rosbags.typesys import get_typestore, Stores

KIT = messages.rosbags_kit(get_typestore(Stores.ROS2_JAZZY))
PARAMS = load_parameter_set()


def fake_estimate(wears, *, std=3.0, p_value=0.5, at_bound=False):
    """Return an estimate function giving the next wear of ``wears`` on every call."""
    values = iter(wears)

    def estimate(speeds, frictions, *, params):
        wear = next(values)
        return SimpleNamespace(wear=wear, wear_std=std, temperature_degc=40.0,
                               temperature_std_degc=2.0, chi2=1.0, dof=len(speeds) - 2,
                               p_value=p_value, temperature_at_bound=at_bound,
                               wear_at_bound=False, n_levels=len(speeds))
    return estimate


def experiment(k):
    levels = tuple(FrictionLevel(speed_rad_s=v, friction=0.1, friction_std_error=0.001,
                                 tau_forward=0.2, tau_backward=0.0, n_forward=50,
                                 n_backward=50, position_min_rad=0.0, position_max_rad=0.5,
                                 start_time_s=100.0 * k + i, end_time_s=100.0 * k + i + 0.5)
                   for i, v in enumerate((2.1, 28.5, 35.1, 41.7)))
    return FrictionExperiment(levels=levels)


def service(wears, history=None, **kwargs):
    """Return an estimator of the fake estimates ``wears`` under the paper's rule."""
    config = EstimatorConfig(joint='joint_2', params=PARAMS,
                             experiment_speeds_rad_s=(2.1, 28.5, 35.1, 41.7),
                             alarm=AlarmPolicy(rule='estimate'), **kwargs.pop('config', {}))
    return WearEstimatorService(config, history=history, estimate=fake_estimate(wears, **kwargs))


def test_alarm_latches_at_threshold_and_reset_clears_it():
    svc = service([10.0, 34.9, 35.0, 20.0, 20.0])
    updates = [svc.process_experiment(experiment(k)) for k in range(4)]
    assert [u.alarm_active for u in updates] == [False, False, True, True]
    assert [u.alarm_raised for u in updates] == [False, False, True, False]
    assert [u.status.level for u in updates] == [messages.DIAGNOSTIC_OK, messages.DIAGNOSTIC_WARN,
                                                 messages.DIAGNOSTIC_ERROR,
                                                 messages.DIAGNOSTIC_ERROR]
    assert svc.reset_alarm(stamp_s=500.0) == (True, 'wear alarm cleared; evidence and trend reset')
    assert not svc.latch.active
    assert svc.current_status().level == messages.DIAGNOSTIC_OK
    assert not svc.process_experiment(experiment(5)).alarm_active


def test_diagnostics_key_values_and_fit_warning():
    svc = service([5.0], p_value=0.001)
    update = svc.process_experiment(experiment(0))
    assert update.status.level == messages.DIAGNOSTIC_WARN
    assert 'do not fit the model' in update.status.message
    assert update.status.value('speeds_rad_s') == '2.1,28.5,35.1,41.7'
    assert float(update.status.value('wear')) == 5.0
    assert float(update.status.value('fit_p_value')) == pytest.approx(0.001)
    out = dict(svc.output_messages(KIT, update))
    assert out['wear'].data == 5.0 and out['wear_alarm'].data is False
    assert out['temperature'].variance == pytest.approx(4.0)
    [(level, name, _, values)] = messages.diagnostics_from_msg(out['/diagnostics'])
    assert (level, name, values['alarm']) == (1, 'wear_monitor: joint_2', 'false')


def test_bad_friction_levels_messages_are_counted_not_fatal():
    svc = service([12.0])
    bad = messages.friction_levels_to_msg(KIT, stamp_s=1.0, joint='joint_2',
                                          speeds_rad_s=[2.1, 28.5], frictions=[0.1, 0.2])
    bad.effort = np.array([0.1])
    assert svc.handle_friction_levels(bad) is None
    bad.effort = np.array([0.1, float('nan')])
    assert svc.handle_friction_levels(bad) is None
    good = messages.friction_levels_to_msg(KIT, stamp_s=2.0, joint='joint_2',
                                           speeds_rad_s=[2.1, 28.5], frictions=[0.1, 0.2])
    assert svc.handle_friction_levels(good).wear == 12.0
    status = svc.current_status()
    assert status.value('rejected_length_mismatch') == '1'
    assert status.value('rejected_not_finite') == '1'
    assert status.value('rejected_total') == '2'


def test_restart_restores_trend_and_latched_alarm(tmp_path):
    path = tmp_path / 'history.sqlite3'
    history = WearHistory(path)
    svc = service([30.0, 40.0], history=history)
    svc.process_experiment(experiment(0))
    svc.process_experiment(experiment(1))
    history.close()  # the process dies here; everything was committed
    restarted = service([10.0], history=WearHistory(path))
    assert restarted.latch.active and restarted.restored_estimates == 2
    assert [r.wear for r in restarted.trend] == [30.0, 40.0]
    assert restarted.current_status().level == messages.DIAGNOSTIC_ERROR
    restarted.reset_alarm(stamp_s=1000.0)
    restarted.history.close()
    again = service([10.0], history=WearHistory(path))
    assert not again.latch.active and again.latch.evidence == 0.0


def test_config_from_the_node_parameters_takes_the_alarm_policy_of_the_parameters():
    values = node_config.load_node_parameters(node_config.WEAR_ESTIMATOR_NODE,
                                              overrides={'alarm_rule': 'estimate',
                                                         'alarm_evidence': 2.0,
                                                         'wear_threshold': 40.0})
    config = EstimatorConfig.from_node_parameters(values, params=PARAMS)
    assert config.alarm == AlarmPolicy(threshold=40.0, healthy=25.0, evidence_to_raise=2.0,
                                       rule='estimate', probability=0.15)
    assert EstimatorConfig(joint='joint_2', params=PARAMS).alarm == AlarmPolicy()


# --------------------------------------------------------------------------- intervals, trend

def _real_service(history, **config):
    return WearEstimatorService(EstimatorConfig(
        joint='joint_2', params=PARAMS, experiment_speeds_rad_s=(2.1, 28.5, 35.1, 41.7),
        **config), history=history)


def _levels_of(k, wear, rng):
    from wear_testing import independent_robot as robot
    speeds = (2.1, 28.5, 35.1, 41.7)
    temperature, load = rng.uniform(30.0, 50.0), rng.normal(0.5, 0.1)
    frictions = [float(robot.friction_model(v, load, temperature, wear)
                       + rng.normal(0.0, PARAMS.sigma)) for v in speeds]
    return messages.FrictionLevelsMessage(stamp_s=3600.0 * k, joint='joint_2',
                                          speeds_rad_s=speeds, frictions=tuple(frictions))


def test_every_estimate_carries_intervals_and_the_trend_survives_a_restart(tmp_path):
    rng = np.random.default_rng(4)
    truth = np.concatenate([np.zeros(4), np.linspace(2.0, 50.0, 10)])
    levels = [_levels_of(k, w, rng) for k, w in enumerate(truth)]
    path = tmp_path / 'h.sqlite3'
    svc = _real_service(WearHistory(path))
    updates = [svc.process_levels(lv) for lv in levels[:10]]
    for update, w in zip(updates, truth):
        low, high = update.wear_interval
        assert 0.0 <= low <= update.wear <= high and high - low <= 42.0
        assert not update.wear_std > 100.0  # NaN where the Fisher std means nothing
        entry = update.to_json()
        assert entry['wear_interval'] == [low, high] and entry['trend']['wear'] is not None
        assert update.status.value('wear_low') and update.status.value('trend_wear')
    # w = 0: where the interval reaches the bound, only the interval is reported (one of these
    # four new-joint experiments reads w-hat 17 [5, 27]: a 95 % interval misses 1 in 20)
    at_bound = [u for u in updates[:4] if u.wear_interval[0] == 0.0]
    assert len(at_bound) >= 3 and all(math.isnan(u.wear_std) for u in at_bound)
    trend = [u.trend.wear for u in updates]
    raw = [u.wear for u in updates]
    assert np.abs(np.diff(trend)).sum() < np.abs(np.diff(raw)).sum()  # the trend smooths
    # The trend's own coverage is tested in test/estimation/test_trend.py; here: it follows.
    covered = sum(u.trend.wear_low - 1.0 <= w <= u.trend.wear_high
                  for u, w in zip(updates, truth))
    assert covered >= 6
    stored = svc.history.records(joint='joint_2')
    assert [r.trend_wear for r in stored] == pytest.approx(trend)
    assert [r.wear_low for r in stored] == pytest.approx([u.wear_interval[0] for u in updates])
    svc.history.close()

    restarted = _real_service(WearHistory(path))
    continued = _real_service(WearHistory(':memory:'))
    for lv in levels[:10]:
        continued.process_levels(lv)
    for lv in levels[10:]:
        a, b = restarted.process_levels(lv), continued.process_levels(lv)
        assert a.trend.wear == pytest.approx(b.trend.wear, abs=1e-9)
        assert a.trend.probability_above_threshold == pytest.approx(
            b.trend.probability_above_threshold, abs=1e-9)
    assert a.trend.probability_above_threshold > 0.5 and truth[-1] >= 35
    restarted.history.close()


def test_the_trend_rule_raises_on_the_trend_and_a_reset_starts_a_new_segment(tmp_path):
    rng = np.random.default_rng(9)
    svc = _real_service(WearHistory(':memory:'),
                        alarm=AlarmPolicy(rule='trend', probability=0.5))
    truth = np.linspace(10.0, 60.0, 12)
    updates = [svc.process_levels(_levels_of(k, w, rng)) for k, w in enumerate(truth)]
    raised = [u.index for u in updates if u.alarm_raised]
    assert len(raised) == 1
    assert truth[raised[0] - 1] >= 30.0
    assert updates[raised[0] - 1].trend.probability_above_threshold >= 0.5
    ok, message = svc.reset_alarm(stamp_s=3600.0 * 12.5)
    assert ok and 'trend reset' in message
    after = svc.process_levels(_levels_of(13, 0.0, rng))
    assert after.trend.segment == 1 and after.trend.wear < 20.0 and not after.alarm_active


def test_a_reset_stored_through_the_history_is_the_ros_reset_to_a_restarted_estimator(
        history_location, tmp_path, request):
    """
    The dashboard's reset (history.reset_alarm) and ~/reset_alarm restore the same state.

    Three estimators after the same experiments: restarted after a reset stored through the
    history, restarted after ~/reset_alarm, and one that runs on while the dashboard resets
    (it takes the reset over before its next experiment); all go on like the node that was
    reset by its service and never stopped.
    """
    if history_location.startswith('postgresql'):
        other = request.getfixturevalue('postgresql_server').create_database()
        running_location = request.getfixturevalue('postgresql_server').create_database()
    else:
        other = str(tmp_path / 'ros.sqlite3')
        running_location = str(tmp_path / 'running.sqlite3')
    rng = np.random.default_rng(9)
    truth = [*np.linspace(10.0, 60.0, 12), 60.0, 60.0, 5.0]  # then the old level, then new
    levels = [_levels_of(k, w, rng) for k, w in enumerate(truth)]
    policy = AlarmPolicy(rule='estimate', evidence_to_raise=12.0)
    live = _real_service(WearHistory(':memory:'), alarm=policy)  # the ROS node, never stopped
    for location in (history_location, other):
        node = _real_service(WearHistory(location), alarm=policy)
        for lv in levels[:12]:
            node.process_levels(lv)
            if location == other:
                live.process_levels(lv)
        assert node.latch.active
        if location == other:
            node.reset_alarm(stamp_s=3600.0 * 12.5)  # ~/reset_alarm, then the node stops
        node.history.close()
    live.reset_alarm(stamp_s=3600.0 * 12.5)
    running = _real_service(WearHistory(running_location), alarm=policy)
    for lv in levels[:12]:
        running.process_levels(lv)
    assert running.follow_history_reset() is None  # nothing new: its own raise
    with WearHistory(running_location) as dashboard_connection:
        dashboard_connection.reset_alarm(joint='joint_2', user='ana', reason='gear replaced')
    assert running.latch.active  # until it looks
    with WearHistory(history_location) as history:  # the dashboard, while no node runs
        old_evidence = history.records(joint='joint_2')[-1].alarm_evidence
        assert old_evidence >= policy.evidence_to_raise  # enough to raise again at once
        history.reset_alarm(joint='joint_2', user='ana', reason='gear box replaced',
                            stamp_s=3600.0 * 12.5)
    dashboard = _real_service(WearHistory(history_location), alarm=policy)
    ros = _real_service(WearHistory(other), alarm=policy)
    for restarted in (dashboard, ros):
        assert not restarted.latch.active and restarted.latch.evidence == 0.0
        assert restarted.wear_trend.segment == 1  # the trend restarted after the last estimate
    for k, lv in enumerate(levels[12:]):
        a, b, c = dashboard.process_levels(lv), ros.process_levels(lv), live.process_levels(lv)
        d = running.process_levels(lv)
        if k == 0:  # w-hat at the old level: the fresh evidence alone does not raise
            assert a.wear > 50.0 and not a.alarm_active
            assert 0.0 < dashboard.latch.evidence < policy.evidence_to_raise
        for other_update, other_service in ((b, ros), (c, live), (d, running)):
            assert (a.alarm_active, a.alarm_raised) == (other_update.alarm_active,
                                                        other_update.alarm_raised)
            assert dashboard.latch.evidence == pytest.approx(other_service.latch.evidence)
            assert a.trend.segment == other_update.trend.segment == 1
            assert a.trend.wear == pytest.approx(other_update.trend.wear, abs=1e-9)
            assert a.trend.probability_above_threshold == pytest.approx(
                other_update.trend.probability_above_threshold, abs=1e-9)
    assert a.alarm_active  # the second experiment at the old level raises it again: new evidence
    assert [e.event for e in running.history.events(joint='joint_2')] == [
        'raised', 'reset', 'raised']  # the reset taken over was not stored twice
    for service in (dashboard, ros, running):
        service.history.close()


def test_a_reset_stored_while_an_experiment_is_estimated_makes_that_row_the_new_lifes(
        history_location):
    """
    The dashboard resets while the estimator works on an experiment (a replay under way).

    The store refuses the old life's row (the latch moved under it), the estimator takes the
    reset over and estimates the experiment again: the row stored after the reset has the
    alarm clear and the trend of the new life, and the fleet shows the new life.
    """
    from robot_wear_monitor.monitoring import estimator_service
    rng = np.random.default_rng(9)
    truth = [*np.linspace(10.0, 60.0, 12), 5.0]  # worn out, then a new gear box
    levels = [_levels_of(k, w, rng) for k, w in enumerate(truth)]
    policy = AlarmPolicy(rule='estimate', evidence_to_raise=12.0)
    svc = _real_service(WearHistory(history_location), alarm=policy)
    for lv in levels[:12]:
        svc.process_levels(lv)
    assert svc.latch.active
    calls = []

    def estimate_while_the_dashboard_resets(speeds, frictions, *, params):
        calls.append(len(calls))
        if len(calls) == 1:  # the reset lands in the middle of this experiment
            with WearHistory(history_location) as dashboard:
                dashboard.reset_alarm(joint='joint_2', user='ana', reason='gear box replaced')
        return estimator_service._default_estimate(speeds, frictions, params=params)

    svc._estimate = estimate_while_the_dashboard_resets
    update = svc.process_levels(levels[12])
    assert len(calls) == 2  # estimated again in the new life
    assert not update.alarm_active and not svc.latch.active
    assert update.trend.segment == 1 and update.trend.wear < 20.0
    assert svc.experiments == 13  # the retry counts once
    with WearHistory(history_location) as history:
        stored = history.records(joint='joint_2')
        [reset] = [e for e in history.events(joint='joint_2') if e.event == 'reset']
        [row] = history.fleet()
    assert len(stored) == 13 and reset.estimate_id == stored[11].id  # tied to the old life
    assert not stored[-1].alarm_active and stored[-1].trend_wear < 20.0
    assert (row.experiments, row.alarm, row.life_started_s) == (1, False, reset.stamp_s)
    assert row.trend_wear == stored[-1].trend_wear
