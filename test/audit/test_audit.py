"""
Audit on undeclared effects: synthetic friction levels from model (5) plus a hidden effect.

Each experiment runs 8 speeds twice at one operating point (temperature, load and the
undeclared variables are constant within an experiment, as in the paper's procedure), so the
replicate scatter gives a model-free noise floor.  Columns ``pressure`` and ``shift`` never
matter.  The tool is told none of this.
"""

import json
import math

import numpy as np
import pytest
from robot_wear_monitor.audit.data import load_audit_data, read_level_table, table_from_columns
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.audit.run import run_audit
from robot_wear_monitor.cli import main
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import load_parameter_set
from wear_testing.effect_generator import model_friction

PARAMS = load_parameter_set()
SPEEDS = np.array([2.1, 8.7, 15.3, 28.5, 41.7, 82.2, 133.5, 236.2])
SIGMA = 4.23e-3  # model error of (5), Sec. II-B1
IRRELEVANT = {'pressure', 'shift'}


def make_columns(effect=None, *, seed=0, n_experiments=40, repeats=2, wear=False):
    rng = np.random.default_rng(seed)
    e = np.repeat(np.arange(n_experiments), SPEEDS.size * repeats)
    per_experiment = {
        'temperature': rng.uniform(30, 50, n_experiments),
        'load': rng.uniform(0.1, 0.9, n_experiments),
        'humidity': rng.uniform(20, 80, n_experiments),
        'position': rng.uniform(-1.5, 1.5, n_experiments),
        'pressure': rng.normal(1000, 10, n_experiments),
        'shift': rng.uniform(0, 100, n_experiments),
    }
    if wear:
        per_experiment['wear'] = np.linspace(0, 60, n_experiments)
    columns = {k: v[e] for k, v in per_experiment.items()}
    columns['speed'] = np.tile(np.repeat(SPEEDS, repeats), n_experiments)
    columns['experiment'] = e
    clean = model_friction(columns, PARAMS)
    columns['friction'] = clean + rng.normal(0, SIGMA, clean.size)
    if effect is not None:
        columns['friction'] = columns['friction'] + effect(columns)
    return columns


def audit(effect=None, *, seed=0, **kwargs):
    table = table_from_columns(make_columns(effect, seed=seed), model='nominal')
    return run_audit(table=table, model='nominal', estimate=False, **kwargs)


def assert_at_noise_floor(result):
    assert result.rms_after <= 1.15 * result.noise_floor
    assert result.rms_after <= 1.15 * SIGMA
    assert abs(result.noise_floor / SIGMA - 1) < 0.15
    assert result.rms_after <= result.rms_before


# ----------------------------------------------------------------------- undeclared effects

def test_smooth_effect_on_an_undeclared_variable_is_named_and_removed():
    result = audit(lambda c: 0.012 * np.tanh((c['humidity'] - 50) / 15), seed=2)
    assert [e.variables for e in result.effects] == [('humidity',)]
    assert result.effects[0].shape == 'smooth'
    assert result.rms_before > 2 * SIGMA
    assert_at_noise_floor(result)


def test_linear_effect_is_named_as_a_coulomb_like_offset():
    result = audit(lambda c: 2e-4 * (c['shift'] - 50), seed=3)
    assert len(result.effects) == 1
    assert result.effects[0].variables == ('shift',)
    assert result.effects[0].shape == 'linear'
    assert_at_noise_floor(result)


def test_periodic_effect_in_position_is_named_with_its_period():
    result = audit(lambda c: 0.01 * np.sin(2 * np.pi * c['position'] / 0.7), seed=2)
    assert [e.variables for e in result.effects] == [('position',)]
    assert result.effects[0].shape == 'periodic'
    assert result.effects[0].info['period'] == pytest.approx(0.7, rel=0.03)
    assert_at_noise_floor(result)


def test_low_speed_interaction_with_a_variable_is_named_with_speed():
    def effect(c):
        return 0.02 * (c['humidity'] - 50) / 30 * np.exp(-(c['speed'] / 15) ** 1.36)
    result = audit(effect, seed=1)
    assert len(result.effects) == 1
    assert set(result.effects[0].variables) == {'speed', 'humidity'}
    assert 'interaction' in result.effects[0].shape
    assert_at_noise_floor(result)


