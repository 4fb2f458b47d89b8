"""
The audit tries model (4) per direction and the level window's position (issue 35, part 3).

Data: the stand-in of a direct-drive two-joint arm's measured levels
(:mod:`wear_testing.direct_drive_arm`: per-direction model (4), a friction drift along the
window at high speed, a session offset between the run and its repeat) and one-way raw runs
with a known torque column.
"""

import gzip
import json

import numpy as np
import pytest
from robot_wear_monitor.audit.data import table_from_columns
from robot_wear_monitor.audit.noise import lack_of_fit
from robot_wear_monitor.audit.run import run_audit
from robot_wear_monitor.cli import main
from wear_testing.direct_drive_arm import arm_levels, levels_csv, TERMS


def _pure_error(table, joint):
    """Return the repeat-to-repeat (pure) error of one joint's levels [N m]."""
    sub = table.subset(table.text['joint'] == joint)
    lof = lack_of_fit(table=sub, residual=np.zeros(sub.n_rows), n_parameters=0,
                      variables=['speed', 'direction', 'joint'])
    return lof.pure_error


@pytest.mark.parametrize('seed', [0, 1])
def test_the_per_direction_model_brings_the_held_out_error_within_twice_the_pure_error(seed):
    table = table_from_columns(arm_levels(seed=seed))
    result = run_audit(table=table, model='speed', group='joint', estimate=False)
    assert result.effects[0].candidate == 'model (4) per direction', result.summary()
    assert result.effects[0].log10_p < -7  # the directions differ (p < 1e-7)
    # and it earned its place held out against one offset per direction
    tried = next(s for s in result.steps if s.get('tried') == 'model (4) per direction')
    assert tried['rms_cv_with_term'] < 0.99 * tried['held_out_of_simpler'][
        'offset per direction'], tried
    for joint in ('1', '2'):
        before, after = result.rms_by_group[joint]
        pure = _pure_error(table, joint)
        assert before > 2.0 * pure  # the common model (4) cannot reach it
        assert after <= 2.0 * pure, (joint, before, after, pure)
        for direction in ('positive', 'negative'):
            fitted = result.parameters_after[f'{joint} {direction}']
            f_c, _, _, _, f_v = TERMS[joint][direction]
            assert fitted['F_c'] == pytest.approx(f_c, abs=0.03)
            assert fitted['F_v'] == pytest.approx(f_v, abs=0.03)
    assert 'no candidate explains it' not in result.stop_reason
    assert not result.parameter_flags


