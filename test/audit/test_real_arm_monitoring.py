"""
The real arm's sets as the nodes and the replay use them; a set without a wear model.

The levels come from :mod:`wear_testing.real_arm_logger` (independent of the package's model
code; motor current [A], 2 Hz, eq. (3) over position bins, joint speeds x gear ratio 100).

* The estimator service the nodes and ``replay`` share (``WearEstimatorService``), fed
  ``FrictionExperiment`` levels as the replay feeds it, accepts the robot's own monitoring
  groups with the set ``identify`` wrote, untouched: every estimate valid, T-hat within 3 degC
  of the measured temperature, no w-hat at the warning level (28).
* ``robot-wear-monitor replay`` of a JointState bag of the generator's samples (logged at
  50 Hz, as a controller's joint_states: at 2 Hz the passes are too short for the nodes'
  time-window levels), motor current as effort (torque scale 1, gear ratio 100), with that
  set: every experiment valid, T-hat within 3 degC of the mean reading and in order, w-hat
  below the warning level, no alarm.
* ``identify --no-wear-model`` writes a set that estimates the temperature only: ``estimate``
  reports T-hat (within 3 degC, in order) and w-hat "not determined" (null in --json, no
  alarm); the service does the same (no alarm, no trend, the history row marked as not judging
  the wear); what needs a wear model (design, simulate) is refused naming it.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.experiment.levels import FrictionExperiment, FrictionLevel
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.estimator_service import (EstimatorConfig,
                                                             WearEstimatorService)
from wear_testing import real_arm_logger as arm

#: The monitoring sessions: (payload, seed); each gives 5 groups 12 minutes apart.
MONITORING = ((False, 11), (True, 12))


@pytest.fixture(scope='module')
def sets(tmp_path_factory):
    """Identify the arm's levels twice: the default set and one without a wear model."""
    folder = tmp_path_factory.mktemp('real_arm_sets')
    levels = arm.identification_levels(seed=0)
    table = folder / 'arm_levels.csv'
    arm.write_csv(table, {k: levels[k] for k in (
        'experiment', 'speed', 'friction', 'temperature', 'load')})
    args = ['identify', str(table), '--friction-unit', 'A', '--gear-ratio',
            str(arm.GEAR_RATIO)]
    assert main(args + ['--out', str(folder / 'arm.yaml')]) == 0
    assert main(args + ['--no-wear-model', '--out', str(folder / 'arm_t.yaml')]) == 0
    return folder


def _groups(payload: bool, seed: int) -> list[dict]:
    session = arm.Session(payload=payload, room_degc=22.0 + seed % 3)
    return arm.monitoring_groups(session, seed=seed, every_s=720.0)


def _experiment(group: dict, index: int) -> FrictionExperiment:
    """Return a group as the segmentation hands it to the service (motor speeds [rad/s])."""
    start = 720.0 * index
    levels = tuple(FrictionLevel(
        speed_rad_s=float(v) * arm.GEAR_RATIO, friction=float(f), friction_std_error=0.01,
        tau_forward=float(f), tau_backward=-float(f), n_forward=4, n_backward=4,
        position_min_rad=-0.3, position_max_rad=0.9, start_time_s=start + 12.0 * i,
        end_time_s=start + 12.0 * i + 10.0)
        for i, (v, f) in enumerate(zip(group['speeds'], group['friction'])))
    return FrictionExperiment(levels=levels)


@pytest.mark.parametrize('payload, seed', MONITORING)
def test_the_service_accepts_the_robots_own_levels_with_its_set(sets, payload, seed):
    params = load_parameter_set(sets / f'arm_load{2 if payload else 1}.yaml')
    service = WearEstimatorService(EstimatorConfig(joint='joint_2', params=params))
    groups = _groups(payload, seed)
    updates = [service.process_experiment(_experiment(g, i)) for i, g in enumerate(groups)]
    assert all(u is not None for u in updates), service.rejections
    assert all(u.valid for u in updates), [u.plausibility.text() for u in updates]
    measured = [g['temperature'] for g in groups]
    t_hat = [u.temperature_degc for u in updates]
    assert np.all(np.abs(np.subtract(t_hat, measured)) <= 3.0), (measured, t_hat)
    assert all(math.isfinite(u.wear) for u in updates)
    assert max(u.wear for u in updates) < params.wear_warning == 28.0
    assert not any(u.alarm_active for u in updates)
    assert service.invalid_estimates == 0 and not service.rejections


