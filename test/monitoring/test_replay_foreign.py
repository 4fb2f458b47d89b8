"""
Replay of foreign recordings through the CLI, against the independent generator's truth.

Issue 8: recordings made by another tool on another arm
(``test/wear_testing/foreign_recordings.py``: its own trajectory, noise, protocol and bag
writing).  Replay runs with no configuration other than the
joint names, gear ratios and torque scales (per joint in a small node-config YAML when several
joints differ), so the speeds and experiments are discovered in the data.  Every figure asserted
here comes from the generator's truth: the experiments (count, speeds, friction levels), the
samples and rejections per reason, the first alarm against the true wear, the per-joint outputs.

Tolerance of the friction levels.  The generator's torque noise is white, std
``torque_noise_std`` (normalised) per sample, and the truth level tau_f already contains the
level offset, so a level of eq. (3) (the mean of the forward and backward plateaus) misses the
truth by the noise of the plateau means only: std = torque_noise_std / sqrt(2 n) with n samples
per plateau.  n is bounded below by half the plateau (trimming, the speed band at the plateau
ends) at the recorded rate, less the dropped messages; the tolerance is six such std.
"""

import contextlib
import io
import json
import math
from pathlib import Path
import sqlite3

import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.recordings.bags import TYPESTORE
from rosbags.rosbag2 import Reader
from wear_testing import foreign_recordings as fr

#: Speeds found must be within this of the truth [rad/s] (motor side).
SPEED_TOLERANCE_RAD_S = 0.05
#: The default alarm rule: P(w >= WEAR_THRESHOLD) of the trend reaches 0.15.
WEAR_THRESHOLD = 35.0


# --------------------------------------------------------------------------- helpers

def run_cli(argv):
    """Run ``robot-wear-monitor`` in-process; return (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def joint_config(path, recording, joints, **extra):
    """
    Write a node config giving each joint its generator gear ratio and torque scale.

    ``extra``: joint -> further per-joint parameters of friction_experiment_node.
    """
    lines = ['friction_experiment_node:', '  ros__parameters:']
    for name in joints:
        spec = recording.joints[name]
        values = {'gear_ratio': float(spec.gear_ratio), 'torque_scale': float(spec.torque_scale)}
        values.update(extra.get(name, {}))
        lines.append(f'    {name}: {json.dumps(values)}')
    Path(path).write_text('\n'.join(lines) + '\n', encoding='utf-8')
    return path


def friction_tolerance(recording):
    """Return the tolerance of a friction level against the truth (see the module docstring)."""
    protocol, imperfections = recording.protocol, recording.imperfections
    samples = 0.5 * protocol.plateau_s * imperfections.rate_hz * (
        1.0 - imperfections.drop_fraction)
    return 6.0 * protocol.torque_noise_std / math.sqrt(2.0 * samples)


def expected_bumps(recording, joint):
    """
    Return the repositioning bumps of ``joint``: moves without a constant-speed plateau.

    A bump precedes each level whose start ``a`` differs from where the joint is; after a
    complete level the joint is back at ``a``, after an interrupted one at the end of its cut
    forward pass.
    """
    spec = recording.joints[joint]
    ramp = recording.protocol.ramp_s
    here = spec.posture_rad
    bumps = 0
    for experiment in recording.experiments_of(joint):
        for level in experiment.levels:
            u = level.speed_rad_s / spec.gear_ratio
            start = level.window_rad[0] - 0.5 * u * ramp
            bumps += abs(start - here) > 1e-9
            here = start if level.complete else level.window_rad[1] + 0.5 * u * ramp
    return bumps


def match_experiments(recording, joint, experiments):
    """Return the truth experiment of each replayed experiment of ``joint`` (by its stamp)."""
    matched = []
    for found in experiments:
        assert found['joint'] == joint
        inside = [e for e in recording.experiments_of(joint)
                  if e.start_s <= found['stamp_s'] <= e.end_s + 1e-6]
        assert len(inside) == 1, (joint, found['index'], found['stamp_s'])
        matched.append(inside[0])
    return matched


def check_experiments(recording, joint, summary):
    """Assert the replayed experiments of ``joint`` are the truth's: count, speeds, levels."""
    found = [e for e in summary['experiments'] if e['joint'] == joint]
    truth = recording.experiments_of(joint)
    assert len(found) == len(truth), joint
    matched = match_experiments(recording, joint, found)
    assert [e.joint_experiment for e in matched] == list(range(len(truth)))
    tolerance = friction_tolerance(recording)
    for entry, experiment in zip(found, matched):
        levels = experiment.complete_levels
        assert len(entry['speeds_rad_s']) == len(entry['frictions']) == len(levels)
        order = np.argsort(entry['speeds_rad_s'])
        expected = sorted(levels, key=lambda level: level.speed_rad_s)
        for k, level in zip(order, expected):
            assert abs(entry['speeds_rad_s'][k] - level.speed_rad_s) <= SPEED_TOLERANCE_RAD_S
            assert abs(entry['frictions'][k] - level.tau_f) <= tolerance, (joint, level)
    return found, matched


