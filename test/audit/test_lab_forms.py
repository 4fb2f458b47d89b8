"""
Friction data in the forms labs record them (part of the lab-data issue).

Own generator here (a speed-only curve (4) with a direction offset, in N.m, repeated runs):
signed speeds (one row per direction, signed torque), a numeric joint column, a table without
a wear column, and fitted parameters that are no friction, each with its known truth.
"""

from __future__ import annotations

import numpy as np
import pytest
from robot_wear_monitor.audit.data import table_from_columns
from robot_wear_monitor.audit.fitting import speed_base
from robot_wear_monitor.audit.run import run_audit, speed_parameter_flags
from robot_wear_monitor.cli import main
from robot_wear_monitor.errors import InputError

SPEEDS = np.geomspace(0.01, 1.6, 20)  # rad/s, both directions
NOISE = 0.01  # N.m


def curve(speed, *, coulomb=1.2, stribeck=0.6, phi=0.05, alpha=1.4, viscous=0.8):
    """Return the friction magnitude of model (4) [N.m] at |speed| [rad/s]."""
    v = np.abs(speed)
    return coulomb + stribeck * np.exp(-(v / phi) ** alpha) + viscous * v


def signed_columns(*, seed=0, repeats=3, offset=0.15):
    """Rows per speed and direction; torque signed; the negative direction ``offset`` higher."""
    rng = np.random.default_rng(seed)
    speed = np.concatenate([SPEEDS, -SPEEDS])
    speed = np.tile(speed, repeats)
    magnitude = curve(speed) + np.where(speed < 0, offset, 0.0)
    torque = np.sign(speed) * magnitude + rng.normal(0, NOISE, speed.size)
    run = np.repeat(np.arange(repeats), 2 * SPEEDS.size)
    return {'speed': speed, 'friction': torque, 'experiment': run}


def test_signed_speeds_become_a_direction_group_and_the_offset_is_found():
    table = table_from_columns(signed_columns())
    assert np.all(table.numeric['speed'] > 0)
    assert set(table.text['direction']) == {'positive', 'negative'}
    assert np.all(table.numeric['friction'] > 0)  # signed torque folded to its magnitude
    result = run_audit(table=table, model='speed', estimate=False)
    assert any('direction' in effect.variables for effect in result.effects), result.summary()
    assert result.rms_after < 0.6 * result.rms_before
    assert result.rms_after < 2.0 * NOISE


def test_signed_speeds_with_a_direction_column_or_a_zero_speed_are_refused():
    columns = signed_columns()
    with pytest.raises(InputError, match="signed speeds and a 'direction' column"):
        table_from_columns({**columns, 'direction': np.where(columns['speed'] > 0, 'a', 'b')})
    columns['speed'] = columns['speed'].copy()
    columns['speed'][3] = 0.0
    with pytest.raises(InputError, match='standstill row'):
        table_from_columns(columns)


