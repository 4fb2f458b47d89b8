"""
Raw runs as labs write them, read one way by segment, identify and audit (issue 43).

A simulated joint with a known friction F_c + F_v |v| (no Stribeck dip) is written as a folder
of plain-named ``.csv`` runs, torque positive along the motion, with a speed signal quantised
at 1 rpm and noisy by 3 %: the truth is F_c and the curve.  Then the three shared measured data
sets (skipped with the reason when ``../shared`` is absent): the screw drives against the
authors' eq. (3) table, the KUKA iiwa runs (torque recorded against the motion) and the Kinova
Gen3 runs (one direction only).
"""

import csv
import json

import numpy as np
import pytest
from robot_wear_monitor.audit.friction_sign import speed_model_friction
from robot_wear_monitor.cli import main
from wear_testing.paths import EXTERNAL_DIR, require_path

F_C, F_V = 0.02, 1.0e-3  # N.m, N.m/(rad/s): the simulated joint's friction
RPM = np.pi / 30.0  # one quantum of the speed signal [rad/s]
SPEEDS = (2.0, 3.5, 5.0, 7.0, 9.0, 12.0, 15.0, 19.0)  # motor rad/s
NAMES = ('first try.csv', 'run-b.csv', 'slow_3.csv', 'Mon 5.csv', 'x7.csv', 'late.csv',
         'again (2).csv', 'last.csv')


def _truth(speed):
    return F_C + F_V * np.abs(speed)


def _lab_run(path, speed, *, rng, sign=1.0, rate=100.0, plateau_s=3.0, still_s=0.5):
    """Write a run back and forth at ``speed`` [rad/s]: quantised speed, torque along motion."""
    ramp = np.linspace(0.0, speed, int(0.2 * rate), endpoint=False)
    profile = np.concatenate([ramp, np.full(int(plateau_s * rate), speed), ramp[::-1]])
    still = np.zeros(int(still_s * rate))
    v = np.concatenate([still, profile, still, -profile, still, profile, still, -profile,
                        still])
    t = np.arange(v.size) / rate
    q = np.cumsum(v) / rate
    measured = np.round((v + rng.normal(0.0, 0.03 * speed, v.size)) / RPM) * RPM
    measured[v == 0] = 0.0
    tau = (0.01 + 0.005 * np.cos(q) + np.sign(v) * _truth(v) * (v != 0)
           + rng.normal(0.0, 0.003, v.size))
    with open(path, 'w') as stream:
        stream.write('t_s,q_rad,dq_rad_s,tau_measured_Nm\n')
        for row in zip(t, q, measured, sign * tau):
            stream.write(','.join(f'{x:.6g}' for x in row) + '\n')
    return path


def _lab_folder(folder, *, sign=1.0, seed=1):
    folder.mkdir()
    rng = np.random.default_rng(seed)
    for name, speed in zip(NAMES, SPEEDS):
        _lab_run(folder / name, speed, rng=rng, sign=sign)
    return folder