def joint_entry(summary, joint):
    """Return the summary's per-joint entry of ``joint``."""
    entries = [entry for entry in summary['joints'] if entry['joint'] == joint]
    assert len(entries) == 1, joint
    return entries[0]


def check_joint_figures(recording, joint, entry):
    """Assert the per-joint figures: samples, rejections by reason, passes, levels per speed."""
    truth = recording.experiments_of(joint)
    assert entry['samples'] == recording.expected_samples(joint)['time_s'].size
    interrupted = sum(e.interrupted for e in truth)
    bumps = expected_bumps(recording, joint)
    expected = {f'reader_{reason}': count
                for reason, count in recording.expected_rejections(joint).items()}
    if bumps:
        expected['pass_too_short'] = bumps
    if interrupted:
        expected['pass_unpaired'] = interrupted   # the broken forward pass
    assert entry['rejected'] == expected, joint
    levels = [level for e in truth for level in e.complete_levels]
    assert entry['levels'] == len(levels)
    # constant-speed passes: both of each complete level, and the broken one
    assert entry['passes'] == 2 * len(levels) + interrupted
    per_speed = {}
    for level in levels:
        key = f'{level.speed_rad_s:g}'
        per_speed[key] = per_speed.get(key, 0) + 1
    # the report bins the measured speeds to 0.1 rad/s: a truth speed near a bin edge may
    # show as two neighbouring keys (see test_levels_per_speed_has_one_key_per_speed), so
    # the counts of the keys within 0.1 rad/s of each truth speed are summed
    found = {float(k): v for k, v in entry['levels_per_speed_rad_s'].items()}
    for speed, count in found.items():
        assert sum(abs(float(k) - speed) <= 0.1 for k in per_speed) == 1, (joint, speed)
    for key, count in per_speed.items():
        near = sum(v for k, v in found.items() if abs(k - float(key)) <= 0.1)
        assert near == count, (joint, key, found)
    assert entry['levels_at_other_speeds_rad_s'] == {}
    assert entry['speeds_configured_rad_s'] == []
    assert entry['experiments'] == len(truth) and entry['experiments_abandoned'] == 0
    assert entry['no_experiment'] is None


# --------------------------------------------------------------------------- point 5

#: Each item of issue 8 point 5: (generator imperfections, joint, window drift, storage,
#: files).  Three experiments of one joint each.
CASES = {
    'rate_100hz_jitter_drops': ({'rate_hz': 100.0, 'stamp_jitter_fraction': 0.2,
                                 'drop_fraction': 0.03}, 'shoulder', 0.0, 'mcap', 1),
    'rate_1khz_jitter_drops': ({'rate_hz': 1000.0, 'stamp_jitter_fraction': 0.2,
                                'drop_fraction': 0.03}, 'shoulder', 0.0, 'mcap', 1),
    'joint_order_shuffled': ({'shuffle_order': True}, 'shoulder', 0.0, 'mcap', 1),
    'joints_absent': ({'shuffle_order': True, 'absent_fraction': 0.03}, 'shoulder', 0.0,
                      'mcap', 1),
    'effort_empty': ({'effort_empty_fraction': 0.03}, 'shoulder', 0.0, 'mcap', 1),
    'direct_drive': ({}, 'wrist_3', 0.0, 'mcap', 1),
    'window_drift': ({}, 'shoulder', 0.05, 'mcap', 1),
    'interrupted': ({'interrupt_experiment': 1, 'interrupt_level': 1}, 'shoulder', 0.0,
                    'mcap', 1),
    'sqlite3': ({'shuffle_order': True}, 'elbow', 0.0, 'sqlite3', 1),
    'mcap_split': ({}, 'shoulder', 0.0, 'mcap', 3),
    'sqlite3_split': ({}, 'shoulder', 0.0, 'sqlite3', 2),
    'zero_stamps_all': ({'zero_stamp_fraction': 1.0}, 'shoulder', 0.0, 'mcap', 1),
    'zero_stamps_some': ({'zero_stamp_fraction': 0.1, 'stamp_jitter_fraction': 0.1},
                         'shoulder', 0.0, 'mcap', 1),
}


