"""
``audit --levels-out`` and ``identify --levels-out``: the levels fitted are ``segment``'s.

A simulated bag (the package's simulation, eight speeds of Table V's grid) and a raw run
(KUKA columns, eight link-side speeds back and forth) are segmented by ``segment`` and read by
``audit`` and ``identify``; the levels they write have ``segment``'s rows and numbers.
"""

import csv

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.monitoring.segment import LEVEL_COLUMNS

BAG_SPEEDS = (2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2)
RAW_SPEEDS = (0.05, 0.08, 0.12, 0.2, 0.3, 0.45, 0.6, 0.8)
BAG_ARGS = ['--joint', 'joint_2', '--gear-ratio', '150', '--torque-scale', '10']


def _rows(path):
    with open(path, newline='') as stream:
        return list(csv.DictReader(stream))


def _friction(speed):
    return 0.3 + 0.4 * np.exp(-np.abs(speed) / 0.1) + 0.5 * np.abs(speed)


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp('levels_out')
    path = folder / 'bag'
    assert main(['simulate', '--out', str(path), '--experiments', '2', '--seed', '4',
                 '--speeds', ','.join(f'{v:g}' for v in BAG_SPEEDS)]) == 0
    segment = folder / 'segment.csv'
    assert main(['segment', str(path), '--joint', 'joint_2', '--out', str(segment)]) == 0
    return path, _rows(segment)


def test_audit_and_identify_of_a_bag_write_segments_levels(bag, tmp_path):
    path, expected = bag
    speeds = np.array([float(row['speed']) for row in expected])
    nearest = np.abs(speeds[:, None] - np.array(BAG_SPEEDS)[None, :])
    assert np.all(nearest.min(axis=1) < 0.02 * speeds)  # each level at a simulated speed
    assert set(nearest.argmin(axis=1)) == set(range(len(BAG_SPEEDS)))  # every speed found
    assert main(['audit', str(path), *BAG_ARGS, '--levels-out', str(tmp_path / 'a.csv')]) == 0
    assert main(['identify', str(path), '--speed-only', *BAG_ARGS, '--out',
                 str(tmp_path / 'set.yaml'), '--levels-out', str(tmp_path / 'i.csv')]) == 0
    for name in ('a.csv', 'i.csv'):
        got = _rows(tmp_path / name)
        assert list(got[0]) == list(LEVEL_COLUMNS)  # segment's columns (no temperature here)
        assert got == expected, name  # the same rows, every cell (experiment and joint too)


def test_every_verb_that_segments_a_bag_takes_the_node_configuration(bag, tmp_path):
    """No scale given: audit and identify of a bag segment it as segment does (150 and 10)."""
    path, expected = bag
    assert main(['audit', str(path), '--joint', 'joint_2', '--levels-out',
                 str(tmp_path / 'a.csv')]) == 0
    assert main(['identify', str(path), '--speed-only', '--joint', 'joint_2', '--out',
                 str(tmp_path / 'set.yaml'), '--levels-out', str(tmp_path / 'i.csv')]) == 0
    assert _rows(tmp_path / 'a.csv') == expected
    assert _rows(tmp_path / 'i.csv') == expected
    # another node configuration: segment, audit and identify all follow it (torque scale 20
    # halves every friction), none keeps the packaged 10
    config = tmp_path / 'node.yaml'
    config.write_text('friction_experiment_node:\n  ros__parameters:\n'
                      '    joint_2: {torque_scale: 20.0}\n')
    written = {}
    for verb, extra in (('segment', ['--out']), ('audit', ['--levels-out']),
                        ('identify', ['--speed-only', '--out', str(tmp_path / 's2.yaml'),
                                      '--levels-out'])):
        out = tmp_path / f'{verb}_20.csv'
        assert main([verb, str(path), '--joint', 'joint_2', '--config', str(config),
                     *extra, str(out)]) == 0
        written[verb] = _rows(out)
    assert written['audit'] == written['identify'] == written['segment']
    halved = np.array([float(row['friction']) for row in written['segment']])
    packaged = np.array([float(row['friction']) for row in expected])
    assert np.allclose(halved, packaged / 2, rtol=1e-5)  # the CSV holds 6 digits


def test_levels_out_of_a_level_table_is_refused(bag, tmp_path, capsys):
    path, expected = bag
    table = tmp_path / 'levels.csv'
    assert main(['segment', str(path), '--joint', 'joint_2', '--out', str(table)]) == 0
    out = tmp_path / 'x.csv'
    assert main(['audit', str(table), '--levels-out', str(out)]) == 2
    assert 'is a table of levels already' in capsys.readouterr().err
    assert not out.exists()


def _raw_run(path, *, rate=200.0, travel=0.6, seed=3):
    """Write a run back and forth over ``travel`` rad at each of RAW_SPEEDS (KUKA columns)."""
    rng = np.random.default_rng(seed)
    still = np.zeros(int(0.5 * rate))
    parts = []
    for speed in RAW_SPEEDS:
        n = int(round(travel / speed * rate))
        for _ in range(2):
            parts += [still, np.full(n, speed), still, np.full(n, -speed)]
    v = np.concatenate(parts)
    q = np.cumsum(v) / rate
    tau = 2.0 * np.cos(q) + np.sign(v) * _friction(v) + rng.normal(0, 0.01, v.size)
    t = np.arange(v.size) / rate
    measured = v + rng.normal(0, 1e-4, v.size)
    with open(path, 'w') as stream:
        stream.write('t_s,q_rad,dq_rad_s,tau_measured_Nm\n')
        stream.writelines(f'{a!r},{b!r},{c!r},{d!r}\n' for a, b, c, d in zip(
            t.tolist(), q.tolist(), measured.tolist(), tau.tolist()))
    return path


def test_audit_and_identify_of_a_raw_run_write_segments_levels(tmp_path):
    run = _raw_run(tmp_path / 'joint2_run.csv')
    assert main(['segment', str(run), '--out', str(tmp_path / 's.csv')]) == 0
    expected = _rows(tmp_path / 's.csv')
    assert len(expected) == 2 * len(RAW_SPEEDS)  # two pairs per speed
    np.testing.assert_allclose(sorted(float(r['speed']) for r in expected),
                               np.repeat(RAW_SPEEDS, 2), rtol=0.02)
    np.testing.assert_allclose([float(r['friction']) for r in expected],
                               _friction(np.array([float(r['speed']) for r in expected])),
                               atol=0.01)
    numbers = [c for c in LEVEL_COLUMNS if c not in ('experiment', 'joint')]
    identify = ['--speed-only', '--out', str(tmp_path / 'set.yaml')]
    for verb, extra in (('audit', []), ('identify', identify)):
        out = tmp_path / f'{verb}.csv'
        assert main([verb, str(run), '--raw-sign', *extra, '--levels-out', str(out)]) == 0
        got = _rows(out)
        assert list(got[0]) == list(LEVEL_COLUMNS)
        assert [[r[c] for c in numbers] for r in got] == \
            [[r[c] for c in numbers] for r in expected], verb
        assert {r['experiment'] for r in got} == {'joint2_run'}  # the run, by its name
        assert len({r['joint'] for r in got}) == 1  # one joint, named from the file name
    # without --raw-sign the data decide (issue 43): this run's torque is along the motion,
    # so its friction is read as recorded, the same as segment's (the KUKA runs are flipped)
    out = tmp_path / 'data_sign.csv'
    assert main(['audit', str(run), '--levels-out', str(out)]) == 0
    assert [r['friction'] for r in _rows(out)] == [r['friction'] for r in expected]
    assert all(float(r['friction']) > 0 for r in _rows(out))
