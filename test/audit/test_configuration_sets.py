"""
A set per configuration (issue 43): ``identify --configuration-column payload``.

The levels come from :mod:`wear_testing.real_arm_logger` with the payload's load columns
overlapping (0.7-2.2 A without, about 2.0-5.0 A with: the other joints in other poses), so no gap
in the load column splits them; the ``payload`` column names the configuration, as a lab's log
does.  The unloaded configuration's set must read the unloaded arm within 3 degC, in order, with
w-hat under the warning level, where the pooled load prior reads it hot.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from robot_wear_monitor.audit.configurations import configuration_label
from robot_wear_monitor.cli import main
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import load_parameter_set
from wear_testing import real_arm_logger as arm

#: The warning level of w-hat (the packaged set's, which the borrowed wear model keeps).
WARNING_W = 28.0


@pytest.fixture(scope='module')
def identified(tmp_path_factory):
    folder = tmp_path_factory.mktemp('payloads')
    levels = arm.identification_levels(seed=0, sessions=arm.OVERLAPPING_SESSIONS)
    table = folder / 'arm_levels.csv'
    arm.write_csv(table, {k: levels[k] for k in (
        'experiment', 'speed', 'friction', 'temperature', 'load', 'payload')})
    out = folder / 'arm.yaml'
    report = folder / 'report.json'
    assert main(['identify', str(table), '--friction-unit', 'A', '--gear-ratio',
                 str(arm.GEAR_RATIO), '--name', 'arm', '--out', str(out),
                 '--configuration-column', 'payload', '--json-out', str(report)]) == 0
    return {'folder': folder, 'out': out, 'report': json.loads(report.read_text()),
            'levels': levels}


def _estimates(capsys, params_file, groups):
    out = []
    for g in groups:
        capsys.readouterr()
        assert main(['estimate', '--speeds', ','.join(
            f'{v * arm.GEAR_RATIO:.6g}' for v in g['speeds']), '--friction',
            ','.join(f'{f:.6g}' for f in g['friction']), '--params', str(params_file),
            '--json']) == 0
        out.append(json.loads(capsys.readouterr().out))
    return out


def test_one_set_per_payload_value_with_its_load_prior_and_operating_range(identified):
    levels = identified['levels']
    configurations = identified['report']['load_configurations']
    assert [c['value'] for c in configurations] == ['0', '1']
    # the load columns overlap: no gap would have split them
    assert configurations[0]['high'] > configurations[1]['low']
    pooled = load_parameter_set(identified['out'])
    for entry, value in zip(identified['report']['configuration_sets'], (0, 1)):
        assert entry['out'] == str(identified['folder'] / f'arm_{value}.yaml')
        params = load_parameter_set(entry['out'])
        assert params.name == f'arm_{value}'
        rows = levels['payload'] == value
        assert params.load_mean == pytest.approx(levels['load'][rows].mean(), rel=1e-4)
        assert params.load_std == pytest.approx(levels['load'][rows].std(ddof=1), rel=1e-3)
        assert params.speed_min_rad_s == pytest.approx(
            levels['speed'][rows].min() * arm.GEAR_RATIO, rel=1e-3)
        assert params.model == pooled.model  # the model is identified on all levels
    assert pooled.load_mean == pytest.approx(levels['load'].mean(), rel=1e-4)


def test_the_pooled_header_says_whom_it_is_for_and_what_it_costs(identified):
    text = identified['out'].read_text()
    assert 'for a monitor that does not know its configuration' in text
    cost = identified['report']['configuration_cost']
    assert cost['experiments'] >= 10
    assert f"{cost['pooled']['rms']:.2g} degC rms" in text
    # on these levels the own configuration's prior reads the temperature better
    assert cost['configuration']['rms'] < cost['pooled']['rms']
    own = load_parameter_set(identified['report']['configuration_sets'][0]['out'])
    assert 'for a monitor that does not know' not in (
        identified['folder'] / 'arm_0.yaml').read_text()
    assert own.name == 'arm_0'


def test_the_unloaded_set_reads_the_unloaded_arm_where_the_pooled_prior_reads_it_hot(
        identified, capsys):
    # the unloaded arm in the middle of its configuration's poses (identified at gravity
    # scales 1, 1.5 and 1.96: the load 1.3 A against the configuration's mean 1.49 A)
    session = arm.Session(payload=False, room_degc=22.0 + 11 % 3, gravity_scale=1.3)
    groups = arm.monitoring_groups(session, seed=11, every_s=720.0)
    measured = np.array([g['temperature'] for g in groups])
    own = _estimates(capsys, identified['report']['configuration_sets'][0]['out'], groups)
    pooled = _estimates(capsys, identified['out'], groups)
    t_own = np.array([e['temperature'] for e in own])
    t_pooled = np.array([e['temperature'] for e in pooled])
    assert all(e['valid'] for e in own), [e['invalid_reasons'] for e in own]
    assert np.all(np.abs(t_own - measured) <= 3.0), (measured, t_own)
    assert np.all(np.diff(t_own) > 0), (measured, t_own)
    assert max(e['wear'] for e in own) < WARNING_W, [e['wear'] for e in own]
    # the pooled prior (a mean load between the payloads, 2.5 A) reads it worse, mostly hot
    assert np.max(np.abs(t_pooled - measured)) > np.max(np.abs(t_own - measured)) + 1.0, (
        measured, t_pooled, t_own)
    assert np.mean(t_pooled - measured) > 0.0


def test_labels_and_refusals(tmp_path, capsys):
    assert configuration_label('5 kg') == '5kg'
    assert configuration_label('tool-A_1') == 'tool-A_1'
    with pytest.raises(InputError, match='no letter'):
        configuration_label(' / ')
    table = tmp_path / 'one.csv'
    arm.write_csv(table, {'speed': [1, 2, 3], 'friction': [1, 1, 1], 'temperature': [1, 2, 3],
                          'load': [1, 1, 1], 'payload': [0, 0, 0]})
    capsys.readouterr()
    assert main(['identify', str(table), '--out', str(tmp_path / 'x.yaml'),
                 '--configuration-column', 'nope']) == 2
    assert 'no such column' in capsys.readouterr().err
