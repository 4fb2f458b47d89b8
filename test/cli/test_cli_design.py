"""``robot-wear-monitor design``: the JSON object and the text output."""

import json

import pytest
from robot_wear_monitor.cli import main

GRID_27 = '2.1,8.7,15.3,21.9,28.5,35.1,41.7,82.2,133.5,184.7,236.2,287.1'


def _json(capsys, argv):
    assert main(argv) == 0
    out = capsys.readouterr().out
    return json.loads(out)


def test_design_json_is_exactly_n_speeds_cost(capsys):
    payload = _json(capsys, ['design', '--n', '3', '--grid', GRID_27, '--json'])
    assert set(payload) == {'n', 'speeds', 'cost'}
    assert payload['n'] == 3 and payload['speeds'] == [28.5, 41.7, 82.2]
    assert payload['cost'] == pytest.approx(22.60, rel=0.01)


def test_design_human_output_has_units(capsys):
    assert main(['design', '--n', '2']) == 0
    out = capsys.readouterr().out
    assert '[rad/s]' in out and '35.84, 40.84' in out and '26.0' in out


def test_design_json_out_writes_the_object_and_keeps_the_text(capsys, tmp_path):
    target = tmp_path / 'design.json'
    assert main(['design', '--n', '3', '--grid', GRID_27, '--json-out', str(target)]) == 0
    captured = capsys.readouterr()
    assert 'optimal grid design' in captured.out and captured.err == ''
    payload = json.loads(target.read_text())
    assert payload['speeds'] == [28.5, 41.7, 82.2] and payload['n'] == 3