def test_replay_of_a_bag_of_the_arm_with_its_set(sets, tmp_path, monkeypatch, capsys):
    from robot_wear_monitor.recordings.bags.writer import write_joint_state_bag
    monkeypatch.setattr(arm, 'SAMPLE_RATE_HZ', 50.0)
    log = arm.log_session(arm.Session(payload=False, room_degc=23.0), seed=77, visit_s=12.0)
    order = np.argsort(log['t_s'])
    rows = order[log['sweep'][order] < 6]  # six whole sweeps (20 minutes), one experiment each
    stamps = 1000.0 + log['t_s'][rows]
    bag = write_joint_state_bag(
        tmp_path / 'arm_bag', stamps_s=stamps, names=['joint_2'],
        position=log['q_rad'][rows, None], velocity=log['dq_rad_s'][rows, None],
        effort=log['current_a'][rows, None])
    summary = tmp_path / 'summary.json'
    assert main(['replay', str(bag), '--out', str(tmp_path / 'monitored'), '--json-out',
                 str(summary), '--gear-ratio', str(arm.GEAR_RATIO), '--torque-scale', '1',
                 '--params', str(sets / 'arm_load1.yaml')]) == 0
    capsys.readouterr()
    experiments = json.loads(summary.read_text())['experiments']
    sweeps = log['sweep'][rows]
    readings, t_hat = [], []
    for e in experiments:
        # the experiment of a sweep ends at its last level, within the sweep's samples
        sweep = sweeps[np.searchsorted(stamps, e['stamp_s']) - 1]
        readings.append(float(log['temperature_degc'][rows][sweeps == sweep].mean()))
        t_hat.append(e['temperature_degc'])
        assert e['valid'] and not e['alarm'], e
        assert e['wear'] < 28.0, e
    assert len(experiments) == 6
    assert np.all(np.abs(np.subtract(t_hat, readings)) <= 3.0), (readings, t_hat)
    assert np.all(np.diff(t_hat) > 0), t_hat
    # the same bag with the set without a wear model: T-hat only, nothing said of wear
    assert main(['replay', str(bag), '--out', str(tmp_path / 'monitored_t'), '--json-out',
                 str(summary), '--gear-ratio', str(arm.GEAR_RATIO), '--torque-scale', '1',
                 '--params', str(sets / 'arm_t_load1.yaml')]) == 0
    capsys.readouterr()
    only_t = json.loads(summary.read_text())['experiments']
    assert len(only_t) == 6
    assert all(e['wear'] is None and e['wear_determined'] is False and not e['alarm']
               and 'wear not determined' in e['message'] for e in only_t)
    assert np.all(np.abs(np.subtract([e['temperature_degc'] for e in only_t], readings)) <= 3.0)


def _estimate(capsys, group: dict, params_file, *extra: str) -> str:
    capsys.readouterr()
    speeds = ','.join(f'{v * arm.GEAR_RATIO:.6g}' for v in group['speeds'])
    assert main(['estimate', '--speeds', speeds,
                 '--friction', ','.join(f'{f:.6g}' for f in group['friction']),
                 '--params', str(params_file), *extra]) == 0
    return capsys.readouterr().out


def test_a_set_without_a_wear_model_says_so(sets):
    text = (sets / 'arm_t_load1.yaml').read_text()
    params = load_parameter_set(sets / 'arm_t_load1.yaml')
    assert params.not_identified == ('wear',) and not params.estimates_wear
    assert params.model.f_s_wear == 0.0 and params.model.f_v_wear == 0.0
    assert '# Wear profile, eq. (7): none (identify --no-wear-model)' in text
    assert 'scaled from' not in text and 'Assumption' not in text
    default = load_parameter_set(sets / 'arm_load1.yaml')
    assert default.estimates_wear and default.model.f_s_wear > 0  # the default keeps it
    # everything but the wear model is the default set's
    assert (params.load_mean, params.speed_min_rad_s, params.sigma) == (
        default.load_mean, default.speed_min_rad_s, default.sigma)


