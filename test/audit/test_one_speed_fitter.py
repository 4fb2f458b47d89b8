"""
One fitter of the speed model (4) for ``identify --speed-only`` and ``audit`` (issue 43).

On the three shared measured data sets (KUKA iiwa, Kinova Gen3, the screw drives), both verbs
give the same parameters (F_c and F_v within 2 %), the same held-out error and the same verdict
on the directions, with every amplitude in its physical domain (>= 0) and Stribeck terms the
data do not support dropped by BIC in both.  The measured data are expected to disagree with
the model; the tests check that the two verbs agree about it.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from robot_wear_monitor.audit.data import load_audit_data, table_from_columns
from robot_wear_monitor.audit.run import run_audit
from robot_wear_monitor.audit.speed_model import speed_only_parameter_set
from robot_wear_monitor.cli import main
from robot_wear_monitor.model.params import load_parameter_set

#: Kinova Gen3 joint 7: torque constant [N.m/A] (the authors' configuration).
KT = 7.6


def _screw(external_data_dir, name):
    path = external_data_dir / 'rvimlab_tro2021_screw_drives' / 'levels' / f'{name}.csv'
    if not path.exists():
        pytest.skip(f'measured data not available: {path}')
    return load_audit_data(str(path), model='speed')


def _kuka(kuka_dir, joint):
    table = load_audit_data(str(kuka_dir), model='speed')
    return table.subset(table.text['joint'] == joint)


def _kinova(external_data_dir):
    """Levels of the one-way Kinova runs: K_t i - tau_sensor over three windows of each run."""
    folder = external_data_dir / 'kinova_gen3_hbrs_sdp' / 'velocity_runs'
    files = sorted(folder.glob('velocity_*readings.csv'))
    if not files:
        pytest.skip(f'measured data not available: {folder}')
    columns: dict[str, list] = {'speed': [], 'friction': [], 'experiment': []}
    for file in files:
        data = np.loadtxt(file)
        steady = data[data.shape[0] // 2:]  # the second half: past the start transient
        for part in np.array_split(steady, 3):
            columns['speed'].append(float(part[:, 2].mean()))
            columns['friction'].append(float((KT * part[:, 5] - part[:, 3]).mean()))
            columns['experiment'].append(file.stem)
    return table_from_columns(columns, source='kinova_gen3_joint7')


TABLES = {
    'screw drive 1 (eq. 3)': lambda e, k: _screw(e, 'levels_drive1_eq3'),
    'screw drive 2 (eq. 3, no Stribeck dip)': lambda e, k: _screw(e, 'levels_drive2_eq3'),
    'screw drive 3 (eq. 3)': lambda e, k: _screw(e, 'levels_drive3_eq3'),
    'screw drive 1 (signed)': lambda e, k: _screw(e, 'levels_drive1_signed'),
    'screw drive 3 (signed)': lambda e, k: _screw(e, 'levels_drive3_signed'),
    'KUKA iiwa joint 1': lambda e, k: _kuka(k, 'joint1'),
    'KUKA iiwa joint 6': lambda e, k: _kuka(k, 'joint6'),
    'Kinova Gen3 joint 7': lambda e, k: _kinova(e),
}


@pytest.mark.parametrize('name', list(TABLES))
def test_identify_and_audit_fit_model_4_alike(name, external_data_dir, kuka_dir):
    table = TABLES[name](external_data_dir, kuka_dir)
    identified = speed_only_parameter_set(table=table, from_params=load_parameter_set(),
                                          name='lab', friction_unit='N.m')
    audited = run_audit(table=table, model='speed', estimate=False)
    fit = {k: p.value for k, p in identified.fit.groups['all'].items()}
    before = audited.parameters_before['all']
    for key in ('F_c', 'F_v'):
        assert before[key] == pytest.approx(fit[key], rel=0.02, abs=1e-12), (name, key)
    for key in ('F_c', 'F_s', 'F_v'):  # the physical domain, in both
        assert fit[key] >= 0 and before[key] >= 0, (name, key)
    assert audited.rms_before == pytest.approx(identified.fit.held_out_rms, rel=1e-6)
    # a Stribeck term the data do not support is dropped by both (BIC)
    dropped = bool(identified.fit.dropped)
    assert dropped == bool(audited.stribeck_dropped), name
    if dropped:
        assert fit['F_s'] == before['F_s'] == 0
    # the same verdict on the directions (identify's candidates: none, an offset, per direction)
    tried = [s for s in audited.steps if s.get('tried') == 'model (4) per direction']
    if identified.direction_test is None:
        assert not tried
    else:
        assert tried[0]['direction_verdict'] == identified.direction_test.preferred, name


def test_the_screw_drive_without_a_dip_drops_its_stribeck_term(external_data_dir):
    table = _screw(external_data_dir, 'levels_drive2_eq3')
    identified = speed_only_parameter_set(table=table, from_params=load_parameter_set(),
                                          name='lab', friction_unit='N.m')
    assert identified.fit.dropped == ('all',)
    text = identified.summary()
    assert re.search(r'^    F_s\s+0 \[N\.m\]  left out: the data do not support its Stribeck '
                     r'term \(BIC\)$', text, re.MULTILINE), text


def test_the_printed_lines_are_what_the_json_and_the_audit_say(external_data_dir, tmp_path,
                                                               capsys):
    path = (external_data_dir / 'rvimlab_tro2021_screw_drives' / 'levels'
            / 'levels_drive1_eq3.csv')
    if not path.exists():
        pytest.skip(f'measured data not available: {path}')
    out = tmp_path / 'drive1.yaml'
    args = ['identify', '--speed-only', str(path), '--out', str(out), '--friction-unit', 'N.m']
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert main(args + ['--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert main(['audit', str(path), '--friction-unit', 'N.m', '--json']) == 0
    audit = json.loads(capsys.readouterr().out)
    assert audit['friction_unit'] == 'N.m'
    for name, fitted in report['fit']['groups']['all'].items():
        match = re.search(rf'^    {name}\s+(\S+) \[[^]]+\]  identified, \+- (\S+)', printed,
                          re.MULTILINE)
        assert match, (name, printed)
        assert float(match.group(1)) == pytest.approx(fitted['value'], rel=1e-4)
        assert float(match.group(2)) == pytest.approx(fitted['std_error'], rel=0.01)
        assert float(match.group(1)) == pytest.approx(
            audit['parameters_before']['all'][name], rel=1e-4)
    # the sigma the set holds is printed, with where it comes from, and is the JSON's
    params = load_parameter_set(out)
    assert f'sigma of (9b) = {params.sigma:.3e} N.m' in printed
    assert report['sigma'] == pytest.approx(params.sigma)
    assert params.sigma == pytest.approx(report['fit']['held_out_error']['std'])


def test_a_clamped_value_is_printed_on_its_bound(tmp_path, capsys):
    # friction falling with speed at the high end: F_v is held at 0 and said so
    speed = np.geomspace(0.5, 20.0, 12)
    friction = 1.0 + 0.3 * np.exp(-speed / 2.0) - 0.004 * speed
    friction += np.random.default_rng(3).normal(0.0, 0.002, speed.size)
    table = tmp_path / 'falling.csv'
    table.write_text('speed,friction\n' + ''.join(f'{float(v)!r},{float(f)!r}\n'
                                                  for v, f in zip(speed, friction)))
    assert main(['identify', '--speed-only', str(table), '--out', str(tmp_path / 'f.yaml'),
                 '--friction-unit', 'N.m']) == 0
    printed = capsys.readouterr().out
    assert re.search(r'^    F_v\s+0 \[N\.m/\(rad/s\)\]  identified, .*on its bound \(F_v >= 0\)',
                     printed, re.MULTILINE), printed
    assert 'warning: all F_v = 0 is on its bound (F_v >= 0)' in printed


def test_plots_with_speed_only_are_refused_naming_the_audit(tmp_path, capsys):
    table = tmp_path / 'levels.csv'
    speed = np.geomspace(0.5, 20.0, 8)
    table.write_text('speed,friction\n' + ''.join(
        f'{float(v)!r},{float(1.0 + 0.05 * v)!r}\n' for v in speed))
    assert main(['identify', '--speed-only', str(table), '--out', str(tmp_path / 'x.yaml'),
                 '--plots', str(tmp_path / 'figures')]) == 2
    assert 'audit BASELINE --plots DIR' in capsys.readouterr().err
    assert not (tmp_path / 'x.yaml').exists() and not (tmp_path / 'figures').exists()
