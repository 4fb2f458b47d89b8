"""
The package against an independent robot: its own trajectories, noise, friction and bags.

``independent_robot`` shares no code with ``robot_wear_monitor.simulation``/``model``; its
recordings carry the truth (wear, temperature, load, the friction actually applied), so these
tests check the replay CLI, the bag reader, the segmentation and the estimator end to end.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from robot_wear_monitor.experiment.segmentation import (segment_batch, SegmenterConfig,
                                                        StreamingSegmenter)
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores
from wear_testing import independent_robot as robot
from wear_testing.paths import REPO_ROOT

SEED = 0
N_EXPERIMENTS = 8
SPEEDS = robot.TABLE_V_SPEEDS_RAD_S
#: The segmentation settings of config/wear_monitor.yaml (friction_experiment_node).
NODE_SEGMENTER = {'joint': 'joint_2', 'gear_ratio': 150.0, 'torque_scale': 10.0,
                  'standstill_speed_rad_s': 0.1, 'speed_tolerance_fraction': 0.05,
                  'speed_tolerance_rad_s': 0.05, 'min_duration_s': 0.2, 'trim_s': 0.02,
                  'min_samples': 20, 'min_window_rad': 0.0, 'max_gap_s': 0.1}
#: |w-hat - w| allowed where w >= 20: about 3x the scatter of w-hat seen there over 30 seeds
#: (std 4-7 per experiment, N = 4 speeds, model error sigma of (9b) per level).
WEAR_TOLERANCE = 15.0
#: |measured - applied friction|: the levels' standard errors are about 2e-4 here.
FRICTION_TOLERANCE = 2.0e-3


@pytest.fixture(scope='module')
def recording():
    return robot.generate_wear_test(n_experiments=N_EXPERIMENTS, wear_start=0.0, wear_end=60.0,
                                    seed=SEED)


@pytest.fixture(scope='module')
def replayed(recording, tmp_path_factory):
    """Write the recording as an MCAP bag and replay it with the command line, as a user."""
    folder = tmp_path_factory.mktemp('independent')
    bag = robot.write_bag(folder / 'recorded', recording)
    out, summary = folder / 'monitored', folder / 'summary.json'
    # ``robot-wear-monitor`` is robot_wear_monitor.cli:main; -m runs this checkout's code
    # rather than a possibly older installed copy.
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(REPO_ROOT)] + [p for p in [os.environ.get('PYTHONPATH')] if p]))
    result = subprocess.run(
        [sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bag), '--out', str(out),
         '--json-out', str(summary)],
        cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    return bag, out, json.loads(summary.read_text()), result.stdout


def test_generator_protocol_and_truth(recording):
    n = len(recording)
    assert recording.names == tuple(f'joint_{i}' for i in range(1, 7))
    assert recording.position.shape == recording.velocity.shape == recording.effort.shape \
        == (n, 6)
    assert recording.stamps_s[0] == pytest.approx(1_700_000_000.0)
    assert np.all(np.diff(recording.stamps_ns) == 1_000_000)
    assert [t.index for t in recording.truth] == list(range(N_EXPERIMENTS))
    wears = [t.wear for t in recording.truth]
    assert wears[0] == 0.0 and wears[-1] == 60.0 and np.all(np.diff(wears) > 0)
    assert all(30.0 <= t.temperature_degc <= 50.0 for t in recording.truth)
    assert all(0.2 <= t.load <= 0.8 for t in recording.truth)
    assert all(a.end_s < b.start_s for a, b in zip(recording.truth, recording.truth[1:]))
    # The monitored joint moves at exactly the commanded speeds (motor side) and nowhere faster
    # than the repositioning; the other joints hold their posture.
    joint = recording.joint_index
    motor = np.abs(recording.velocity[:, joint]) * recording.gear_ratio
    for speed in SPEEDS:
        assert np.count_nonzero(np.abs(motor - speed) < 0.01) > 2 * 250 * N_EXPERIMENTS
    others = np.delete(np.arange(6), joint)
    assert np.ptp(recording.position[:, others], axis=0).max() < 1e-3
    # Friction model (8) of PARAMETERS.md: a new joint at 40 degC, tau_l = 0.5 (hand-computed).
    assert robot.friction_model(35.1, 0.5, 40.0, 0.0) == pytest.approx(0.05557, abs=2e-5)
    assert robot.wear_friction(35.1, 35.0) == pytest.approx(0.02171, abs=2e-5)


def test_replay_cli_estimates_the_true_wear_and_alarms_near_35(recording, replayed):
    bag, out, summary, stdout = replayed
    truth = recording.truth
    assert f'{N_EXPERIMENTS} experiments from {len(recording)} messages' in stdout
    assert (out / 'metadata.yaml').is_file()
    assert summary['joint'] == 'joint_2'
    assert summary['joint_state_messages'] == summary['samples'] == len(recording)
    experiments = summary['experiments']
    assert len(experiments) == N_EXPERIMENTS
    errors = []
    for entry, true in zip(experiments, truth):
        # Each estimate belongs to the experiment it came from (stamped at its last sample).
        assert true.start_s <= entry['stamp_s'] <= true.end_s
        assert np.allclose(entry['speeds_rad_s'], SPEEDS, atol=0.5)
        frictions = np.array(entry['frictions'])
        assert np.abs(frictions - true.friction_true).max() < FRICTION_TOLERANCE
        assert np.abs(frictions - true.friction_model).max() < 4 * robot.SIGMA_9B
        if true.wear >= 20.0:
            errors.append(entry['wear'] - true.wear)
            assert abs(entry['wear'] - true.wear) < WEAR_TOLERANCE, (entry, true)
        else:
            assert entry['wear'] < 30.0, (entry, true)
    assert abs(np.mean(errors)) < 6.0, errors
    # The alarm (default rule 'trend'): raised by the first experiment whose wear trend gives
    # P(w >= 35) >= 0.15, when the true wear is near 35, never while it is below 25; latched.
    probability = [entry['trend']['probability_above_threshold'] for entry in experiments]
    first = next(i for i, p in enumerate(probability) if p >= 0.15)
    assert summary['first_alarm'] is not None
    assert summary['first_alarm']['index'] == experiments[first]['index']
    assert summary['first_alarm']['wear'] == pytest.approx(experiments[first]['wear'])
    assert 25.0 <= truth[first].wear <= 52.0
    assert all(p < 0.15 for p, true in zip(probability, truth) if true.wear < 25.0)
    assert [entry['alarm'] for entry in experiments] == \
        [False] * first + [True] * (N_EXPERIMENTS - first)


def test_segmentation_batch_and_streaming_agree_with_the_truth(recording):
    config = SegmenterConfig(**NODE_SEGMENTER)
    joint = recording.joint_index
    batch = segment_batch(time_s=recording.stamps_s, position_rad=recording.position[:, joint],
                          velocity_rad_s=recording.velocity[:, joint],
                          effort=recording.effort[:, joint], config=config)
    streaming = StreamingSegmenter(config)
    levels = []
    for stamp, names, position, velocity, effort in robot.messages(recording):
        levels += streaming.add_joint_state(stamp_s=stamp, name=names, position=position,
                                            velocity=velocity, effort=effort)
    levels += streaming.finish()
    assert levels == batch.levels
    assert not batch.rejections and not streaming.rejections
    assert len(levels) == N_EXPERIMENTS * len(SPEEDS)
    applied = np.array([true.friction_true for true in recording.truth]).ravel()
    for i, level in enumerate(levels):
        true = recording.truth[i // len(SPEEDS)]
        assert level.speed_rad_s == pytest.approx(SPEEDS[i % len(SPEEDS)], abs=0.5)
        assert true.start_s <= level.start_time_s < level.end_time_s <= true.end_s
        # The pair's window is centred where the passes were, gravity and ramps are gone, and
        # the reported standard error is honest.
        centre = 0.5 * (level.position_min_rad + level.position_max_rad)
        assert centre == pytest.approx(recording.centre_rad, abs=1e-3)
        assert min(level.n_forward, level.n_backward) >= 250
        assert abs(level.friction - applied[i]) < 5 * level.friction_std_error
        assert level.friction_std_error < 5e-4


def test_bag_has_joint_states_stamped_at_the_sample_times(recording, replayed):
    bag = replayed[0]
    typestore = get_typestore(Stores.ROS2_JAZZY)
    with Reader(bag) as reader:
        assert [(c.topic, c.msgtype) for c in reader.connections] == \
            [('/joint_states', 'sensor_msgs/msg/JointState')]
        assert reader.message_count == len(recording)
        for i, (connection, timestamp, raw) in enumerate(reader.messages()):
            if i == 3:
                break
            msg = typestore.deserialize_cdr(raw, connection.msgtype)
            assert timestamp == recording.stamps_ns[i]
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == timestamp
            assert list(msg.name) == list(recording.names)
            assert np.array_equal(msg.effort, recording.effort[i])
