"""
The user's path on data that behave like a real arm: record -> identify -> estimate, untouched.

The levels come from :mod:`wear_testing.real_arm_logger` (independent of the package's model
code): motor current [A] as friction, viscous friction falling 2 %/degC, whole-degree
temperature readings over heat-up sessions, a payload on and off (a ``load`` column in A),
a position ripple, per-session offsets, a 2 Hz logger and eq. (3) over position bins, joint
speeds (gear ratio 100).  ``identify`` writes the sets; ``estimate`` reads them as written.
Targets (issue 35): T-hat within 3 degC of the measured temperature and in its order, a w-hat
for every group and none at the warning level (28) or above from heat alone, including the
coldest group; every comment of the set true, what identify prints equal to what the set
holds, the unit in the header, no path in the set.  The same on the packaged example joint.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
import re

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.model.params import load_parameter_set
from wear_testing import independent_robot as robot
from wear_testing import make_examples
from wear_testing import real_arm_logger as arm

EXAMPLES = Path(__file__).resolve().parents[2] / 'examples'
#: The monitoring sessions: (payload, seed); each gives 5 groups 12 minutes apart.
MONITORING = ((False, 11), (True, 12))


@pytest.fixture(scope='module')
def identified(tmp_path_factory):
    folder = tmp_path_factory.mktemp('real_arm')
    levels = arm.identification_levels(seed=0)
    table = folder / 'arm_levels.csv'
    arm.write_csv(table, {k: levels[k] for k in (
        'experiment', 'speed', 'friction', 'temperature', 'load', 'position_min_rad',
        'position_max_rad')})
    out = folder / 'arm.yaml'
    report = folder / 'report.json'
    args = ['identify', str(table), '--friction-unit', 'A', '--gear-ratio',
            str(arm.GEAR_RATIO), '--out', str(out)]
    assert main(args + ['--json-out', str(report)]) == 0
    return {'folder': folder, 'table': table, 'out': out, 'args': args,
            'report': json.loads(report.read_text())}


def _estimate(capsys, speeds_rad_s, friction, params_file):
    capsys.readouterr()
    assert main(['estimate', '--speeds', ','.join(f'{v:.6g}' for v in speeds_rad_s),
                 '--friction', ','.join(f'{f:.6g}' for f in friction), '--params',
                 str(params_file), '--json']) == 0
    return json.loads(capsys.readouterr().out)


def test_the_set_covers_the_robot_it_was_fitted_on(identified):
    params = load_parameter_set(identified['out'])
    # motor side, from the levels: 0.35-1.05 rad/s joint x 100, steps of 0.0583 x 100
    assert params.speed_min_rad_s == pytest.approx(35.0, rel=1e-3)
    assert params.speed_max_rad_s == pytest.approx(105.0, rel=1e-3)
    assert params.speed_separation_rad_s == pytest.approx(5.833, rel=1e-3)
    assert params.friction_unit == 'A'
    configurations = identified['report']['load_configurations']
    assert len(configurations) == 2  # the payload off (0.7-1.1 A) and on (3.2-5.2 A)
    assert configurations[0]['high'] < 1.2 < 3.0 < configurations[1]['low']
    sets = identified['report']['configuration_sets']
    for one, cluster in zip(sets, configurations):
        loaded = load_parameter_set(one['out'])
        assert loaded.load_mean == pytest.approx(cluster['mean'], rel=1e-5)
        assert loaded.load_std == pytest.approx(cluster['std'], rel=1e-5)
        assert loaded.model == params.model  # one joint: the same model and wear model
    # the wear model is the reference's scaled to amperes, not its normalised numbers
    scaling = identified['report']['wear_model_scaling']
    assert 5 < scaling['amplitude'] < 50
    assert params.model.f_s_wear == pytest.approx(9.02e-4 * scaling['amplitude'], rel=1e-4)


def test_every_comment_is_true_and_printed_equals_written(identified, capsys):
    text = identified['out'].read_text()
    params = load_parameter_set(identified['out'])
    report = identified['report']
    assert '# Friction (and its load) in A;' in text and 'Torques are normalised' not in text
    assert str(identified['folder']) not in text and not re.search(r'(^|\s)/\w', text)
    assert 'abb_irb6620_joint2' in text  # the reference by its set name
    for name, fitted in report['nominal']['parameters'].items():
        line = next(x for x in text.splitlines() if x.strip().startswith(name + ':'))
        value = float(line.split(':')[1].split('#')[0])
        assert value == pytest.approx(getattr(params.model, name), rel=1e-9)
        same = value == pytest.approx(fitted['value'], rel=1e-5)
        if fitted['std_error'] is not None and same:
            assert f"identified, +- {fitted['std_error']:.2e}" in line, line
        else:
            assert 'from abb_irb6620_joint2' in line or 'undetermined' in line, line
    for name in ('f_s_wear', 'f_v_wear', 'phi_s_wear'):
        assert 'scaled from abb_irb6620_joint2' in next(
            x for x in text.splitlines() if x.strip().startswith(name + ':'))
    assert 'Assumption: the wear model (7) of abb_irb6620_joint2 scaled' in text
    # what identify prints is what the set holds
    capsys.readouterr()
    assert main(identified['args'][:-1] + [str(identified['folder'] / 'again.yaml')]) == 0
    printed = capsys.readouterr().out
    for name in report['set_values']:
        match = re.search(rf'^  {name}\s+(\S+) \[', printed, re.MULTILINE)
        assert match, name
        assert float(match.group(1)) == pytest.approx(getattr(params.model, name), rel=1e-4)
    assert f'mean {params.load_mean:.4g}, std {params.load_std:.4g}' in printed


@pytest.mark.parametrize('payload, seed', MONITORING)
def test_heat_is_not_read_as_wear_on_the_robots_own_levels(identified, capsys, payload, seed):
    sets = identified['report']['configuration_sets']
    params_file = sets[1 if payload else 0]['out']
    session = arm.Session(payload=payload, room_degc=22.0 + seed % 3)
    groups = arm.monitoring_groups(session, seed=seed, every_s=720.0)
    estimates = [_estimate(capsys, g['speeds'] * arm.GEAR_RATIO, g['friction'], params_file)
                 for g in groups]
    measured = [g['temperature'] for g in groups]
    t_hat = [e['temperature'] for e in estimates]
    w_hat = [e['wear'] for e in estimates]
    assert all(e['valid'] for e in estimates), [e['invalid_reasons'] for e in estimates]
    assert np.all(np.abs(np.subtract(t_hat, measured)) <= 3.0), (measured, t_hat)
    assert np.all(np.diff(t_hat) > 0), (measured, t_hat)  # in the measured order
    assert all(math.isfinite(w) for w in w_hat)
    assert max(w_hat) < 28.0 and w_hat[0] < 28.0, w_hat  # the coldest group too


def test_the_same_path_on_the_packaged_example_joint(tmp_path, capsys):
    out = tmp_path / 'example.yaml'
    assert main(['identify', str(EXAMPLES / 'baseline.csv'), '--out', str(out)]) == 0
    rng = np.random.default_rng(5)
    speeds = np.asarray(make_examples.GRID)
    temperatures = (32.0, 35.0, 38.0, 41.0)  # above, T is weakly determined (docs/identify.md)
    t_hat, w_hat = [], []
    for t in temperatures:
        friction = robot.friction_model(speeds, 0.5, t, 0.0, make_examples.JOINT) + rng.normal(
            0.0, make_examples.SIGMA, speeds.size)
        estimate = _estimate(capsys, speeds, friction, out)
        assert estimate['valid'], estimate['invalid_reasons']
        t_hat.append(estimate['temperature'])
        w_hat.append(estimate['wear'])
    assert np.all(np.abs(np.subtract(t_hat, temperatures)) <= 3.0), t_hat
    assert np.all(np.diff(t_hat) > 0)
    assert max(w_hat) < 28.0, w_hat