def test_a_numeric_joint_column_is_a_group_and_joints_are_fitted_apart(tmp_path, capsys):
    rng = np.random.default_rng(2)
    rows = []
    for joint, scale in ((1, 1.0), (2, 7.0)):
        for run in range(3):
            f = scale * curve(SPEEDS) + rng.normal(0, NOISE, SPEEDS.size)
            rows += [(joint, run + 10 * joint, v, x) for v, x in zip(SPEEDS, f)]
    path = tmp_path / 'joints.csv'
    path.write_text('joint,experiment,speed,friction\n' + ''.join(
        f'{j},{e},{float(v)!r},{float(x)!r}\n' for j, e, v, x in rows))
    assert main(['audit', str(path), '--json']) == 0
    import json
    report = json.loads(capsys.readouterr().out)
    assert report['group'] == 'joint' and set(report['parameters_after']) == {'1', '2'}
    coulomb = {k: v['F_c'] for k, v in report['parameters_after'].items()}
    assert coulomb['2'] / coulomb['1'] == pytest.approx(7.0, rel=0.1)
    assert 'joint' not in report['candidates']  # a group, never a number to be linear in
    # each joint its own held-out error: a sevenfold friction is not pooled with the other
    errors = report['rms_by_group']
    assert set(errors) == {'1', '2'} and errors['2']['after'] < 3 * NOISE
    assert errors['1']['after'] < 3 * NOISE
    # a parameter set is one joint's: identify refuses to pool them unless asked
    out = tmp_path / 'set.yaml'
    assert main(['identify', str(path), '--out', str(out), '--speed-only']) == 2
    assert 'levels of 2 joints (1, 2)' in capsys.readouterr().err and not out.exists()
    assert main(['identify', str(path), '--out', str(out), '--speed-only', '--joint', '2',
                 '--json']) == 0
    fitted = json.loads(capsys.readouterr().out)['fit']['groups']['all']
    assert fitted['F_c']['value'] == pytest.approx(7.0 * 1.2, rel=0.05)
    assert main(['identify', str(path), '--out', str(out), '--speed-only', '--joint', '3']) == 2
    assert '--joint 3: not in the levels (joints: 1, 2)' in capsys.readouterr().err
    assert main(['identify', str(path), '--out', str(out), '--speed-only', '--pool-joints',
                 '--json']) == 0
    assert json.loads(capsys.readouterr().out)['fit']['n_levels'] == len(rows)


def test_no_wear_error_without_a_wear_column_and_no_packaged_set_without_params(capsys):
    from pathlib import Path
    baseline = Path(__file__).resolve().parents[2] / 'examples' / 'baseline.csv'
    assert main(['audit', str(baseline), '--model', 'nominal', '--json']) == 0
    import json
    report = json.loads(capsys.readouterr().out)
    assert report['estimate_changes']['applies'] is False
    assert 'no --params' in report['estimate_changes']['reason']
    params = Path(__file__).resolve().parents[2] / 'config' / 'irb6620_joint2.yaml'
    assert main(['audit', str(baseline), '--model', 'nominal', '--params', str(params),
                 '--json']) == 0
    changes = json.loads(capsys.readouterr().out)['estimate_changes']
    assert changes['applies'] is True and changes['wear_rms_error_before'] is None
    assert changes['temperature_rms_error_before_degc'] is not None
    assert 'no wear column' in changes['reference']


def test_parameters_that_are_no_friction_or_sit_on_a_bound_are_flagged():
    rng = np.random.default_rng(4)
    speed = np.tile(SPEEDS, 3)
    offset = curve(speed) - 2.0 + rng.normal(0, NOISE, speed.size)  # a torque offset
    table = table_from_columns({'speed': speed, 'friction': offset,
                                'experiment': np.repeat(np.arange(3), SPEEDS.size)})
    result = run_audit(table=table, model='speed', estimate=False)
    # model (4) is fitted in its domain (identify --speed-only's fitter): F_c is held at 0
    assert result.parameters_after['all']['F_c'] == 0
    assert any(flag.startswith('F_c = 0 sits on its bound') for flag in result.parameter_flags)
    assert 'FLAG: F_c' in result.summary() and 'fitted (all): F_c' in result.summary()
    base = speed_base(table, None)
    lower, upper = base.bounds(table)
    theta = np.array([np.log(0.05), upper[1]])  # alpha on its upper bound
    flags = speed_parameter_flags(base, theta, np.array([1.0, 0.5, 0.8]), table)
    assert flags == ('alpha = 3 sits on its upper bound 3: not identified by these speeds',)


def _replicated(extra=None, *, seed=6, runs=4):
    rng = np.random.default_rng(seed)
    speed = np.tile(SPEEDS, runs) * (1 + rng.normal(0, 0.002, SPEEDS.size * runs))
    friction = curve(speed) + rng.normal(0, NOISE, speed.size)
    if extra is not None:
        friction = friction + extra(speed)
    return table_from_columns({'speed': speed, 'friction': friction,
                               'experiment': np.repeat(np.arange(runs), SPEEDS.size)})


