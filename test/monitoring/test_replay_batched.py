"""
Batched estimation in the replay equals one-by-one estimation, number for number.

The replay estimates the experiments it has at hand together (``batch_experiments``); the
services then take them one by one.  Each bag here is replayed with batching off
(``batch_experiments=1``: every estimate computed alone, the path of the nodes) and on, and
everything the replay gives is compared exactly: the summary (experiments, levels, estimates,
intervals, trend, alarms, rejections), every message of the output bag byte for byte, and the
history rows.
"""

import math
import sqlite3

import pytest
from robot_wear_monitor.experiment.simulation import accelerated_wear_scenario, simulate_scenario
from robot_wear_monitor.monitoring import estimator_service
from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
from robot_wear_monitor.recordings.bags import write_joint_state_bag
from rosbags.rosbag2 import Reader
from wear_testing import foreign_recordings as fr


def _bag_messages(path):
    with Reader(path) as reader:
        return [(c.topic, stamp, bytes(data)) for c, stamp, data in reader.messages()]


def _history_rows(path):
    """Return table -> rows of a history file, the wall-clock columns left out."""
    with sqlite3.connect(path) as db:
        tables = [r[0] for r in db.execute(
            "select name from sqlite_master where type = 'table' order by name")]
        rows = {}
        for table in tables:
            cursor = db.execute(f'select * from "{table}"')
            keep = [i for i, column in enumerate(cursor.description)
                    if column[0] != 'wall_time_s']
            rows[table] = [tuple(row[i] for i in keep) for row in cursor.fetchall()]
    return rows


def _replay(bag, folder, *, batch, monkeypatch, **parameters):
    """
    Replay ``bag`` with ``batch_experiments=batch``; return (summary, bag msgs, history, calls).

    ``calls``: how many times the service computed an estimate itself (not prepared).
    """
    calls = []
    original = estimator_service._estimate_batch

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)
    monkeypatch.setattr(estimator_service, '_estimate_batch', counted)
    experiment, estimator = replay_parameters(**parameters)
    folder.mkdir()
    result = replay_bag(bag, out_bag=folder / 'out', experiment_parameters=experiment,
                        estimator_parameters=estimator, history_file=folder / 'h.sqlite3',
                        chunk_messages=4096, batch_experiments=batch)
    monkeypatch.undo()
    summary = result.summary()
    summary.pop('out_bag')
    return (summary, _bag_messages(folder / 'out'), _history_rows(folder / 'h.sqlite3'),
            len(calls))


def _same(a, b):
    """Assert two replays gave the same (NaN equal to NaN)."""
    def canonical(value):
        if isinstance(value, float) and math.isnan(value):
            return 'nan'
        if isinstance(value, dict):
            return {k: canonical(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [canonical(v) for v in value]
        return value
    assert canonical(a[0]) == canonical(b[0])
    assert a[1] == b[1]
    assert canonical(a[2]) == canonical(b[2])
    assert len(a[2]['estimates']) == len(a[0]['experiments'])


def _compare(bag, tmp_path, monkeypatch, *, experiments, **parameters):
    alone = _replay(bag, tmp_path / 'alone', batch=1, monkeypatch=monkeypatch, **parameters)
    together = _replay(bag, tmp_path / 'together', batch=64, monkeypatch=monkeypatch,
                       **parameters)
    small = _replay(bag, tmp_path / 'small', batch=3, monkeypatch=monkeypatch, **parameters)
    assert len(alone[0]['experiments']) == experiments
    assert alone[3] == experiments  # every estimate computed alone
    assert together[3] < experiments // 2  # most estimates prepared in batches (else the
    assert small[3] < experiments        # comparison proves nothing)
    _same(alone, together)
    _same(alone, small)
    return alone


def test_simulated_bag(tmp_path, monkeypatch):
    """The simulator's accelerated wear scenario: same experiments, estimates and alarm."""
    scenario = simulate_scenario(config=accelerated_wear_scenario(n_experiments=24, seed=4),
                                 seed=4)
    bag = tmp_path / 'scenario'
    write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort)
    alone = _compare(bag, tmp_path, monkeypatch, experiments=24, joint='joint_2',
                     gear_ratio=150.0, torque_scale=10.0)
    assert alone[0]['first_alarm'] is not None  # the alarm path is compared too


@pytest.mark.parametrize('imperfections,storage,files', [
    ({'rate_hz': 100.0, 'shuffle_order': True, 'stamp_jitter_fraction': 0.1}, 'mcap', 1),
    ({'drop_fraction': 0.03, 'absent_fraction': 0.02, 'absent_joints': ('shoulder',),
      'interrupt_experiment': 5, 'interrupt_level': 1}, 'sqlite3', 2),
])
def test_foreign_recorder_bags(tmp_path, monkeypatch, imperfections, storage, files):
    """Another tool's multi-joint recordings, every joint monitored, imperfections included."""
    joints = ('shoulder', 'elbow', 'wrist_3')
    recording = fr.generate(schedule=list(joints) * 4, seed=7,
                            imperfections=fr.Imperfections(**imperfections))
    bag = fr.write_bag(recording, tmp_path / 'bag', storage=storage, split_files=files)
    config = tmp_path / 'joints.yaml'
    lines = ['friction_experiment_node:', '  ros__parameters:']
    for joint in joints:
        spec = recording.joints[joint]
        lines += [f'    {joint}.gear_ratio: {spec.gear_ratio}',
                  f'    {joint}.torque_scale: {spec.torque_scale}']
    config.write_text('\n'.join(lines) + '\n')
    experiment, estimator = replay_parameters(config_file=config, joints=list(joints))
    del experiment, estimator  # the config is valid (raises otherwise)
    _compare(bag, tmp_path, monkeypatch, experiments=len(recording.experiments),
             config_file=config, joints=list(joints))
