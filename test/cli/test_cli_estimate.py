"""``robot-wear-monitor estimate``: JSON fields, text output, one-line errors."""

import json
import math

import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.estimation.wear_report import meaningful_std, wear_report
from robot_wear_monitor.model.params import load_parameter_set

GRID_27 = '2.1,8.7,15.3,21.9,28.5,35.1,41.7,82.2,133.5,184.7,236.2,287.1'


def _json(capsys, argv):
    assert main(argv) == 0
    out = capsys.readouterr().out
    return json.loads(out)


def test_estimate_json_fields_and_null_p_value(capsys):
    payload = _json(capsys, ['estimate', '--speeds', '35.84,40.84', '--friction',
                             '0.0622,0.0598', '--json'])
    for key in ('temperature', 'wear', 'covariance', 'alarm', 'chi2', 'p_value', 'wear_std',
                'dof', 'temperature_at_bound', 'wear_at_bound'):
        assert key in payload
    assert len(payload['covariance']) == 2 and len(payload['covariance'][0]) == 2
    assert isinstance(payload['alarm'], bool)
    assert payload['alarm'] == (payload['wear'] >= 35.0)
    if payload['dof'] == 0:
        assert payload['p_value'] is None


def test_estimate_with_redundancy_has_a_p_value_and_human_output(capsys):
    payload = _json(capsys, ['estimate', '--speeds', '31.65,36.65,41.65,46.65', '--friction',
                             '0.0641,0.0628,0.0612,0.0597', '--json'])
    assert payload['dof'] >= 1 and 0.0 <= payload['p_value'] <= 1.0
    assert main(['estimate', '--speeds', '38.6', '--friction', '0.06']) == 0
    out = capsys.readouterr().out
    assert 'temperature [degC]' in out and 'wear w' in out and 'alarm' in out


def test_estimate_json_is_the_wear_report_of_the_estimation_package(capsys):
    speeds, frictions = [31.65, 36.65, 41.65, 46.65], [0.0641, 0.0628, 0.0612, 0.0597]
    payload = _json(capsys, ['estimate', '--speeds', ','.join(map(str, speeds)), '--friction',
                             ','.join(map(str, frictions)), '--json'])
    report = wear_report(speeds_rad_s=speeds, frictions=frictions,
                         params=load_parameter_set(None))
    assert payload == json.loads(json.dumps(report.to_dict()))
    low, high = payload['wear_interval']
    assert low <= payload['wear'] <= high


def test_meaningful_std_keeps_an_interior_std_and_drops_one_at_the_bound():
    assert meaningful_std(std=2.0, value=20.0, low=16.1, high=23.9) == 2.0
    assert math.isnan(meaningful_std(std=2.0, value=0.3, low=0.0, high=4.0))  # at w = 0
    assert math.isnan(meaningful_std(std=2.0, value=20.0, low=16.1, high=23.9,
                                     open_above=True))


@pytest.mark.parametrize('argv, fragment', [
    (['estimate', '--speeds', '35,40', '--friction', '0.06'], 'friction'),
    (['estimate', '--speeds', '35,-40', '--friction', '0.06,0.05'], '> 0'),
    (['design', '--n', '0'], '>= 1'),
    (['design', '--n', '13', '--grid', GRID_27], 'larger than'),
    (['design', '--n', '2', '--params', '/nonexistent/params.yaml'], 'params.yaml'),
    (['study', '--n', '2', '--speeds', '35', '--runs', '10'], '--speeds'),
    (['study', '--n', '0', '--runs', '10'], '>= 1'),
])
def test_bad_input_exits_2_with_one_line(capsys, argv, fragment):
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and 'Traceback' not in captured.err
    assert captured.out == ''


def test_bad_params_file_exits_2(capsys, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: x\n', encoding='utf-8')
    assert main(['estimate', '--speeds', '35,40', '--friction', '0.06,0.05', '--params',
                 str(bad)]) == 2
    assert 'bad.yaml' in capsys.readouterr().err


def test_levels_in_newton_metres_against_a_normalised_set_are_a_unit_mistake(capsys):
    """Levels 36x smaller than the set's friction that vary by 20 %: not 'equal', a unit."""
    from robot_wear_monitor.model.friction import friction
    params = load_parameter_set()
    speeds = [10.0, 30.0, 60.0, 100.0, 150.0]
    levels = [float(f) / 36.0 for f in friction(speeds, params.load_mean, 40.0, 0.0,
                                                params.model)]
    argv = ['estimate', '--speeds', ','.join(map(str, speeds)), '--friction',
            ','.join(f'{f:.6g}' for f in levels)]
    assert main(argv + ['--json']) == 2  # a user mistake; the JSON is still printed
    payload = json.loads(capsys.readouterr().out)
    assert payload['valid'] is False
    assert payload['likely_cause'].startswith('the unit of the levels')
    assert 'times smaller' in payload['likely_cause'] and 'saturated' not in payload[
        'likely_cause']
    assert main(argv) == 2
    assert 'likely cause: the unit of the levels' in capsys.readouterr().out