def test_replicate_runs_give_the_pure_error_and_a_passing_lack_of_fit_test():
    result = run_audit(table=_replicated(), model='speed', estimate=False)
    lof = result.lack_of_fit
    assert lof is not None and lof.groups == SPEEDS.size  # speeds scattered 0.2 %: one set-point
    assert lof.pure_error == pytest.approx(NOISE, rel=0.25)
    assert lof.p_value > 0.01 and 'to the replicate scatter' in lof.statement()
    assert 'replicates: lack of fit against the pure error' in result.summary()
    # nothing left to explain: the audit stops on the lack-of-fit test, adds nothing
    assert result.stop_reason.startswith('the model explains the data to the replicate error')
    assert not result.effects


def test_lack_of_fit_names_the_speeds_the_model_cannot_explain():
    def bump(v):  # a resonance near 0.3 rad/s that no term of model (4) has
        return 0.08 * np.exp(-((np.log(v) - np.log(0.3)) / 0.15) ** 2)
    result = run_audit(table=_replicated(bump), model='speed', estimate=False, max_effects=0)
    lof = result.lack_of_fit
    assert lof is not None and lof.p_value < 1e-6
    low, high = lof.speed_range
    assert low <= 0.3 <= high and high < 1.0 and low > 0.05
    assert 'the model cannot explain the speeds' in result.to_dict()['lack_of_fit']['statement']
    assert result.stop_reason.endswith(f'lack of fit remains against the replicate error '
                                       f'(speeds {low:.4g} to {high:.4g})')
    assert result.noise_floor == pytest.approx(lof.pure_error)
    assert result.noise_floor_method.startswith('replicates: pure error of')
    # let the audit look for the effect: a smooth term in speed explains the resonance
    found = run_audit(table=_replicated(lambda v: 0.08 * np.exp(
        -((np.log(v) - np.log(0.3)) / 0.15) ** 2)), model='speed', estimate=False)
    assert found.effects and found.effects[0].variables == ('speed',)
    # the goal: within 1.5 x the replicate error, or a lack-of-fit statement naming the speeds
    assert found.rms_after < 1.5 * found.lack_of_fit.pure_error or (
        'lack of fit remains against the replicate error' in found.stop_reason
        and '(speeds 0.1' in found.stop_reason)


def _raw_run(path, velocity, torque, dt=0.005):
    position = np.cumsum(velocity) * dt
    rows = zip(np.arange(velocity.size) * dt, position, velocity, torque)
    path.write_text('t_s,q_rad,dq_rad_s,tau_measured_Nm\n' + ''.join(
        ','.join(repr(float(x)) for x in row) + '\n' for row in rows))
    return path


@pytest.mark.parametrize('speed, reason', [
    (0.3, 'the joint moves one way only (forward, at about 0.3 rad/s)'),
    (0.0017, 'too slow to tell from standstill at 0.00'),
])
def test_a_raw_run_without_levels_is_exit_2_with_the_reason(tmp_path, capsys, speed, reason):
    rng = np.random.default_rng(1)
    n = 2000
    run = _raw_run(tmp_path / 'run.csv', speed + rng.normal(0, 0.002, n),
                   curve(np.full(n, speed)) + rng.normal(0, NOISE, n))
    out = tmp_path / 'levels.csv'
    assert main(['segment', str(run), '--out', str(out)]) == 2
    assert reason in capsys.readouterr().err
    assert not out.exists()  # no header-only table that reads as "no levels, all fine"


ONE_WAY_SPEEDS = (0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0)


def _one_way(folder, speed, direction, *, rng, gravity=5.0, rate=200.0, tag='',
             negative_offset=0.0):
    """Write a run that moves once across [-0.5, 0.5] rad at ``speed`` one way (KUKA columns)."""
    import gzip
    travel = 1.0
    n_move = int(round(travel / speed * rate))
    n_still = int(0.5 * rate)
    q_move = np.linspace(-0.5, 0.5, n_move) if direction > 0 else np.linspace(0.5, -0.5, n_move)
    q = np.concatenate([np.full(n_still, q_move[0]), q_move, np.full(n_still, q_move[-1])])
    v = np.concatenate([np.zeros(n_still), np.full(n_move, direction * speed),
                        np.zeros(n_still)])
    magnitude = curve(np.abs(v)) + (negative_offset if direction < 0 else 0.0)
    tau = gravity * np.cos(q) + np.sign(v) * magnitude + rng.normal(0, NOISE, q.size)
    t = np.arange(q.size) / rate
    label = f'{speed:g}'.replace('.', 'p')
    name = folder / f'joint2_{"fwd" if direction > 0 else "bwd"}{tag}_vel_{label}.csv.gz'
    with gzip.open(name, 'wt') as stream:
        stream.write('t_s,q_rad,dq_rad_s,tau_measured_Nm\n')
        for row in zip(t, q, v + rng.normal(0, 1e-4, q.size), tau):
            stream.write(','.join(repr(float(x)) for x in row) + '\n')
    return name