@pytest.mark.parametrize('payload, seed', MONITORING)
def test_estimate_reports_temperature_only_with_such_a_set(sets, capsys, payload, seed):
    params_file = sets / f'arm_t_load{2 if payload else 1}.yaml'
    groups = _groups(payload, seed)
    reports = [json.loads(_estimate(capsys, g, params_file, '--json')) for g in groups]
    measured = [g['temperature'] for g in groups]
    t_hat = [r['temperature'] for r in reports]
    assert all(r['valid'] for r in reports), [r['invalid_reasons'] for r in reports]
    if not payload:
        # with the payload, T-hat errs up to 6 degC: the model error of (5) there, which
        # the wear term takes up when there is one (docs/identify.md, T-hat only)
        assert np.all(np.abs(np.subtract(t_hat, measured)) <= 3.0), (measured, t_hat)
        assert np.all(np.diff(t_hat) > 0), (measured, t_hat)
    for r in reports:
        assert r['wear'] is None and r['wear_std'] is None and r['wear_determined'] is False
        assert r['alarm'] is None and r['warning'] is False
        assert r['wear_interval'] == [None, None]
        low, high = r['temperature_interval']
        assert low <= r['temperature'] <= high
    text = _estimate(capsys, groups[0], params_file)
    assert 'wear w [-]          not determined' in text
    assert 'alarm               none (no wear model)' in text
    assert text.startswith(f'temperature estimate from N = {len(groups[0]["speeds"])} level')


def test_the_service_reports_temperature_only_with_such_a_set(sets):
    params = load_parameter_set(sets / 'arm_t_load1.yaml')
    history = WearHistory(':memory:')
    service = WearEstimatorService(EstimatorConfig(joint='joint_2', params=params),
                                   history=history)
    groups = _groups(False, 11)
    updates = [service.process_experiment(_experiment(g, i)) for i, g in enumerate(groups)]
    assert all(u is not None and u.valid for u in updates), service.rejections
    measured = [g['temperature'] for g in groups]
    assert np.all(np.abs(np.subtract([u.temperature_degc for u in updates], measured)) <= 3.0)
    for update in updates:
        assert math.isnan(update.wear) and not update.wear_determined
        assert not update.alarm_active and update.trend is None
        summary = update.to_json()
        assert summary['wear'] is None and summary['wear_determined'] is False
        assert 'wear not determined' in update.status.message
        assert update.status.value('wear') == 'not determined'
        low, high = update.temperature_interval
        assert low <= update.temperature_degc <= high
    records = history.restore(joint='joint_2', trend_length=100).records
    assert len(records) == len(groups)
    assert all(not r.valid and 'wear not determined' in r.invalid_reason for r in records)
    # a restart restores no trend and no alarm from these rows
    again = WearEstimatorService(EstimatorConfig(joint='joint_2', params=params),
                                 history=history)
    assert not again.latch.active and again.restored_estimates == len(groups)


def test_what_needs_a_wear_model_is_refused_and_options_that_contradict_it(sets, capsys):
    params_file = str(sets / 'arm_t_load1.yaml')
    capsys.readouterr()
    assert main(['design', '--n', '3', '--params', params_file]) == 2
    assert 'did not identify wear' in capsys.readouterr().err
    table = str(sets / 'arm_levels.csv')
    for extra in (['--borrowed-wear', 'reference'],
                  ['--wear-test', table, '--critical-experiment', '1']):
        assert main(['identify', table, '--no-wear-model', '--out',
                     str(sets / 'never.yaml'), *extra]) == 2
        assert '--no-wear-model' in capsys.readouterr().err
    assert not (sets / 'never.yaml').exists()
