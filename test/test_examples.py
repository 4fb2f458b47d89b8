"""The shipped example tables: what the independent generator writes, and identify finds them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from wear_testing import make_examples

EXAMPLES = Path(__file__).resolve().parents[1] / 'examples'


def test_the_shipped_tables_are_what_the_generator_writes():
    files = {**make_examples.example_files(), **make_examples.arm_run_files()}
    shipped = {f'arm_runs/{p.name}' for p in (EXAMPLES / 'arm_runs').iterdir()}
    assert shipped == {name for name in files if name.startswith('arm_runs/')}
    for name, text in files.items():
        assert (EXAMPLES / name).read_text(encoding='utf-8') == text, (
            f'examples/{name} differs from test/wear_testing/make_examples.py: '
            'run PYTHONPATH=test python3 -m wear_testing.make_examples and commit')


def test_identify_on_the_examples_recovers_the_joint_and_its_wear(tmp_path, capsys):
    out = tmp_path / 'my_joint.yaml'
    assert main(['identify', str(EXAMPLES / 'baseline.csv'), '--wear-test',
                 str(EXAMPLES / 'wear_test.csv'), '--critical-experiment',
                 str(make_examples.CRITICAL), '--out', str(out), '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    nominal = report['nominal']['parameters']
    truth = {'f_c_load': make_examples.JOINT['F_ctl'], 'f_s_load': make_examples.JOINT['F_stl'],
             'phi_s_load': make_examples.JOINT['phi_stl']}
    for name, value in truth.items():
        fitted = nominal[name]
        assert abs(fitted['value'] - value) <= 3 * fitted['std_error'], (name, fitted, value)
    wear = report['wear']['parameters']
    assert abs(wear['f_s_wear']['value'] - make_examples.JOINT['F_sw']) <= 3 * wear[
        'f_s_wear']['std_error']
    assert out.is_file()


@pytest.mark.parametrize('name', ['baseline.csv', 'wear_test.csv'])
def test_the_tables_hold_the_columns_the_readme_names(name):
    header = (EXAMPLES / name).read_text(encoding='utf-8').splitlines()[0].split(',')
    assert {'speed', 'friction', 'temperature', 'load', 'experiment'} <= set(header)


def test_an_arm_run_is_too_slow_for_pass_pairs_and_gives_one_level_per_speed_in_bins(
        tmp_path, capsys):
    run = str(EXAMPLES / 'arm_runs' / 'run_11.csv')
    assert main(['segment', run, '--gear-ratio', '100']) == 2
    assert 'too slow for time-window levels: 2 Hz' in capsys.readouterr().err
    out = tmp_path / 'levels.csv'
    assert main(['segment', run, '--position-bins', '2', '--gear-ratio', '100', '--out',
                 str(out)]) == 0
    rows = [line.split(',') for line in out.read_text().splitlines()[1:]]
    speeds = sorted(float(r[0]) for r in rows)
    assert np.allclose(speeds, np.asarray(make_examples.ARM_SPEEDS_RAD_S) * 100, rtol=0.02)
    assert all(1.0 < float(r[1]) < 2.0 for r in rows)  # the friction current [A]