def test_one_way_runs_are_paired_across_files_and_gravity_cancels(tmp_path):
    from robot_wear_monitor.audit.data import table_from_raw_runs
    rng = np.random.default_rng(8)
    files = [_one_way(tmp_path, v, d, rng=rng) for v in ONE_WAY_SPEEDS for d in (1, -1)]
    table = table_from_raw_runs(sorted(files), flip_sign=False)
    assert table.n_rows == len(ONE_WAY_SPEEDS)
    order = np.argsort(table.numeric['speed'])
    speeds = table.numeric['speed'][order]
    np.testing.assert_allclose(speeds, ONE_WAY_SPEEDS, rtol=0.02)
    # eq. (3) across the two files: the gravity torque (5 N.m x cos q) cancels
    np.testing.assert_allclose(table.numeric['friction'][order], curve(speeds), atol=0.01)
    assert all('+' in e for e in table.text['experiment'])


def test_one_way_runs_without_a_partner_are_named(tmp_path):
    from robot_wear_monitor.audit.data import table_from_raw_runs
    rng = np.random.default_rng(9)
    files = [_one_way(tmp_path, v, 1, rng=rng) for v in ONE_WAY_SPEEDS[:2]]
    with pytest.raises(InputError, match='move one way only and have no run the other way'):
        table_from_raw_runs(files, flip_sign=False)


def _back_and_forth(path, speed, *, velocity_noise, rng, rate=200.0, cycles=3):
    """Write a run back and forth across 0.02 rad at ``speed`` [rad/s] (KUKA columns)."""
    n_move = int(round(0.02 / speed * rate))
    n_still = int(0.5 * rate)
    v = np.concatenate([np.concatenate([np.zeros(n_still), np.full(n_move, speed),
                                        np.zeros(n_still), np.full(n_move, -speed)])
                        for _ in range(cycles)])
    q = np.cumsum(v) / rate
    tau = 2.0 * np.cos(q) + np.sign(v) * curve(np.abs(v)) + rng.normal(0, NOISE, v.size)
    return _raw_run(path, v + rng.normal(0, velocity_noise, v.size), tau, dt=1.0 / rate)


def test_the_standstill_threshold_follows_the_speed_noise_of_a_slow_run(tmp_path, capsys):
    rng = np.random.default_rng(10)
    quiet = _back_and_forth(tmp_path / 'quiet.csv', 0.0017, velocity_noise=1e-5, rng=rng)
    out = tmp_path / 'levels.csv'
    assert main(['segment', str(quiet), '--out', str(out)]) == 0
    rows = out.read_text().splitlines()[1:]
    assert len(rows) >= 2
    header = out.read_text().splitlines()[0].split(',')
    speed = [float(r.split(',')[header.index('speed')]) for r in rows]
    friction = [float(r.split(',')[header.index('friction')]) for r in rows]
    np.testing.assert_allclose(speed, 0.0017, rtol=0.05)
    np.testing.assert_allclose(friction, float(curve(np.array([0.0017]))[0]), atol=0.02)
    noisy = _back_and_forth(tmp_path / 'noisy.csv', 0.0017, velocity_noise=3e-3, rng=rng)
    assert main(['segment', str(noisy), '--out', str(tmp_path / 'n.csv')]) == 2
    assert 'too slow to tell from standstill at' in capsys.readouterr().err
    # or the user sets the threshold: below the run's speed it segments, above it does not
    assert main(['segment', str(quiet), '--out', str(tmp_path / 's.csv'),
                 '--standstill-speed', '0.0005']) == 0
    set_speed = [float(r.split(',')[header.index('speed')])
                 for r in (tmp_path / 's.csv').read_text().splitlines()[1:]]
    np.testing.assert_allclose(set_speed, 0.0017, rtol=0.05)
    assert main(['segment', str(quiet), '--out', str(tmp_path / 'x.csv'),
                 '--standstill-speed', '0.01']) == 2
    assert 'too slow to tell from standstill at 0.0017 rad/s' in capsys.readouterr().err
    assert not (tmp_path / 'x.csv').exists()
    from robot_wear_monitor.audit.data import load_audit_data
    table = load_audit_data(quiet, standstill_speed_rad_s=0.0005)
    assert table.n_rows >= 2
    with pytest.raises(InputError, match='no friction level'):
        load_audit_data(quiet, standstill_speed_rad_s=0.01)