def _rows(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


def test_plain_named_runs_are_one_joint_and_give_the_true_coulomb_level(tmp_path, capsys):
    folder = _lab_folder(tmp_path / 'runs')
    # a run that gives nothing: a 0.25 s plateau at 2 rad/s, resting the rest of the time
    v = np.concatenate([np.zeros(100), np.full(25, 2.0), np.zeros(100)])
    with open(folder / 'short.csv', 'w') as stream:
        stream.write('t_s,q_rad,dq_rad_s,tau_measured_Nm\n')
        for i, x in enumerate(v):
            stream.write(f'{i / 100:.6g},{np.sum(v[:i]) / 100:.6g},{x:.6g},{0.03 * x:.6g}\n')
    out, levels = tmp_path / 'lab.yaml', tmp_path / 'levels.csv'
    assert main(['identify', str(folder), '--speed-only', '--out', str(out), '--levels-out',
                 str(levels), '--json']) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    fitted = report['fit']['groups']['all'] if 'fit' in report else report['groups']['all']
    assert fitted['F_c']['value'] == pytest.approx(F_C, rel=0.1)
    # the count of runs and the true reason of the one unused
    assert '9 raw run(s): 8 used, 1 unused' in captured.err
    assert 'unused short: plateau shorter than needed at its rate' in captured.err
    assert 'too slow' not in captured.err and 'other sign' not in captured.err
    table = _rows(levels)
    speed = np.array([float(r['speed']) for r in table])
    friction = np.array([float(r['friction']) for r in table])
    assert len({r['experiment'] for r in table}) == len(SPEEDS)  # each run's file name
    assert {r['joint'] for r in table} == {'runs'}  # one joint, named after its folder
    np.testing.assert_allclose(friction, _truth(speed), rtol=0.06)
    # segment of one of the runs: the same levels (same sign) as identify --levels-out
    single = tmp_path / 'one.csv'
    assert main(['segment', str(folder / 'x7.csv'), '--out', str(single)]) == 0
    alone = _rows(single)
    assert {r['experiment'] for r in alone} == {'x7'}  # the label is the file name
    assert [r['friction'] for r in alone] == [r['friction'] for r in table
                                              if r['experiment'] == 'x7']


def test_torque_against_the_motion_is_read_with_the_other_sign_and_said(tmp_path, capsys):
    folder = _lab_folder(tmp_path / 'kuka_like', sign=-1.0, seed=2)
    out = tmp_path / 'lab.yaml'
    assert main(['identify', str(folder), '--speed-only', '--out', str(out), '--json']) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    fitted = report['fit']['groups']['all'] if 'fit' in report else report['groups']['all']
    speeds = np.asarray(SPEEDS)  # the curve of the truth (the split into F_c, F_s is the fit's)
    np.testing.assert_allclose(speed_model_friction(
        {k: p['value'] for k, p in fitted.items()}, speeds), _truth(speeds), rtol=0.05)
    assert 'read with the other sign' in captured.err
    # --raw-sign keeps the sign against the motion: a zero fit is refused, no set written
    refused = tmp_path / 'refused.yaml'
    assert main(['identify', str(folder), '--speed-only', '--raw-sign', '--out',
                 str(refused)]) == 2
    error = capsys.readouterr().err
    assert 'the likely cause is the sign of the torque' in error
    assert 'no set is written' in error
    assert not refused.exists()
    # segment and audit read the same sign as identify
    levels = tmp_path / 'levels.csv'
    assert main(['segment', str(folder), '--out', str(levels)]) == 0
    assert 'read with the other sign' in capsys.readouterr().err
    assert all(float(r['friction']) > 0 for r in _rows(levels))


def test_a_negative_level_table_is_refused_by_identify_speed_only(tmp_path, capsys):
    speed = np.repeat(SPEEDS, 2)
    table = tmp_path / 'negative.csv'
    table.write_text('speed,friction\n' + ''.join(
        f'{float(v)!r},{-float(_truth(v))!r}\n' for v in speed))
    out = tmp_path / 'set.yaml'
    assert main(['identify', str(table), '--speed-only', '--out', str(out)]) == 2
    assert 'zero at every measured speed' in capsys.readouterr().err
    assert not out.exists()
    # signed speeds with signed frictions stay valid: the negative rows are folded
    signed = tmp_path / 'signed.csv'
    noise = np.random.default_rng(3).normal(0.0, 2e-4, (len(SPEEDS), 2))
    signed.write_text('speed,friction\n' + ''.join(
        f'{s * v!r},{s * float(_truth(v) + noise[i, j])!r}\n'
        for i, v in enumerate(SPEEDS) for j, s in enumerate((1, -1))))
    assert main(['identify', str(signed), '--speed-only', '--out', str(out)]) == 0
    assert out.exists()


def test_a_joint_column_or_prefix_splits_a_folder(tmp_path):
    from robot_wear_monitor.recordings.raw_runs import joint_of_run
    run = tmp_path / 'a.csv'
    run.write_text('t_s,q_rad,dq_rad_s,tau_measured_Nm,joint\n0,0,0,0,3\n0.01,0,0,0,3\n')
    assert joint_of_run(run) == '3'
    assert joint_of_run(tmp_path / 'joint4_vel_p5.csv.gz') == 'joint4'
    mixed = tmp_path / 'b.csv'
    mixed.write_text('t_s,q_rad,dq_rad_s,tau_measured_Nm,joint\n0,0,0,0,A1\n0.01,0,0,0,A2\n')
    with pytest.raises(Exception, match='a raw run is one joint'):
        joint_of_run(mixed)


# --------------------------------------------------------------------------- shared data

SCREW = EXTERNAL_DIR / 'rvimlab_tro2021_screw_drives'


def test_screw_drive_3_steady_recordings_give_the_authors_levels(tmp_path, capsys):
    folder = require_path(SCREW / 'raw_runs' / 'driveNo3')
    authors = {r['experiment'][4:]: (float(r['speed']), float(r['friction']))
               for r in _rows(SCREW / 'levels' / 'levels_drive3_eq3.csv')}
    out = tmp_path / 'levels.csv'
    assert main(['segment', str(folder), '--out', str(out)]) == 0
    err = capsys.readouterr().err
    assert 'raw run(s):' in err and 'share no position window' in err
    close = 0
    for row in _rows(out):
        if not row['experiment'].startswith('steady_p'):
            continue
        forward, backward = row['experiment'].split('+')
        assert forward[len('steady_p'):] == backward[len('steady_n'):]  # same set-point
        speed, friction = authors[forward[len('steady_p'):]]
        if abs(float(row['speed']) / speed - 1) <= 0.08 and \
                abs(float(row['friction']) / friction - 1) <= 0.08:
            close += 1
    assert close >= 15


def test_a_screw_drive_start_stop_run_reads_the_same_in_segment_and_identify(tmp_path,
                                                                             capsys):
    run = require_path(SCREW / 'raw_runs' / 'driveNo3' / 'start_stop_200.csv')
    segmented = tmp_path / 'segment.csv'
    assert main(['segment', str(run), '--out', str(segmented)]) == 0
    written = tmp_path / 'identify.csv'
    # one speed is too few for model (4) (exit 2), but the levels are written first
    assert main(['identify', str(run), '--speed-only', '--out', str(tmp_path / 's.yaml'),
                 '--levels-out', str(written)]) == 2
    capsys.readouterr()
    friction = [float(r['friction']) for r in _rows(segmented)]
    assert friction == [float(r['friction']) for r in _rows(written)]
    assert friction[0] == pytest.approx(1.595e-3, rel=0.01)  # PROVENANCE.md: positive


def test_kuka_runs_are_read_with_the_other_sign_in_every_verb(tmp_path, capsys, kuka_dir):
    folder = tmp_path / 'joint6'
    folder.mkdir()
    for path in sorted((kuka_dir / 'raw_runs').glob('joint6_vel_*.csv.gz')):
        (folder / path.name).symlink_to(path)
    levels = tmp_path / 'levels.csv'
    assert main(['identify', str(folder), '--speed-only', '--out', str(tmp_path / 'k.yaml'),
                 '--levels-out', str(levels)]) == 0
    err = capsys.readouterr().err
    assert 'joint6: the eq. (3) friction' in err and 'read with the other sign' in err
    table = _rows(levels)
    assert all(float(r['friction']) > 0 for r in table)
    one = sorted(folder.iterdir())[0]
    single = tmp_path / 'one.csv'
    assert main(['segment', str(one), '--out', str(single)]) == 0
    label = one.name[:-len('.csv.gz')]
    assert [r['friction'] for r in _rows(single)] == [r['friction'] for r in table
                                                      if r['experiment'] == label]
    assert {r['joint'] for r in _rows(single)} == {'joint6'}


def test_kinova_one_way_runs_are_each_named_one_direction_only(tmp_path, capsys):
    source = require_path(EXTERNAL_DIR / 'kinova_gen3_hbrs_sdp' / 'velocity_runs')
    folder = tmp_path / 'kinova'
    folder.mkdir()
    files = sorted(source.glob('velocity_*readings.csv'))
    for path in files:  # the project's columns: 1 kHz, joint 7, Kt x current [N.m]
        data = np.loadtxt(path)
        t = np.arange(data.shape[0]) / 999.0
        with open(folder / path.name, 'w') as stream:
            stream.write('t_s,q_rad,dq_rad_s,tau_measured_Nm\n')
            for row in zip(t, data[:, 1], data[:, 2], 7.6 * data[:, 5]):
                stream.write(','.join(f'{x:.6g}' for x in row) + '\n')
    assert main(['segment', str(folder), '--out', str(tmp_path / 'levels.csv')]) == 2
    error = capsys.readouterr().err
    assert f'no friction level found in {len(files)} raw run(s) (0 used, {len(files)} unused)' \
        in error
    assert 'moves one way only' in error
    assert not (tmp_path / 'levels.csv').exists()
