"""
The threshold a joint is judged by has one owner: the node parameter, stored with each estimate.

A site that sets ``wear_threshold: 30`` in its node configuration (the packaged
``config/wear_monitor.yaml`` with that line edited, given with ``--config``) gets alarms at 30,
and ``fleet --json``, ``/api/fleet``, the fleet page and the joint page all say 30, although
the parameter set's ``alarm.wear_threshold`` is 35; the replay warns once that the two differ.
A simulated joint whose true wear rises linearly from 10 to 38 over 40 experiments is replayed
with both configurations: the same estimates, judged against 30 and against 35.
"""

import csv
import dataclasses
import io
import json
import math
import re

from fastapi import testclient as fastapi_testclient
import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                      simulate_scenario)
from robot_wear_monitor.fleet.notifications import due_events
from robot_wear_monitor.fleet.ranking import fleet_view
from robot_wear_monitor.history import HistoryRecord, WearHistory
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.node_config import (default_node_config_file,
                                                       load_node_parameters,
                                                       WEAR_ESTIMATOR_NODE)
from robot_wear_monitor.monitoring.wear_update import EstimatorConfig
from robot_wear_monitor.recordings.bags import write_joint_state_bag
from wear_testing.fleet_history import login

EXPERIMENTS = 40
#: the true wear of the simulated joint, experiment by experiment
TRUE_WEAR = np.linspace(10.0, 38.0, EXPERIMENTS)
SITE_THRESHOLD = 30.0
PASSWORD = 'viewer-pass-22'
#: a page or an answer that calls 35 the threshold ("threshold 35", "threshold: 35.0", ...)
CALLS_35_THE_THRESHOLD = re.compile(r'threshold\W{0,12}(?:w\W{0,4})?35(?![\d.]*[1-9])')


def _site_config(path):
    """Write the packaged node configuration with its wear_threshold line set to 30."""
    text = default_node_config_file().read_text(encoding='utf-8')
    lines = [line for line in text.splitlines() if line.strip().startswith('wear_threshold:')]
    assert len(lines) == 1 and 'wear_threshold: 0.0' in lines[0]  # 0: the set's (35)
    path.write_text(text.replace('wear_threshold: 0.0', 'wear_threshold: 30.0'),
                    encoding='utf-8')
    return path


@pytest.fixture(scope='module')
def replays(tmp_path_factory):
    """Replay the joint with the site's configuration (30) and the packaged one (35)."""
    folder = tmp_path_factory.mktemp('threshold')
    config = accelerated_wear_scenario(n_experiments=EXPERIMENTS, seed=6)
    config = dataclasses.replace(config, wear=tuple(TRUE_WEAR.tolist()))
    scenario = simulate_scenario(config=config, seed=6)
    bag = folder / 'bag'
    write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort)
    site = _site_config(folder / 'site.yaml')
    out = {}
    for name, extra in (('site', ['--config', str(site)]), ('packaged', [])):
        history = folder / f'{name}.sqlite3'
        summary = folder / f'{name}.json'
        assert main(['replay', str(bag), '--history', str(history), '--json-out', str(summary),
                     '--no-progress', *extra]) == 0
        out[name] = (str(history), json.loads(summary.read_text(encoding='utf-8')))
    return out


def _first_alarm(summary):
    return summary['first_alarm']['index'] if summary['first_alarm'] else None


def test_the_joint_alarms_at_the_sites_threshold(replays):
    _, site = replays['site']
    _, packaged = replays['packaged']
    probability = load_node_parameters(WEAR_ESTIMATOR_NODE)['alarm_probability']
    trends = [e['trend'] for e in site['experiments']]
    assert all(t['threshold'] == SITE_THRESHOLD for t in trends)
    assert all(e['trend']['threshold'] == 35.0 for e in packaged['experiments'])
    # the same estimates, judged against 30: P(w >= 30) >= P(w >= 35) in every experiment
    assert [e['wear'] for e in site['experiments']] == [e['wear'] for e in packaged['experiments']]
    above_30 = np.array([t['probability_above_threshold'] for t in trends])
    above_35 = np.array([e['trend']['probability_above_threshold']
                         for e in packaged['experiments']])
    assert np.all(above_30 >= above_35) and np.any(above_30 > above_35 + 0.1)
    # raised by the first experiment whose P(w >= 30) reaches the alarm probability, and
    # before the run judged against 35 (whose first alarm is that of P(w >= 35))
    first = _first_alarm(site)
    assert first == 1 + int(np.argmax(above_30 >= probability))
    assert _first_alarm(packaged) == 1 + int(np.argmax(above_35 >= probability))
    assert first < _first_alarm(packaged)
    assert TRUE_WEAR[-1] >= 38.0 - 1e-9 and site['state'][0]['alarm']
    assert (site['state'][0]['threshold'], site['state'][0]['warning_level']) == (30.0, 28.0)
    assert (packaged['state'][0]['threshold'], packaged['state'][0]['warning_level']) == (
        35.0, 28.0)
    with WearHistory(replays['site'][0], init=False) as history:
        records = history.records(joint='joint_2')
        [raised] = [e for e in history.events(joint='joint_2') if e.event == 'raised']
    assert {(r.threshold, r.warning_level) for r in records} == {(30.0, 28.0)}
    assert raised.note.startswith('trend P(w >= 30) = ')