def test_a_one_way_run_without_a_partner_uses_a_known_torque_column(tmp_path, capsys):
    import gzip
    rng = np.random.default_rng(11)
    for speed, tag in [(v, t) for v in ONE_WAY_SPEEDS for t in ('', '_b', '_c')]:
        path = _one_way(tmp_path, speed, 1, rng=rng, tag=tag)
        lines = gzip.open(path, 'rt').read().splitlines()
        q = [float(line.split(',')[1]) for line in lines[1:]]
        with gzip.open(path, 'wt') as stream:  # the user's gravity model: 5 N.m x cos q
            stream.write(lines[0] + ',gravity_Nm\n')
            stream.write(''.join(f'{line},{float(5.0 * np.cos(x))!r}\n'
                                 for line, x in zip(lines[1:], q)))
    assert main(['audit', str(tmp_path), '--raw-sign', '--json']) == 2
    assert '--known-torque COLUMN' in capsys.readouterr().err
    assert main(['audit', str(tmp_path), '--raw-sign', '--known-torque', 'gravity_Nm',
                 '--json']) == 0
    import json
    report = json.loads(capsys.readouterr().out)
    fitted = report['parameters_after']['all']
    assert fitted['F_c'] == pytest.approx(1.2, abs=0.1)
    assert fitted['F_v'] == pytest.approx(0.8, abs=0.15)