class Replayed:
    """One generated recording, its bag and what the CLI replay of it returned."""

    def __init__(self, folder, name, recording, bag, code, stdout, stderr, summary, out):
        """Keep the pieces of one replay."""
        self.folder, self.name, self.recording, self.bag = folder, name, recording, bag
        self.code, self.stdout, self.stderr = code, stdout, stderr
        self.summary, self.out = summary, out


@pytest.fixture(scope='module')
def point5(tmp_path_factory):
    """Return case name -> :class:`Replayed`, generated and replayed once per module."""
    cache = {}

    def get(name):
        if name not in cache:
            imperfections, joint, drift, storage, files = CASES[name]
            folder = tmp_path_factory.mktemp(name)
            recording = fr.generate(schedule=[joint] * 3, seed=2, window_drift_rad=drift,
                                    imperfections=fr.Imperfections(**imperfections))
            bag = fr.write_bag(recording, folder / 'bag', storage=storage, split_files=files)
            spec = recording.joints[joint]
            out = folder / 'out'
            code, stdout, stderr = run_cli([
                'replay', bag, '--out', out, '--json-out', folder / 'summary.json',
                '--joint', joint, '--gear-ratio', spec.gear_ratio,
                '--torque-scale', spec.torque_scale, '--no-progress'])
            summary = (json.loads((folder / 'summary.json').read_text())
                       if code == 0 else None)
            cache[name] = Replayed(folder, name, recording, bag, code, stdout, stderr,
                                   summary, out)
        return cache[name]
    return get


@pytest.mark.parametrize('name', list(CASES))
def test_point5_experiments_and_rejections_match_the_truth(point5, name):
    """Each real-recording item: the truth's experiments, levels and rejections, no config."""
    run = point5(name)
    assert run.code == 0, run.stderr
    recording, summary = run.recording, run.summary
    joint = CASES[name][1]
    assert summary['joint_state_messages'] == len(recording)
    check_experiments(recording, joint, summary)
    entry = joint_entry(summary, joint)
    check_joint_figures(recording, joint, entry)
    assert [e['joint'] for e in summary['joints']] == [joint]
    # the replay-wide rejections are the joint's, with the segmentation's prefixed
    expected = {(k[len('reader_'):] if k.startswith('reader_') else f'segmentation_{k}'): v
                for k, v in entry['rejected'].items()}
    assert summary['rejections'] == expected
    assert f'{len(recording.experiments)} experiments from {len(recording)} messages' \
        in run.stdout
    assert run.out.is_dir()


def test_imperfections_are_really_in_the_recordings(point5):
    """The generator did make each imperfection (else the tests above prove nothing)."""
    for name in ('rate_100hz_jitter_drops', 'rate_1khz_jitter_drops'):
        recording = point5(name).recording
        period = 1.0 / recording.imperfections.rate_hz
        steps = np.diff(recording.true_time_s)
        assert recording.dropped > 0.02 * len(recording)
        assert np.std(steps[steps < 1.5 * period]) > 0.05 * period
    shuffled = point5('joint_order_shuffled').recording
    assert len({tuple(row) for row in shuffled.order[:300]}) > 100
    assert not all(point5('joints_absent').recording.present('shoulder'))
    assert point5('effort_empty').recording.effort_empty.any()
    assert point5('direct_drive').recording.joints['wrist_3'].gear_ratio == 1.0
    centres = [e.centre_rad for e in point5('window_drift').recording.experiments]
    assert np.allclose(np.diff(centres), 0.05)
    # drifted windows: consecutive experiments' windows at one speed do not coincide
    windows = [e.levels[0].window_rad for e in point5('window_drift').recording.experiments]
    assert windows[1][0] - windows[0][0] == pytest.approx(0.05)