def test_the_replay_warns_once_that_the_node_and_the_set_differ(tmp_path, replays, capsys):
    site_history, _ = replays['site']
    bag = str(site_history).replace('site.sqlite3', 'bag')
    site = _site_config(tmp_path / 'site.yaml')
    capsys.readouterr()
    assert main(['replay', bag, '--config', str(site), '--history', str(tmp_path / 'h.db'),
                 '--no-progress']) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if line.startswith('warning: ')]
    assert warnings == [
        "warning: joint 'joint_2': the node parameters differ from parameter set "
        "'abb_irb6620_joint2': wear_threshold 30 (the set says 35); the node's values are "
        'used and stored with every estimate']
    assert main(['replay', bag, '--history', str(tmp_path / 'h35.db'), '--no-progress']) == 0
    assert 'warning' not in capsys.readouterr().err


def test_the_node_configuration_wins_and_says_so_only_when_it_differs():
    values = load_node_parameters(WEAR_ESTIMATOR_NODE)
    params = load_parameter_set()
    assert EstimatorConfig.from_node_parameters(values, params=params).levels_warning() == ''
    config = EstimatorConfig.from_node_parameters(
        {**values, 'wear_threshold': 30.0, 'wear_warning': 24.0, 'robot_id': 'cell_1'},
        params=params)
    assert config.alarm.threshold == 30.0 and config.wear_warning == 24.0
    assert config.levels_warning() == (
        "robot 'cell_1' joint 'joint_2': the node parameters differ from parameter set "
        "'abb_irb6620_joint2': wear_threshold 30 (the set says 35), wear_warning 24 (the set "
        "says 28); the node's values are used and stored with every estimate")


def test_fleet_json_the_api_and_the_pages_all_say_30(replays, capsys):
    history, _ = replays['site']
    capsys.readouterr()
    assert main(['fleet', '--history', history, '--json']) == 0
    [row] = json.loads(capsys.readouterr().out)
    assert (row['threshold'], row['warning_level'], row['threshold_assumed']) == (
        30.0, 28.0, False)
    assert row['alarm'] is True
    assert main(['fleet', '--history', history, '--wide']) == 0  # threshold, then alarm
    table = capsys.readouterr().out
    assert re.search(r'\b30\s+LATCHED', table) and not CALLS_35_THE_THRESHOLD.search(table)
    assert main(['fleet', '--history', history]) == 0  # the default: the alarm below the row
    table = capsys.readouterr().out
    assert re.search(r'ALARM .* 30 ', table) and not CALLS_35_THE_THRESHOLD.search(table)
    assert main(['fleet', '--history', history, '--csv']) == 0
    [line] = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert (line['threshold'], line['threshold_assumed']) == ('30', 'no')
    assert main(['history', history, '--json']) == 0
    estimates = json.loads(capsys.readouterr().out)['estimates']
    assert {(e['threshold'], e['warning_level']) for e in estimates} == {(30.0, 28.0)}
    with WearHistory(history, init=False) as stored:
        stored.add_user(name='vic', role='viewer', password=PASSWORD)
    app = create_app(DashboardSettings(history=history))
    with fastapi_testclient.TestClient(app) as client:
        assert login(client, 'vic', PASSWORD).status_code == 303
        [api] = client.get('/api/fleet').json()['rows']
        # every key of fleet --json is in /api/fleet under its name, with its value
        assert {key: api[key] for key in row if key != 'stale'} == {
            key: value for key, value in row.items() if key != 'stale'}
        assert api['text']['threshold'] == '30'
        # the bar: 0 to 1.5 x 30, the tick at 30
        assert api['bar']['scale_max'] == pytest.approx(45.0)
        assert api['bar']['threshold'] == pytest.approx(100.0 / 1.5, abs=0.01)
        wear_pct = 100.0 * min(api['wear'], 45.0) / 45.0
        assert api['bar']['wear'] == pytest.approx(wear_pct, abs=0.01)
        joint = client.get('/api/robots/default/joints/joint_2').json()
        assert (joint['threshold'], joint['threshold_assumed'], joint['threshold_text']) == (
            30.0, False, '30')
        assert joint['state']['threshold'] == 30.0
        fleet_page = client.get('/').text
        joint_page = client.get('/robots/default/joints/joint_2').text
    assert 'threshold 30</span>' in fleet_page
    assert '<dd id="f-threshold">30</dd>' in joint_page
    assert '"threshold": 30.0' in joint_page and '"threshold_text": "30"' in joint_page
    assert 'assumed' not in fleet_page and 'threshold-note' not in joint_page
    for text in (fleet_page, joint_page, json.dumps(api), json.dumps(joint)):
        assert not CALLS_35_THE_THRESHOLD.search(text), CALLS_35_THE_THRESHOLD.search(text)