def test_the_window_of_a_level_table_is_a_position_candidate(tmp_path, capsys):
    path = tmp_path / 'arm.csv'
    levels_csv(path, arm_levels(seed=3, drift={'1': 0.3, '2': 0.15}))
    assert main(['audit', str(path), '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert {'position_centre', 'position_span'} <= set(report['candidates'])
    assert not {'position_min_rad', 'position_max_rad'} & set(report['candidates'])
    named = [set(e['variables']) for e in report['effects']]
    assert named[0] == {'speed', 'direction'}
    assert {'speed', 'position_centre'} in named[1:], report['effects']


def test_symmetric_levels_keep_one_model_for_both_directions():
    columns = arm_levels(seed=4)
    magnitude = np.abs(columns['friction'])
    joint = columns['joint']
    speed = np.abs(columns['speed'])
    # the same friction both ways: the positive direction's terms plus the level error
    for j in TERMS:
        f_c, f_s, phi, alpha, f_v = TERMS[j]['positive']
        rows = joint == j
        truth = f_c + f_s * np.exp(-(speed[rows] / phi) ** alpha) + f_v * speed[rows]
        magnitude[rows] = truth + np.random.default_rng(5).normal(0, 0.003, rows.sum())
    columns['friction'] = np.sign(columns['speed']) * magnitude
    del columns['position_min_rad'], columns['position_max_rad']
    result = run_audit(table=table_from_columns(columns), model='speed', group='joint',
                       estimate=False)
    tried = [s for s in result.steps if s.get('tried') == 'model (4) per direction']
    assert all(s['decision'].startswith('rejected') for s in tried)
    assert not any(e.candidate == 'model (4) per direction' for e in result.effects)


def _one_way(folder, speed, direction, *, rng, offset=0.0):
    """Write a run that moves once across [-0.5, 0.5] rad one way, with a gravity column."""
    rate, n_still = 200.0, 100
    n_move = int(round(1.0 / speed * rate))
    q_move = np.linspace(-0.5, 0.5, n_move)[::direction]
    q = np.concatenate([np.full(n_still, q_move[0]), q_move, np.full(n_still, q_move[-1])])
    v = np.concatenate([np.zeros(n_still), np.full(n_move, direction * speed),
                        np.zeros(n_still)])
    magnitude = (1.2 + 0.4 * np.exp(-np.abs(v) / 0.2) + 0.8 * np.abs(v)
                 + (offset if direction < 0 else 0.0))
    gravity = 5.0 * np.cos(q)
    tau = gravity + np.sign(v) * magnitude + rng.normal(0, 0.01, q.size)
    label = f'{speed:g}'.replace('.', 'p')
    name = folder / f'joint2_{"fwd" if direction > 0 else "bwd"}_vel_{label}.csv.gz'
    with gzip.open(name, 'wt') as stream:
        stream.write('t_s,q_rad,dq_rad_s,tau_measured_Nm,gravity_Nm\n')
        for row in zip(np.arange(q.size) / rate, q, v + rng.normal(0, 1e-4, q.size), tau,
                       gravity):
            stream.write(','.join(repr(float(x)) for x in row) + '\n')
    return name


def test_one_way_runs_with_a_known_torque_fit_sanely_in_both_sign_conventions(tmp_path,
                                                                              capsys):
    """Forward and backward runs at other speeds, 0.3 N.m apart: no degenerate fit."""
    rng = np.random.default_rng(12)
    for v in (0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0):
        _one_way(tmp_path, v, 1, rng=rng)
    for v in (0.15, 0.25, 0.38, 0.52, 0.7, 0.9, 1.2):
        _one_way(tmp_path, v, -1, rng=rng, offset=0.3)
    assert main(['audit', str(tmp_path), '--known-torque', 'gravity_Nm', '--raw-sign',
                 '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    # the truth is one model (4) and an offset of 0.3 N.m in the negative direction: the
    # one-parameter offset predicts held-out levels better than model (4) per direction
    # (the step's own candidate may name it, e.g. as a Coulomb-like offset per direction)
    assert len(report['effects']) == 1
    assert report['effects'][0]['name'].startswith('offset per direction')
    tried = [s for s in report['steps'] if s.get('tried') == 'model (4) per direction']
    assert tried[0]['preferred'].startswith('offset per direction')
    assert tried[0]['decision'].startswith('rejected')
    held = tried[0]['held_out_of_simpler']
    assert held['offset per direction'] < 0.2 * tried[0]['rms_cv_with_term']
    fitted = report['parameters_after']['all']
    # F_c is the level of the direction the offset is measured from (1.2 or 1.2 + 0.3)
    assert min(abs(fitted['F_c'] - 1.2), abs(fitted['F_c'] - 1.5)) < 0.05, fitted
    assert fitted['F_v'] == pytest.approx(0.8, abs=0.08)
    assert fitted['F_s'] > 0
    assert not report['parameter_flags'] and not report['impossible_values']
    # without --raw-sign the data decide (issue 43): the torque is along the motion here, so
    # the same fit as with it; the sign is no longer forced the other way
    assert main(['audit', str(tmp_path), '--known-torque', 'gravity_Nm', '--json']) == 0
    same = json.loads(capsys.readouterr().out)
    assert same['parameters_after'] == report['parameters_after']
    assert not same['impossible_values']


def test_the_nominal_model_flags_a_negative_coulomb_level_in_text_and_json(tmp_path, capsys):
    """A torque with the other sign convention: every term negative, and the audit says so."""
    from wear_testing.effect_generator import levels
    columns = levels(seed=21, n_experiments=12)
    path = tmp_path / 'levels.csv'
    names = ['speed', 'friction', 'temperature', 'load', 'experiment']
    path.write_text(','.join(names) + '\n' + ''.join(
        ','.join(repr(float(-x if k == 'friction' else x)) for k, x in zip(names, row)) + '\n'
        for row in zip(*(columns[k] for k in names))))
    assert main(['audit', str(path), '--model', 'nominal', '--max-effects', '0']) == 0
    text = capsys.readouterr().out
    assert 'FLAG: f_c0 + f_c_load tau_l = -' in text
    assert 'a negative Coulomb level is no friction' in text
    assert main(['audit', str(path), '--model', 'nominal', '--max-effects', '0',
                 '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    coulomb = [v for v in report['impossible_values'] if v['meaning'] == 'Coulomb level']
    assert coulomb and all(v['value'] < 0 and v['where'].startswith('at load ')
                           for v in coulomb)
    assert any(v['meaning'] == 'viscous slope' for v in report['impossible_values'])
    assert len(report['parameter_flags']) == len(report['impossible_values'])
    # the same levels with their own sign: nothing impossible
    path.write_text(','.join(names) + '\n' + ''.join(
        ','.join(repr(float(x)) for x in row) + '\n'
        for row in zip(*(columns[k] for k in names))))
    assert main(['audit', str(path), '--model', 'nominal', '--max-effects', '0',
                 '--json']) == 0
    assert json.loads(capsys.readouterr().out)['impossible_values'] == []