def test_an_interrupted_experiment_keeps_its_complete_levels(point5):
    """The cut experiment is replayed with its complete level; the broken pass is counted."""
    run = point5('interrupted')
    recording = run.recording
    (broken,) = [e for e in recording.experiments if e.interrupted]
    assert [level.complete for level in broken.levels] == [True, False]
    found, matched = check_experiments(recording, 'shoulder', run.summary)
    (entry,) = [f for f, m in zip(found, matched) if m.interrupted]
    assert len(entry['speeds_rad_s']) == 1
    assert abs(entry['speeds_rad_s'][0] - broken.levels[0].speed_rad_s) <= SPEED_TOLERANCE_RAD_S
    assert joint_entry(run.summary, 'shoulder')['rejected']['pass_unpaired'] == 1
    # the experiment after the interruption is whole
    after = [f for f, m in zip(found, matched) if m.index == broken.index + 1]
    assert len(after) == 1 and len(after[0]['speeds_rad_s']) == 2


@pytest.mark.parametrize('name,suffix,files', [('sqlite3', '.db3', 1), ('mcap_split', '.mcap', 3),
                                               ('sqlite3_split', '.db3', 2)])
def test_storages_and_split_bags(point5, name, suffix, files):
    """The bags are of the storage and the number of files asked (and replayed above)."""
    run = point5(name)
    assert len(list(run.bag.glob('*' + suffix))) == files
    assert run.code == 0 and len(run.summary['experiments']) == len(run.recording.experiments)


@pytest.mark.parametrize('name', ['zero_stamps_all', 'zero_stamps_some'])
def test_zero_header_stamps_are_said_once(point5, name):
    """Zero header stamps: the receive time is used, and the note is given exactly once."""
    run = point5(name)
    zero = int(np.count_nonzero(run.recording.stamp_ns == 0))
    assert zero > 0
    assert len(run.summary['notes']) == 1
    note = run.summary['notes'][0]
    assert f'{zero} of {len(run.recording)}' in note and 'receive time' in note
    lines = [line for line in run.stderr.splitlines() if line.startswith('note:')]
    assert len(lines) == 1 and f'{zero} of {len(run.recording)}' in lines[0]
    assert run.stderr.count('zero header stamp') == 1
    clean = point5('joint_order_shuffled')
    assert clean.summary['notes'] == [] and 'note:' not in clean.stderr


def test_the_zero_stamp_note_names_the_bag_once(point5):
    """The note line on stderr names the bag once."""
    run = point5('zero_stamps_all')
    (line,) = [line for line in run.stderr.splitlines() if line.startswith('note:')]
    assert line.count(str(run.bag)) == 1, line


# --------------------------------------------------------------------------- several joints

#: Joints tested in turn, alternating; the wear ramps of default_joints() (shoulder 0 -> 60,
#: elbow 10 -> 70 cross the threshold; base_yaw 0 -> 30 does not).
MULTI_JOINTS = ('shoulder', 'elbow', 'wrist_3', 'base_yaw')
MULTI_RUNS = 6


@pytest.fixture(scope='module')
def arm(tmp_path_factory):
    """Return a multi-joint recording replayed with ``--joint all`` and a history file."""
    folder = tmp_path_factory.mktemp('arm')
    recording = fr.generate(schedule=list(MULTI_JOINTS) * MULTI_RUNS, seed=3,
                            imperfections=fr.Imperfections(rate_hz=100.0, shuffle_order=True,
                                                           stamp_jitter_fraction=0.1))
    bag = fr.write_bag(recording, folder / 'bag')
    config = joint_config(folder / 'joints.yaml', recording, recording.joint_names)
    out = folder / 'out'
    history = folder / 'history.sqlite'
    code, stdout, stderr = run_cli(['replay', bag, '--out', out, '--json-out', folder / 'all.json',
                                    '--joint', 'all', '--config', config, '--history', history,
                                    '--no-progress'])
    assert code == 0, stderr
    summary = json.loads((folder / 'all.json').read_text())
    return Replayed(folder, 'all', recording, bag, code, stdout, stderr, summary, out), history


