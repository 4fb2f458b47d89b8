"""
The KUKA iiwa raw runs as one MCAP bag of all 7 joints: the same passes as the raw runs.

``bench/kuka_to_bag.py`` lays the 80 raw runs on one time line in one bag; each joint's stream
of that bag, read with :func:`iter_joint_chunks` and segmented with the same
``raw_run_segmenter_config`` as the raw-run path, must give the levels of the raw runs of that
joint, run after run.

The conversion shifts each run's time axis by a whole number of nanoseconds (``offset_ns``) to
put the runs one after the other.  At absolute times (~1.5e9 s) float seconds are rounded to
~0.24 us, and the 200 Hz samples fall exactly on the segmenter's trim threshold (0.02 s = 4
samples), so which sample a tie keeps depends on the rounding of the time axis.  The exact
comparison (same passes, same sample counts, tau_f within 1e-9) holds against the raw runs on
the bag's time axis (``t_s`` + offset, the only change the conversion makes) and, since the
segmenter's time comparisons allow 1 us, against the raw runs on their own time axis too.
The replay/segment path (discovery, every joint, chunks) gives the same levels.
Skipped when ../shared/data is absent.
"""

import importlib.util
from pathlib import Path
import shutil
import sys

import numpy as np
import pytest
from robot_wear_monitor.experiment.segmentation import segment_batch
from robot_wear_monitor.experiment.segmentation_settings import raw_run_segmenter_config
from robot_wear_monitor.recordings.bags import iter_joint_chunks, JOINT_STATE_TYPE, TYPESTORE
from robot_wear_monitor.recordings.tables import list_kuka_runs, read_kuka_run
from wear_testing.paths import REPO_ROOT

FIELDS = ('time_s', 'position_rad', 'velocity_rad_s', 'effort')


def _script():
    spec = importlib.util.spec_from_file_location('kuka_to_bag',
                                                  REPO_ROOT / 'bench' / 'kuka_to_bag.py')
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope='module')
def converted(kuka_dir, tmp_path_factory):
    script = _script()
    bag = tmp_path_factory.mktemp('kuka') / 'iiwa_friction'
    placed = script.convert(kuka_dir, bag)
    stream = iter_joint_chunks(bag)
    parts = {}
    for chunk in stream:
        for joint, samples in chunk.items():
            parts.setdefault(joint, []).append(samples)
    joints = {joint: {f: np.concatenate([getattr(p, f) for p in pieces]) for f in FIELDS}
              for joint, pieces in parts.items()}
    yield script, bag, placed, stream, joints
    shutil.rmtree(bag, ignore_errors=True)  # 0.5 GB


def _raw_levels(kuka_dir, run, offset_ns=None):
    data = read_kuka_run(kuka_dir / run.source)
    time_s = data.t_s
    if offset_ns is not None:  # the run's time axis in the bag
        sec, nanosec = np.divmod(offset_ns + np.round(data.t_s * 1e9).astype(np.int64),
                                 1_000_000_000)
        time_s = sec + nanosec * 1e-9
    return segment_batch(time_s=time_s, position_rad=data.q_rad, velocity_rad_s=data.dq_rad_s,
                         effort=data.tau_measured_Nm, config=raw_run_segmenter_config()).levels


def test_the_bag_holds_every_run_and_all_seven_joints(kuka_dir, converted):
    script, bag, placed, stream, joints = converted
    assert list(bag.glob('*.mcap')) and len(placed) == len(list_kuka_runs(kuka_dir))
    total = sum(p.messages for p in placed)
    assert stream.message_count == total == stream.total_messages
    assert stream.joints_seen == list(script.JOINT_NAMES)
    assert all(not stream.rejections[j] for j in script.JOINT_NAMES)
    assert script.placed_runs(bag) == placed
    held = script.held_positions(kuka_dir)
    for run in placed[::7]:
        data = read_kuka_run(kuka_dir / run.source)
        rows = slice(run.first_message, run.first_message + run.messages)
        tested = joints[run.joint]
        assert np.array_equal(tested['position_rad'][rows], data.q_rad)
        assert np.array_equal(tested['velocity_rad_s'][rows], data.dq_rad_s)
        assert np.array_equal(tested['effort'][rows], data.tau_measured_Nm)
        stamps = tested['time_s'][rows]
        assert np.max(np.abs(stamps - stamps[0] - (data.t_s - data.t_s[0]))) < 1e-6
        means = held[Path(run.source).name]
        for k, joint in enumerate(script.JOINT_NAMES):
            if joint != run.joint:  # held: the run's mean position, no velocity or torque
                assert np.all(joints[joint]['position_rad'][rows] == means[k])
                assert not np.any(joints[joint]['velocity_rad_s'][rows])
                assert not np.any(joints[joint]['effort'][rows])
    # an independent decoding of one message
    from rosbags.rosbag2 import Reader
    with Reader(bag) as reader:
        _, _, raw = next(reader.messages())
    message = TYPESTORE.deserialize_cdr(raw, JOINT_STATE_TYPE)
    assert list(message.name) == list(script.JOINT_NAMES)