def _record(k, *, threshold, trend, crossing):
    return HistoryRecord(
        robot='cell_1', joint='joint_2', stamp_s=1.8e9 + 3600.0 * k, speeds_rad_s=(2.1, 28.5),
        frictions=(0.1, 0.05), temperature_degc=40.0, temperature_std_degc=1.0, wear=trend,
        wear_std=2.0, chi2=1.0, dof=1, p_value=0.5, temperature_at_bound=False,
        wear_at_bound=False, alarm_active=False, alarm_evidence=0.0, status_level=0,
        parameter_set='abb_irb6620_joint2', wear_low=trend - 4.0, wear_high=trend + 4.0,
        trend_wear=trend, trend_low=trend - 2.0, trend_high=trend + 2.0,
        crossing_experiments=crossing, crossing_time_s=math.nan, threshold=threshold,
        warning_level=24.0)


def test_the_forecast_and_the_notifications_use_the_stored_threshold(tmp_path):
    """A joint judged by 30 whose trend (24) crosses it in 4 experiments: cone and notice."""
    from robot_wear_monitor.dashboard.views import forecast_cone, joint_json
    from robot_wear_monitor.fleet.notifications import load_notification_config
    from robot_wear_monitor.fleet.thresholds import ParameterSets
    path = tmp_path / 'h.db'
    with WearHistory(path) as history:
        for k, trend in enumerate((18.0, 20.0, 22.0, 24.0)):
            history.append(_record(k, threshold=SITE_THRESHOLD, trend=trend,
                                   crossing=(SITE_THRESHOLD - trend) / 1.5))
        records = history.records(joint='joint_2', robot='cell_1')
        now_s = records[-1].stamp_s + 60.0
        story = joint_json(history, robot='cell_1', joint='joint_2', now_s=now_s,
                           parameter_sets=ParameterSets())
        [view] = fleet_view(history.fleet(), now_s=now_s)
        notify = tmp_path / 'notify.yaml'
        notify.write_text('events: [forecast_crossing]\nforecast_horizon_days: 30\n'
                          'webhooks: [{name: m, url: "http://127.0.0.1:9/x"}]\n')
        [event] = due_events(history=history, config=load_notification_config(notify),
                             now_s=now_s)
    cone = story['forecast']
    # the cone's middle line meets 30 (not 35) at the stored crossing, 4 experiments ahead
    assert max(cone['wear']) == pytest.approx(SITE_THRESHOLD)
    assert cone['crossing_experiments'] == pytest.approx(4.0)
    assert cone['rate_per_experiment'] == pytest.approx(1.5)
    assert forecast_cone(records, threshold=35.0)['rate_per_experiment'] == pytest.approx(2.75)
    assert (story['threshold'], story['warning_level']) == (30.0, 24.0)
    assert (view.threshold, view.threshold_assumed) == (30.0, False)
    assert 'the wear threshold 30 is forecast to be crossed by' in event.summary
    assert 'Wear threshold: 30 (the alarm level' in event.description


def test_a_row_without_a_stored_threshold_takes_its_own_sets_given_by_file(tmp_path):
    """An older row of a site set (threshold 40) read with ``--params``: 40, assumed."""
    from robot_wear_monitor.fleet.notifications import load_notification_config
    from robot_wear_monitor.fleet.thresholds import ParameterSets
    from robot_wear_monitor.model.params import default_parameter_file
    text = default_parameter_file().read_text(encoding='utf-8')
    assert 'name: abb_irb6620_joint2' in text and 'wear_threshold: 35.0' in text
    site_set = tmp_path / 'site_set.yaml'
    site_set.write_text(text.replace('name: abb_irb6620_joint2', 'name: site_set')
                        .replace('wear_threshold: 35.0', 'wear_threshold: 40.0'),
                        encoding='utf-8')
    sets = ParameterSets([site_set])
    with WearHistory(tmp_path / 'h.db') as history:
        for k, trend in enumerate((30.0, 31.0, 32.0)):
            history.append(dataclasses.replace(
                _record(k, threshold=math.nan, trend=trend, crossing=8.0 - k),
                parameter_set='site_set', warning_level=math.nan))
        now_s = 1.8e9 + 3 * 3600.0
        [view] = fleet_view(history.fleet(), now_s=now_s, parameter_sets=sets)
        [packaged] = fleet_view(history.fleet(), now_s=now_s)
        notify = tmp_path / 'notify.yaml'
        notify.write_text('events: [forecast_crossing]\nforecast_horizon_days: 30\n'
                          'webhooks: [{name: m, url: "http://127.0.0.1:9/x"}]\n')
        [event] = due_events(history=history, config=load_notification_config(notify),
                             now_s=now_s, parameter_sets=sets)
    assert (view.threshold, view.threshold_assumed) == (40.0, True)
    assert view.as_json()['threshold'] == 40.0 and view.as_json()['threshold_assumed']
    # without the file the name is not known: the packaged default set's 35, also assumed
    assert (packaged.threshold, packaged.threshold_assumed) == (35.0, True)
    assert 'the wear threshold 40 (assumed) is forecast to be crossed' in event.summary