def read_bag_topics(path):
    """Return topic -> list of deserialised messages of an output bag."""
    topics = {}
    with Reader(path) as reader:
        for connection, _, raw in reader.messages():
            topics.setdefault(connection.topic, []).append(
                TYPESTORE.deserialize_cdr(raw, connection.msgtype))
    return topics


def test_all_joints_experiments_per_joint(arm):
    """``--joint all``: every joint reported; the tested ones give the truth's experiments."""
    run, _ = arm
    recording, summary = run.recording, run.summary
    assert sorted(e['joint'] for e in summary['joints']) == sorted(recording.joint_names)
    for joint in MULTI_JOINTS:
        check_experiments(recording, joint, summary)
        entry = joint_entry(summary, joint)
        check_joint_figures(recording, joint, entry)
        assert entry['estimates'] == MULTI_RUNS
    for joint in set(recording.joint_names) - set(MULTI_JOINTS):
        entry = joint_entry(summary, joint)
        assert entry['experiments'] == entry['levels'] == entry['passes'] == 0
        assert 'never moves' in entry['no_experiment'] and repr(joint) in entry['no_experiment']
    assert len(summary['experiments']) == len(recording.experiments)
    # in time, the experiments alternate between the joints as run
    chronological = sorted(summary['experiments'], key=lambda e: e['stamp_s'])
    assert [e['joint'] for e in chronological] == [e.joint for e in recording.experiments]
    for joint in MULTI_JOINTS:
        assert f'  {joint}: ' in run.stdout


def test_the_alarm_comes_at_the_right_experiment_per_joint(arm):
    """
    The first alarm of each joint is within one experiment of its true crossing of 35.

    The wear of a joint steps by (wear_end - wear_start) / (MULTI_RUNS - 1) (12 for the
    shoulder and elbow) per experiment; the trend rule fires when P(w >= 35) reaches 0.15,
    i.e. up to about one interval half-width (~10 here) before the estimate crosses, and one
    experiment late at most when the crossing experiment's true wear is just above 35.
    """
    run, _ = arm
    recording, summary = run.recording, run.summary
    for joint in ('shoulder', 'elbow', 'base_yaw'):
        found = [e for e in summary['experiments'] if e['joint'] == joint]
        matched = match_experiments(recording, joint, found)
        raised = [m.joint_experiment for f, m in zip(found, matched) if f['alarm_raised']]
        over = recording.first_experiment_over(joint, WEAR_THRESHOLD)
        entry = joint_entry(summary, joint)
        if over is None:   # base_yaw: its true wear never reaches the threshold
            assert raised == [] and entry['first_alarm'] is None, joint
            continue
        assert len(raised) == 1, (joint, raised)
        assert abs(raised[0] - over.joint_experiment) <= 1, (joint, raised, over)
        first = next(f for f in found if f['alarm_raised'])
        assert entry['first_alarm']['index'] == first['index']
        assert entry['first_alarm']['stamp_s'] == first['stamp_s']
        # once raised, the alarm stays active
        active = [f['alarm'] for f in found]
        assert active == [k >= found.index(first) for k in range(len(found))]
    raised = [(e['stamp_s'], e['index'], e['joint']) for e in summary['experiments']
              if e['alarm_raised']]
    assert summary['first_alarm'] is not None
    assert (summary['first_alarm']['stamp_s'], summary['first_alarm']['index']) in \
        [(stamp, index) for stamp, index, _ in raised]


def test_the_summary_first_alarm_is_the_earliest_in_time(arm):
    """With several joints, the summary's first alarm is the earliest alarm raised."""
    run, _ = arm
    summary = run.summary
    raised = sorted((e['stamp_s'], e['joint'], e['index']) for e in summary['experiments']
                    if e['alarm_raised'])
    assert len({joint for _, joint, _ in raised}) >= 2
    assert summary['first_alarm']['stamp_s'] == raised[0][0], raised