def test_interaction_of_two_undeclared_variables_is_named():
    result = audit(lambda c: 0.015 * (c['humidity'] - 50) / 30 * c['position'], seed=2)
    assert len(result.effects) == 1
    assert set(result.effects[0].variables) == {'humidity', 'position'}
    assert_at_noise_floor(result)


def test_two_effects_are_found_one_after_the_other():
    def effect(c):
        return (0.01 * np.sin(2 * np.pi * c['position'] / 0.9)
                + 0.012 * np.tanh((c['humidity'] - 50) / 15))
    result = audit(effect, seed=4)
    named = sorted(v for e in result.effects for v in e.variables)
    assert named == ['humidity', 'position']
    assert not IRRELEVANT & set(named)
    assert_at_noise_floor(result)
    gains = [e.rms_gain for e in result.effects]
    assert all(g > 0 for g in gains)


@pytest.mark.parametrize('seed', range(6))
def test_clean_data_adds_nothing(seed):
    result = audit(seed=seed)
    assert result.effects == ()
    assert result.rms_after == result.rms_before
    assert_at_noise_floor(result)


def test_speed_model_per_group_finds_a_text_column_offset():
    rng = np.random.default_rng(5)
    rows = []
    # friction in the domain of model (4) (F_s >= 0: the audit fits it there, as identify)
    for joint, (fc, fs, phi, fv) in {'a': (0.3, 0.1, 0.2, 0.05), 'b': (0.1, 0.05, 0.4, 0.2),
                                     'c': (0.8, 0.15, 0.3, 0.1)}.items():
        for run, speed in enumerate(np.linspace(0.1, 1.0, 10)):
            for pose in ('up', 'down'):
                for sweep in range(3):  # an experiment is one sweep of all speeds
                    value = fc + fs * math.exp(-(speed / phi) ** 1.5) + fv * speed
                    value += 0.04 * (pose == 'down') + rng.normal(0, 0.005)
                    rows.append((speed, value, joint, pose, f'{joint}-{pose}-{sweep}',
                                 rng.uniform(0, 60)))
    columns = dict(zip(('speed', 'friction', 'joint', 'pose', 'experiment', 'time'),
                       map(list, zip(*rows))))
    table = table_from_columns(columns)
    assert set(table.text) == {'joint', 'pose', 'experiment'}
    result = run_audit(table=table, model='speed', group='joint')
    assert [e.variables for e in result.effects] == [('pose',)]
    assert result.effects[0].shape == 'offset per category'
    assert result.rms_after <= 1.15 * result.noise_floor


def test_complete_model_reports_what_the_effect_changes_in_t_and_w():
    columns = make_columns(lambda c: 0.012 * np.tanh((c['humidity'] - 50) / 15), seed=6,
                           n_experiments=16, wear=True)
    table = table_from_columns(columns, model='complete')
    result = run_audit(table=table, model='complete', max_effects=1)
    assert [e.variables for e in result.effects] == [('humidity',)]
    changes = result.estimate_changes
    assert changes['applies'] is True
    assert changes['n_experiments'] == 16
    assert changes['temperature_rms_error_after_degc'] < \
        changes['temperature_rms_error_before_degc']
    assert changes['wear_rms_error_after'] < changes['wear_rms_error_before']
    json.dumps(result.to_dict(), allow_nan=False)


# ----------------------------------------------------------------------- report and inputs

def test_json_report_has_the_documented_fields_and_is_valid_json():
    result = audit(lambda c: 2e-4 * (c['shift'] - 50), seed=3)
    report = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    for key in ('rms_before', 'rms_after', 'noise_floor', 'effects'):
        assert key in report
    effect = report['effects'][0]
    assert effect['variables'] == ['shift']
    assert effect['rms_gain'] > 0
    assert {'name', 'variables', 'rms_gain'} <= set(effect)


def write_csv(path, columns):
    names = list(columns)
    lines = [','.join(names)]
    for row in zip(*(columns[n] for n in names)):
        lines.append(','.join(str(v) for v in row))
    path.write_text('\n'.join(lines) + '\n', encoding='utf-8')
    return path