def test_identify_makes_a_speed_only_set_that_says_what_it_cannot_do(tmp_path, capsys):
    import json
    columns = signed_columns(repeats=4, offset=0.15)  # the negative direction 0.15 N.m higher
    path = tmp_path / 'curve.csv'
    path.write_text('speed,friction,experiment\n' + ''.join(
        f'{float(v)!r},{float(f)!r},{int(e)}\n' for v, f, e in zip(
            columns['speed'], columns['friction'], columns['experiment'])))
    out = tmp_path / 'lab.yaml'
    assert main(['identify', str(path), '--out', str(out)]) == 2  # the old answer stays
    assert '--speed-only identifies the speed model (4)' in capsys.readouterr().err
    assert main(['identify', str(path), '--out', str(out), '--speed-only', '--friction-unit',
                 'N.m', '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['kind'] == 'speed_only' and report['loaded_back']
    fitted = report['fit']['groups']['all']  # eq. (3): the mean of the two directions
    for name, truth in (('F_c', 1.2 + 0.075), ('F_s', 0.6), ('phi_s', 0.05), ('F_v', 0.8)):
        value, error = fitted[name]['value'], fitted[name]['std_error']
        assert abs(value - truth) <= 3 * error + 1e-3, (name, value, error)
    directions = report['per_direction']['groups']
    for direction, coulomb in (('positive', 1.2), ('negative', 1.35)):
        value, error = directions[direction]['F_c']['value'], \
            directions[direction]['F_c']['std_error']
        assert abs(value - coulomb) <= 3 * error + 1e-3, (direction, value, error)
    from robot_wear_monitor.model.params import load_parameter_set
    params = load_parameter_set(out)
    assert params.not_identified == ('temperature', 'load', 'wear')
    assert params.friction_unit == 'N.m'
    assert 'not_identified:' in out.read_text() and 'friction_unit: N.m' in out.read_text()
    # what needs temperature, load or wear is refused, naming the set and why
    assert main(['estimate', '--speeds', '0.1,0.5,1.0', '--friction', '1.3,1.6,2.0',
                 '--params', str(out)]) == 2
    assert 'did not identify wear' in capsys.readouterr().err
    assert main(['design', '--n', '2', '--params', str(out)]) == 2
    assert 'designing the experiment' in capsys.readouterr().err
    assert main(['simulate', '--out', str(tmp_path / 'bag'), '--params', str(out)]) == 2
    # a wear test needs the nominal model, which these levels cannot give
    assert main(['identify', str(path), '--out', str(tmp_path / 'x.yaml'), '--speed-only',
                 '--wear-test', str(path), '--critical-experiment', '1']) == 2
    assert 'a wear test (7) needs the nominal model (5)' in capsys.readouterr().err


POSITIVE = {'coulomb': 1.2, 'stribeck': 0.6, 'phi': 0.05, 'alpha': 1.4, 'viscous': 0.8}
NEGATIVE = {'coulomb': 1.0, 'stribeck': 0.9, 'phi': 0.08, 'alpha': 1.4, 'viscous': 1.1}


def _direction_csv(path, *, negative, seed=3, repeats=4):
    """Signed levels whose model (4) is ``POSITIVE`` forwards and ``negative`` backwards."""
    rng = np.random.default_rng(seed)
    rows = []
    for run in range(repeats):
        for v in SPEEDS:
            rows.append((v, curve(v, **POSITIVE) + rng.normal(0, NOISE), run))
            rows.append((-v, -(curve(v, **negative) + rng.normal(0, NOISE)), run))
    path.write_text('speed,friction,experiment\n' + ''.join(
        f'{float(v)!r},{float(f)!r},{int(e)}\n' for v, f, e in rows))
    return path


def test_identify_writes_model_4_per_direction_when_the_directions_differ(tmp_path, capsys):
    import json

    from robot_wear_monitor.model.friction import direction_friction
    from robot_wear_monitor.model.params import load_parameter_set
    path = _direction_csv(tmp_path / 'signed.csv', negative=NEGATIVE)
    out = tmp_path / 'lab.yaml'
    assert main(['identify', str(path), '--out', str(out), '--speed-only', '--friction-unit',
                 'N.m', '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['direction_test']['differ'] and report['direction_test']['p_value'] < 1e-6
    params = load_parameter_set(out)
    assert params.direction_model is not None and 'direction_model:' in out.read_text()
    names = {'f_c': 'coulomb', 'f_s': 'stribeck', 'phi_s': 'phi', 'alpha': 'alpha',
             'f_v': 'viscous'}
    groups = report['per_direction']['groups']
    for terms, truth, direction in zip(params.direction_model, (POSITIVE, NEGATIVE),
                                       ('positive', 'negative')):
        for key, name in names.items():
            error = groups[direction][{'f_c': 'F_c', 'f_s': 'F_s', 'phi_s': 'phi_s',
                                       'alpha': 'alpha', 'f_v': 'F_v'}[key]]['std_error']
            assert abs(getattr(terms, key) - truth[name]) <= 4 * error + 1e-3, \
                (direction, key, getattr(terms, key), truth[name], error)
    # the set's per-direction model predicts each direction's friction to the noise
    speeds = np.concatenate([SPEEDS, -SPEEDS])
    truth = np.where(speeds > 0, curve(speeds, **POSITIVE), curve(speeds, **NEGATIVE))
    assert np.max(np.abs(direction_friction(speeds, params.direction_model) - truth)) \
        < 3 * NOISE
    # the noise of the set is one direction's, not the gap between the directions
    assert params.sigma < 2 * NOISE
    # eq. (3) levels are the mean of the directions: the symmetric model is near it
    mean = 0.5 * (curve(SPEEDS, **POSITIVE) + curve(SPEEDS, **NEGATIVE))
    from robot_wear_monitor.model.friction import nominal_friction
    symmetric = nominal_friction(SPEEDS, 0.0, 40.0, params.model)
    assert np.sqrt(np.mean((symmetric - mean) ** 2)) < 0.05


def test_identify_keeps_one_symmetric_model_when_the_directions_agree(tmp_path, capsys):
    import json

    from robot_wear_monitor.model.params import load_parameter_set
    path = _direction_csv(tmp_path / 'signed.csv', negative=POSITIVE)
    out = tmp_path / 'lab.yaml'
    assert main(['identify', str(path), '--out', str(out), '--speed-only', '--json']) == 0
    printed = capsys.readouterr()
    report = json.loads(printed.out)
    assert not report['direction_test']['differ']
    # a level table does not say its unit: the set's is named as assumed
    assert 'friction unit of' in printed.err and "the set says 'normalised'" in printed.err
    assert report['friction_unit'] == 'normalised'
    assert load_parameter_set(out).direction_model is None
    assert 'direction_model' not in out.read_text()


@pytest.mark.parametrize('change, message', [
    ({'positive': None}, 'direction_model.positive: expected a mapping'),
    ({'sideways': {}}, 'unknown key direction_model.sideways'),
    ({'negative': {'f_c': 1.0, 'f_s': 0.5, 'phi_s': -0.1, 'alpha': 1.0, 'f_v': 0.1}},
     'direction_model.negative.phi_s: must be > 0'),
    ({'negative': {'f_c': 1.0, 'f_s': 0.5, 'phi_s': 0.1, 'alpha': 1.0}},
     'missing key direction_model.negative.f_v'),
])
def test_a_bad_direction_model_is_refused_naming_the_key(change, message):
    from robot_wear_monitor.errors import InputError as Error
    from robot_wear_monitor.model.params import (load_parameter_set, parameter_set_from_mapping,
                                                 parameter_set_to_mapping)
    terms = {'f_c': 1.0, 'f_s': 0.5, 'phi_s': 0.1, 'alpha': 1.0, 'f_v': 0.1}
    document = parameter_set_to_mapping(load_parameter_set())
    document['direction_model'] = {'positive': dict(terms), 'negative': dict(terms), **change}
    with pytest.raises(Error, match=message.replace('.', r'\.')):
        parameter_set_from_mapping(document, source='set.yaml')


BACKWARD_SPEEDS = (0.15, 0.25, 0.38, 0.52, 0.7, 0.9, 1.2)  # none near a forward speed


def test_one_way_runs_with_a_known_torque_keep_their_direction(tmp_path):
    """Unpaired forward and backward runs: each level says its direction (the data's sign)."""
    import gzip

    from robot_wear_monitor.audit.data import table_from_raw_runs
    rng = np.random.default_rng(12)
    files = [_one_way(tmp_path, v, 1, rng=rng) for v in ONE_WAY_SPEEDS] + [
        _one_way(tmp_path, v, -1, rng=rng, negative_offset=0.3) for v in BACKWARD_SPEEDS]
    for path in files:  # the user's gravity model beside the torque
        lines = gzip.open(path, 'rt').read().splitlines()
        q = [float(line.split(',')[1]) for line in lines[1:]]
        with gzip.open(path, 'wt') as stream:
            stream.write(lines[0] + ',gravity_Nm\n')
            stream.write(''.join(f'{line},{float(5.0 * np.cos(x))!r}\n'
                                 for line, x in zip(lines[1:], q)))
    table = table_from_raw_runs(sorted(files), flip_sign=False, known_torque='gravity_Nm')
    direction = table.text['direction']
    assert set(direction.tolist()) == {'positive', 'negative'}
    speed, friction = table.numeric['speed'], table.numeric['friction']
    truth = curve(speed) + np.where(direction == 'negative', 0.3, 0.0)
    np.testing.assert_allclose(friction, truth, atol=0.02)
    forward = direction == 'positive'
    np.testing.assert_allclose(np.sort(np.unique(np.round(speed[forward], 2))),
                               ONE_WAY_SPEEDS, rtol=0.03)