def test_all_joints_output_bag_has_per_joint_topics(arm):
    """Outputs per joint under /<joint>/...; friction_levels one topic, frame_id = joint."""
    run, _ = arm
    recording = run.recording
    topics = read_bag_topics(run.out)
    for joint in MULTI_JOINTS:
        runs = len(recording.experiments_of(joint))
        for base in ('wear', 'temperature', 'wear_alarm', 'wear_trend'):
            assert len(topics[f'/{joint}/{base}']) == runs, (joint, base)
    for joint in set(recording.joint_names) - set(MULTI_JOINTS):
        assert not any(topic.startswith(f'/{joint}/') for topic in topics)
    assert '/wear' not in topics
    levels = topics['/friction_levels']
    assert [m.header.frame_id for m in levels] == [e.joint for e in recording.experiments]
    tolerance = friction_tolerance(recording)
    for message, experiment in zip(levels, recording.experiments):
        truth = sorted(experiment.complete_levels, key=lambda level: level.speed_rad_s)
        assert len(message.effort) == len(truth)
        order = np.argsort(np.abs(message.velocity))
        for k, level in zip(order, truth):
            assert abs(abs(message.velocity[k]) - level.speed_rad_s) <= SPEED_TOLERANCE_RAD_S
            assert abs(abs(message.effort[k]) - level.tau_f) <= tolerance
    assert len(topics['/diagnostics']) == len(recording.experiments)


def test_history_rows_are_keyed_by_joint(arm):
    """``--history``: one row per estimate, keyed by joint, at the experiment's stamp."""
    run, history = arm
    recording, summary = run.recording, run.summary
    with contextlib.closing(sqlite3.connect(history)) as db:
        rows = db.execute('SELECT joint, stamp_s, wear FROM estimates ORDER BY stamp_s'
                          ).fetchall()
    assert [r[0] for r in rows] == [e.joint for e in recording.experiments]
    for joint in MULTI_JOINTS:
        mine = [r for r in rows if r[0] == joint]
        found = sorted((e for e in summary['experiments'] if e['joint'] == joint),
                       key=lambda e: e['stamp_s'])
        assert len(mine) == len(recording.experiments_of(joint))
        assert [r[1] for r in mine] == pytest.approx([e['stamp_s'] for e in found])
        assert [r[2] for r in mine] == pytest.approx([e['wear'] for e in found])


def test_an_explicit_joint_list_monitors_those_joints_only(arm):
    """``--joint shoulder wrist_3``: those two joints, their topics, the same results."""
    run, _ = arm
    recording = run.recording
    folder = run.folder
    chosen = ['shoulder', 'wrist_3']
    config = joint_config(folder / 'two.yaml', recording, chosen)
    code, stdout, stderr = run_cli(['replay', run.bag, '--out', folder / 'two',
                                    '--json-out', folder / 'two.json', '--joint', ','.join(chosen),
                                    '--config', config, '--no-progress'])
    assert code == 0, stderr
    summary = json.loads((folder / 'two.json').read_text())
    assert sorted(e['joint'] for e in summary['joints']) == sorted(chosen)
    for joint in chosen:
        check_experiments(recording, joint, summary)
        check_joint_figures(recording, joint, joint_entry(summary, joint))
        mine = [e for e in summary['experiments'] if e['joint'] == joint]
        everything = [e for e in run.summary['experiments'] if e['joint'] == joint]
        assert [e['frictions'] for e in mine] == [e['frictions'] for e in everything]
        assert [e['alarm_raised'] for e in mine] == [e['alarm_raised'] for e in everything]
    assert len(summary['experiments']) == sum(len(recording.experiments_of(j)) for j in chosen)
    topics = read_bag_topics(folder / 'two')
    assert {t.split('/')[1] for t in topics if t.count('/') == 2} == set(chosen)
    assert [m.header.frame_id for m in topics['/friction_levels']] == \
        [e.joint for e in recording.experiments if e.joint in chosen]


def test_levels_per_speed_has_one_key_per_speed(arm):
    """Each speed run gets one key in levels_per_speed_rad_s, with all its levels."""
    run, _ = arm
    recording = run.recording
    for joint in MULTI_JOINTS:
        entry = joint_entry(run.summary, joint)
        speeds = recording.joints[joint].speeds_rad_s
        assert len(entry['levels_per_speed_rad_s']) == len(speeds), entry
        assert sorted(entry['levels_per_speed_rad_s'].values()) == \
            [len(recording.experiments_of(joint))] * len(speeds)


# --------------------------------------------------------------------------- exit 2