def test_cli_audit_writes_json_and_figures(tmp_path, capsys):
    columns = make_columns(lambda c: 0.01 * np.sin(2 * np.pi * c['position'] / 0.7), seed=2,
                           n_experiments=24)
    csv = write_csv(tmp_path / 'levels.csv', columns)
    report = tmp_path / 'report.json'
    code = main(['audit', str(csv), '--model', 'nominal', '--json-out', str(report),
                 '--plots', str(tmp_path / 'fig')])
    assert code == 0
    assert 'position' in capsys.readouterr().out
    data = json.loads(report.read_text())
    assert data['effects'][0]['variables'] == ['position']
    assert data['rms_after'] < data['rms_before']
    for name in ('audit_residuals.png', 'audit_errors.png'):
        assert (tmp_path / 'fig' / name).stat().st_size > 1000


def test_cli_json_to_stdout_on_clean_data_has_no_effects(tmp_path, capsys):
    csv = write_csv(tmp_path / 'levels.csv', make_columns(seed=7, n_experiments=20))
    assert main(['audit', str(csv), '--model', 'nominal', '--json']) == 0
    data = json.loads(capsys.readouterr().out)
    assert data['effects'] == []
    assert data['rms_after'] == data['rms_before']


@pytest.mark.parametrize('change, message', [
    (lambda c: c.pop('load'), "'load'"),
    (lambda c: c['friction'].__setitem__(3, np.nan), 'NaN'),
    (lambda c: [c[k].__setitem__(slice(None), []) for k in ()] or c.clear(), 'empty'),
])
def test_cli_user_mistakes_exit_2_with_one_line(tmp_path, capsys, change, message):
    columns = make_columns(seed=0, n_experiments=4)
    change(columns)
    path = tmp_path / 'bad.csv'
    if columns:
        write_csv(path, columns)
    else:
        path.write_text('', encoding='utf-8')
    assert main(['audit', str(path), '--model', 'nominal']) == 2
    error = capsys.readouterr().err
    assert message in error
    assert len(error.strip().splitlines()) == 1


def test_cli_unknown_model_and_missing_file_exit_2(tmp_path, capsys):
    csv = write_csv(tmp_path / 'levels.csv', make_columns(seed=0, n_experiments=4))
    assert main(['audit', str(csv), '--model', 'fancy']) == 2
    assert 'fancy' in capsys.readouterr().err
    assert main(['audit', str(tmp_path / 'none.csv')]) == 2
    assert 'no such file' in capsys.readouterr().err


def test_table_checks():
    with pytest.raises(InputError, match='no rows'):
        table_from_columns({'speed': [], 'friction': []})
    with pytest.raises(InputError, match='standstill row'):
        table_from_columns({'speed': [1.0, 0.0], 'friction': [0.1, 0.1]})
    signed = table_from_columns({'speed': [1.0, -1.0], 'friction': [0.1, -0.12]})
    assert list(signed.numeric['speed']) == [1.0, 1.0]  # signed speeds: a direction group
    assert list(signed.numeric['friction']) == [0.1, 0.12]
    assert list(signed.text['direction']) == ['positive', 'negative']
    with pytest.raises(InputError, match='unknown model'):
        table_from_columns({'speed': [1.0], 'friction': [0.1]}, model='x')
    table = table_from_columns({'speed': [1, 2], 'friction': [0.1, 0.2], 'pose': ['a', 'b']})
    assert isinstance(table, AuditTable) and table.n_rows == 2 and 'pose' in table.text
    with pytest.raises(InputError, match='distinct speeds'):
        run_audit(table=table, model='speed')


def test_read_level_table_and_load_audit_data_agree(tmp_path):
    csv = write_csv(tmp_path / 'levels.csv', make_columns(seed=0, n_experiments=3))
    a = read_level_table(csv, model='nominal')
    b = load_audit_data(csv, model='nominal')
    assert a.n_rows == b.n_rows == 48
    np.testing.assert_allclose(a.numeric['friction'], b.numeric['friction'])