def test_each_joint_of_the_bag_gives_the_passes_of_its_raw_runs(kuka_dir, converted):
    script, bag, placed, stream, joints = converted
    compared = 0
    for joint in script.JOINT_NAMES:
        found = segment_batch(**joints[joint], config=raw_run_segmenter_config(joint=joint)).levels
        runs = [run for run in placed if run.joint == joint]
        exact = [level for run in runs for level in _raw_levels(kuka_dir, run, run.offset_ns)]
        own = [level for run in runs for level in _raw_levels(kuka_dir, run)]
        assert len(found) == len(exact) == len(own) > 0, joint
        for ours, raw, unshifted in zip(found, exact, own):
            assert (ours.n_forward, ours.n_backward) == (raw.n_forward, raw.n_backward)
            assert ours.friction == pytest.approx(raw.friction, abs=1e-9)
            assert ours.speed_rad_s == pytest.approx(raw.speed_rad_s, abs=1e-9)
            assert ours.tau_forward == pytest.approx(raw.tau_forward, abs=1e-9)
            assert (ours.position_min_rad, ours.position_max_rad) == \
                (raw.position_min_rad, raw.position_max_rad)
            assert ours.start_time_s == pytest.approx(raw.start_time_s, abs=1e-6)
            # the raw runs on their own time axis: the same passes (the segmenter's time
            # comparisons allow 1 us, so a sample on a trim threshold falls on the same side)
            assert (ours.n_forward, ours.n_backward) == \
                (unshifted.n_forward, unshifted.n_backward)
            assert ours.friction == pytest.approx(unshifted.friction, abs=1e-9)
            assert ours.speed_rad_s == pytest.approx(unshifted.speed_rad_s, abs=1e-9)
            compared += 1
    assert compared == sum(
        len(_raw_levels(kuka_dir, run)) for run in placed) and compared > 500


def _kuka_node_config(path):
    """Write a node config: every joint, the raw-run segmenter settings, speeds discovered."""
    config = raw_run_segmenter_config()
    names = ('gear_ratio', 'torque_scale', 'standstill_speed_rad_s', 'speed_tolerance_fraction',
             'speed_tolerance_rad_s', 'min_duration_s', 'trim_s', 'min_samples',
             'min_window_rad', 'max_gap_s')
    lines = ['friction_experiment_node:', '  ros__parameters:', '    joints: [all]']
    for name in names:
        value = getattr(config, name)  # ROS 2 types: an integer, the others doubles
        lines.append(f'    {name}: {int(value) if name == "min_samples" else float(value)!r}')
    path.write_text('\n'.join(lines) + '\n')
    return path


def test_the_replay_path_with_discovery_gives_the_raw_run_levels(kuka_dir, converted,
                                                                 tmp_path):
    """Every joint, speeds found in the data, the bag read in chunks: the raw runs' levels."""
    from robot_wear_monitor.monitoring.joints import JointExperiments
    from robot_wear_monitor.monitoring.replay import replay_parameters
    script, bag, placed, _, _ = converted
    experiment, _ = replay_parameters(config_file=_kuka_node_config(tmp_path / 'kuka.yaml'))
    assert experiment['experiment_speeds_rad_s'] == ()
    experiments = JointExperiments(experiment)
    stream = iter_joint_chunks(bag, joints=experiments.selection, chunk_messages=5000)
    for chunk in stream:
        for joint, samples in chunk.items():
            experiments.service(joint).add_recording(
                time_s=samples.time_s, position_rad=samples.position_rad,
                velocity_rad_s=samples.velocity_rad_s, effort=samples.effort)
    experiments.finish()
    assert list(experiments.services) == list(script.JOINT_NAMES)
    for joint, service in experiments.services.items():
        raw = [level for run in placed if run.joint == joint
               for level in _raw_levels(kuka_dir, run)]
        assert len(service.levels) == len(raw) > 0, joint
        for ours, theirs in zip(service.levels, raw):
            assert (ours.n_forward, ours.n_backward) == (theirs.n_forward, theirs.n_backward)
            assert ours.friction == pytest.approx(theirs.friction, abs=1e-9)
            assert ours.speed_rad_s == pytest.approx(theirs.speed_rad_s, abs=1e-9)
        summary = service.summary()
        assert summary['levels'] == len(raw) and summary['experiments'] >= 1
        assert sum(summary['levels_per_speed_rad_s'].values()) == len(raw)


def test_segment_on_the_bag_writes_every_joints_levels(kuka_dir, converted, tmp_path, capsys):
    import csv

    from robot_wear_monitor import cli
    script, bag, placed, _, _ = converted
    out = tmp_path / 'levels.csv'
    code = cli.main(['segment', str(bag), '--joint', 'all', '--config',
                     str(_kuka_node_config(tmp_path / 'kuka.yaml')), '--out', str(out)])
    report = capsys.readouterr().err
    assert code == 0, report
    rows = list(csv.DictReader(out.open()))
    for joint in script.JOINT_NAMES:
        raw = [level for run in placed if run.joint == joint
               for level in _raw_levels(kuka_dir, run)]
        mine = [row for row in rows if row['joint'] == joint]
        assert len(mine) == len(raw)
        assert [float(r['friction']) for r in mine] == pytest.approx(
            [level.friction for level in raw], rel=1e-5, abs=1e-9)
        assert f'  {joint}: ' in report and f'{len(raw)} levels' in report