def _refused(tmp_path, bag, *options):
    out = tmp_path / 'out'
    code, stdout, stderr = run_cli(['replay', bag, '--out', out, '--json-out',
                                    tmp_path / 'summary.json', '--no-progress', *options])
    assert code == 2
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert not out.exists() and not (tmp_path / 'summary.json').exists()
    assert not list(tmp_path.glob('out*'))
    return lines[0]


def test_a_joint_that_never_moves_exits_2(tmp_path):
    """A bag in which nothing moves: exit 2, one sentence, no output bag."""
    still = fr.generate(schedule=[], hold_s=5.0)
    assert not np.any(still.velocity_rad_s)
    bag = fr.write_bag(still, tmp_path / 'still')
    line = _refused(tmp_path, bag, '--joint', 'shoulder', '--gear-ratio', 120,
                    '--torque-scale', 2000)
    assert line.startswith('robot-wear-monitor replay: error: no friction experiment')
    assert "joint 'shoulder' never moves" in line


def test_a_wrong_joint_name_exits_2_and_lists_the_joints_seen(tmp_path):
    """A joint name not in the recording: exit 2 and the names that are there."""
    recording = fr.generate(schedule=['shoulder'], seed=5,
                            imperfections=fr.Imperfections(rate_hz=100.0))
    bag = fr.write_bag(recording, tmp_path / 'bag')
    line = _refused(tmp_path, bag, '--joint', 'joint_2', '--gear-ratio', 120,
                    '--torque-scale', 2000)
    assert "'joint_2'" in line
    assert 'joints seen: ' + ', '.join(recording.joint_names) in line


def test_a_bag_without_joint_states_exits_2(tmp_path):
    """A bag whose JointState topic is not /joint_states: exit 2, the topics listed."""
    recording = fr.generate(schedule=['shoulder'], seed=6,
                            imperfections=fr.Imperfections(rate_hz=100.0))
    bag = fr.write_bag(recording, tmp_path / 'bag', topic='/arm/joint_states')
    line = _refused(tmp_path, bag, '--joint', 'shoulder', '--gear-ratio', 120,
                    '--torque-scale', 2000)
    assert '/joint_states' in line and '/arm/joint_states' in line


# --------------------------------------------------------------------------- speed filter

def test_configured_speeds_filter_and_report_the_others(point5, tmp_path):
    """experiment_speeds_rad_s of one speed: the other speed's levels counted, not dropped."""
    source = point5('joint_order_shuffled')
    recording = source.recording
    spec = recording.joints['shoulder']
    kept, other = spec.speeds_rad_s
    config = joint_config(tmp_path / 'filter.yaml', recording, ['shoulder'],
                          shoulder={'experiment_speeds_rad_s': [kept]})
    code, stdout, stderr = run_cli(['replay', source.bag, '--out', tmp_path / 'out', '--json-out',
                                    tmp_path / 'summary.json', '--joint', 'shoulder',
                                    '--config', config, '--no-progress'])
    assert code == 0, stderr
    summary = json.loads((tmp_path / 'summary.json').read_text())
    entry = joint_entry(summary, 'shoulder')
    truth = recording.experiments_of('shoulder')
    at_other = sum(1 for e in truth for level in e.complete_levels
                   if level.speed_rad_s == other)
    at_kept = sum(1 for e in truth for level in e.complete_levels
                  if level.speed_rad_s == kept)
    assert at_other > 0
    assert entry['speeds_configured_rad_s'] == [kept]
    (speed, count), = entry['levels_at_other_speeds_rad_s'].items()
    assert abs(float(speed) - other) <= 0.1 and count == at_other
    assert entry['experiments'] == len(truth)
    found = summary['experiments']
    assert len(found) == len(truth)
    tolerance = friction_tolerance(recording)
    for experiment, matched in zip(found, match_experiments(recording, 'shoulder', found)):
        (level,) = [lv for lv in matched.complete_levels if lv.speed_rad_s == kept]
        assert len(experiment['speeds_rad_s']) == 1
        assert abs(experiment['speeds_rad_s'][0] - kept) <= SPEED_TOLERANCE_RAD_S
        assert abs(experiment['frictions'][0] - level.tau_f) <= tolerance
    # every level is found and counted; the filter only decides which form experiments
    assert entry['levels'] == sum(entry['levels_per_speed_rad_s'].values()) == \
        at_kept + at_other
