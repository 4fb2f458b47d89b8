"""Segmentation of eq. (3): truth on simulated streams, streaming == batch, bad samples."""

from collections import Counter

import numpy as np
import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import FrictionLevel
from robot_wear_monitor.experiment.segmentation import (ExperimentAssembler, segment_batch,
                                                        SegmenterConfig, SpeedTally,
                                                        StreamingSegmenter)
from robot_wear_monitor.experiment.simulation import (JointSimConfig, PAPER_SPEEDS_RAD_S,
                                                      ScenarioConfig, segmenter_config_for,
                                                      simulate_scenario)


@pytest.fixture(scope='module')
def paper_grid():
    """One experiment over the whole eq. (27) grid, noise, gravity, quantisation on."""
    config = ScenarioConfig(speeds_rad_s=PAPER_SPEEDS_RAD_S, wear=(35.0,),
                            temperature_degc=(40.0,), load=(0.5,), level_error_std=0.005,
                            joint=JointSimConfig(shuffle_joint_order=True))
    return simulate_scenario(config=config, seed=3)


def _stream(scenario, segmenter):
    levels = []
    for stamp, name, position, velocity, effort in scenario.messages():
        levels += segmenter.add_joint_state(stamp_s=stamp, name=name, position=position,
                                            velocity=velocity, effort=effort)
    return levels + segmenter.finish()


def _stream_samples(config, t, q, v, e):
    """Return the streaming segmenter's levels of the samples, one by one, and the segmenter."""
    streaming = StreamingSegmenter(config)
    levels = []
    for sample in zip(t, q, v, e):
        levels += streaming.add_sample(time_s=sample[0], position_rad=sample[1],
                                       velocity_rad_s=sample[2], effort=sample[3])
    return levels + streaming.finish(), streaming


def test_every_paper_speed_matches_truth(paper_grid):
    config = segmenter_config_for(paper_grid.config)
    t, q, v, e = paper_grid.joint_samples()
    result = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    truth = paper_grid.truth[0]
    assert len(result.levels) == len(truth.speeds_rad_s)
    quantisation = paper_grid.config.effort_resolution / paper_grid.config.torque_scale
    for level, speed, friction in zip(result.levels, truth.speeds_rad_s, truth.friction_true):
        assert level.speed_rad_s == pytest.approx(speed, rel=0.01)
        # Bound: 4 standard errors of the level plus one quantisation step of the effort.
        assert abs(level.friction - friction) <= 4 * level.friction_std_error + quantisation
        assert level.n_forward >= 20 and level.n_backward >= 20
    assert set(result.rejections) <= {'pass_too_short'}  # reposition moves only


def test_streaming_equals_batch_with_bad_samples(paper_grid):
    config = segmenter_config_for(paper_grid.config)
    t, q, v, e = (a.copy() for a in paper_grid.joint_samples())
    rng = np.random.default_rng(0)
    bad = rng.choice(t.size, 40, replace=False)
    e[bad[:10]] = np.nan
    q[bad[10:20]] = np.inf
    t[bad[20:30]] = t[bad[20:30]] - 0.5
    t[bad[30]:] += 1.0  # one gap
    levels, streaming = _stream_samples(config, t, q, v, e)
    batch = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    assert levels == batch.levels
    assert streaming.rejections == batch.rejections
    assert batch.rejections['non_finite'] == 20
    assert batch.rejections['time_gap'] == 1
    assert batch.rejections['time_not_increasing'] >= 10


def test_streaming_messages_equal_batch(paper_grid):
    config = segmenter_config_for(paper_grid.config)
    streamed = _stream(paper_grid, StreamingSegmenter(config))
    t, q, v, e = paper_grid.joint_samples()
    assert streamed == segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e,
                                     config=config).levels


def _message(segmenter, stamp, **fields):
    message = {'name': ['a', 'j'], 'position': [0.0, 0.0], 'velocity': [0.0, 1.0],
               'effort': [0.0, 0.1]}
    message.update(fields)
    return segmenter.add_joint_state(stamp_s=stamp, **message)


@pytest.mark.parametrize('fields,reason', [
    ({'name': ['a', 'b']}, 'joint_missing'),
    ({'effort': []}, 'missing_effort'),
    ({'position': []}, 'missing_position'),
    ({'velocity': []}, 'missing_velocity'),
    ({'effort': [0.0, 0.1, 0.2]}, 'length_mismatch'),
    ({'effort': [0.0, float('nan')]}, 'non_finite'),
    ({'position': [0.0, float('inf')]}, 'non_finite'),
])
def test_message_rejections(fields, reason):
    segmenter = StreamingSegmenter(SegmenterConfig(joint='j'))
    _message(segmenter, 0.0)
    _message(segmenter, 0.01, **fields)
    assert segmenter.rejections == Counter({reason: 1})


def test_time_backwards_and_gap_are_counted():
    segmenter = StreamingSegmenter(SegmenterConfig(joint='j', max_gap_s=0.1))
    for stamp in (0.0, 0.01, 0.005, 0.01, 0.5):
        _message(segmenter, stamp)
    assert segmenter.rejections == Counter({'time_not_increasing': 2, 'time_gap': 1})


def test_bad_sample_cuts_the_pass(paper_grid):
    config = segmenter_config_for(paper_grid.config)
    t, q, v, e = (a.copy() for a in paper_grid.joint_samples())
    clean = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    first = clean.levels[0]
    middle = np.flatnonzero((t > first.start_time_s + 0.3) & (np.abs(v) > 0))[0]
    e[middle] = 1e9  # would ruin the mean if it were averaged in...
    e[middle] = np.nan  # ...so it is rejected instead
    cut = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    assert all(abs(level.friction) < 1 for level in cut.levels)
    assert cut.levels[0].n_forward + cut.levels[0].n_backward < \
        first.n_forward + first.n_backward


@pytest.mark.parametrize('field,value', [('gear_ratio', 0.0), ('torque_scale', -1.0),
                                         ('speed_tolerance_fraction', 1.5),
                                         ('min_samples', 2), ('max_gap_s', float('nan')),
                                         ('window_center_rad', 0.1)])
def test_config_validation_names_the_field(field, value):
    with pytest.raises(InputError, match=field.split('_rad')[0]):
        SegmenterConfig(joint='j', **{field: value})


def test_batch_rejects_arrays_of_different_lengths():
    with pytest.raises(InputError, match='differ in length'):
        segment_batch(time_s=[0, 1], position_rad=[0], velocity_rad_s=[0, 1], effort=[0, 1],
                      config=SegmenterConfig(joint='j'))


def _level(speed, start, friction=0.1, se=0.01):
    return FrictionLevel(speed_rad_s=speed, friction=friction, friction_std_error=se,
                         tau_forward=friction, tau_backward=-friction, n_forward=100,
                         n_backward=100, position_min_rad=0.0, position_max_rad=0.1,
                         start_time_s=start, end_time_s=start + 2.0)


def test_assembler_with_speeds_merges_repeats_and_completes():
    assembler = ExperimentAssembler(speeds_rad_s=[10.0, 30.0], speed_tolerance_rad_s=1.0,
                                    idle_gap_s=10.0)
    assert assembler.add(_level(10.2, 0.0, 0.1)) == []
    assert assembler.add(_level(9.9, 3.0, 0.3)) == []
    assert assembler.add(_level(55.0, 5.0)) == [] and assembler.ignored == 1
    (experiment,) = assembler.add(_level(30.0, 6.0, 0.2))
    assert experiment.frictions == pytest.approx([0.2, 0.2])
    assert experiment.levels[0].n_forward == 200
    # an incomplete experiment followed by a long pause is abandoned
    assembler.add(_level(10.0, 100.0))
    assert assembler.add(_level(10.0, 200.0)) == [] and assembler.abandoned == 1


def test_assembler_without_speeds_splits_on_idle_and_repeat():
    assembler = ExperimentAssembler(speed_tolerance_rad_s=1.0, idle_gap_s=10.0)
    assembler.add(_level(10.0, 0.0))
    assembler.add(_level(20.0, 3.0))
    (first,) = assembler.add(_level(10.0, 6.0))  # repeat
    assert list(first.speeds_rad_s) == [10.0, 20.0]
    (second,) = assembler.add(_level(30.0, 60.0))  # idle gap
    assert list(second.speeds_rad_s) == [10.0]
    (last,) = assembler.flush()
    assert list(last.speeds_rad_s) == [30.0]


@pytest.mark.parametrize('seed', [1, 2])
def test_chunks_of_any_size_give_the_streaming_levels(seed):
    """The chunked replay path equals the live one on an independent recording with faults."""
    from robot_wear_monitor.experiment.segmentation import ChunkSegmenter
    from wear_testing import independent_robot as robot
    recording = robot.generate_wear_test(n_experiments=3, seed=seed, rate_hz=500.0)
    column = recording.joint_index
    t = recording.stamps_s.copy()
    q = recording.position[:, column].copy()
    v = recording.velocity[:, column].copy()
    e = recording.effort[:, column].copy()
    rng = np.random.default_rng(seed)
    bad = rng.choice(t.size, 12, replace=False)
    e[bad[:4]] = np.nan
    v[bad[4:7]] = np.inf
    t[bad[7:11]] -= 0.3
    t[bad[11]:] += 0.5  # a gap
    config = SegmenterConfig(joint=recording.joint, gear_ratio=recording.gear_ratio,
                             torque_scale=recording.torque_scale)
    expected, streaming = _stream_samples(config, t, q, v, e)
    assert len(expected) >= 6
    cuts = np.unique(np.concatenate([rng.integers(0, t.size, 40), bad[:8], bad[:8] + 1,
                                     [1, 2, 3, t.size - 1]]))
    edges = np.concatenate(([0], cuts, [t.size]))
    chunked = ChunkSegmenter(config)
    levels = []
    for start, stop in zip(edges[:-1], edges[1:]):
        levels += chunked.add(time_s=t[start:stop], position_rad=q[start:stop],
                              velocity_rad_s=v[start:stop], effort=e[start:stop])
    levels += chunked.finish()
    assert levels == expected
    assert chunked.rejections == streaming.rejections
    assert chunked.rejections['non_finite'] == 7 and chunked.rejections['time_gap'] >= 1


@pytest.mark.parametrize('settings', [{}, {'trim_s': 0.0, 'min_duration_s': 0.05},
                                      {'window_center_rad': 0.6, 'window_half_width_rad': 0.01}])
def test_moves_of_one_chunk_at_once_give_the_streaming_levels(settings):
    """One chunk's moves analysed together equal the per-move live path, bit for bit."""
    from wear_testing import independent_robot as robot
    recording = robot.generate_wear_test(n_experiments=3, seed=4)
    column = recording.joint_index
    t = recording.stamps_s.copy()
    q = recording.position[:, column].copy()
    v = recording.velocity[:, column].copy()
    e = recording.effort[:, column].copy()
    rng = np.random.default_rng(4)
    bad = rng.choice(t.size, 12, replace=False)
    e[bad[:4]] = np.nan
    v[bad[4:7]] = np.inf
    t[bad[7:11]] -= 0.3
    t[bad[11]:] += 0.5  # a gap
    config = SegmenterConfig(joint=recording.joint, gear_ratio=recording.gear_ratio,
                             torque_scale=recording.torque_scale, **settings)
    expected, streaming = _stream_samples(config, t, q, v, e)
    batch = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    assert batch.levels == expected  # every field of every level, exactly
    assert batch.rejections == streaming.rejections
    assert batch.rejections['non_finite'] == 7 and batch.rejections['time_not_increasing'] == 4
    assert len(batch.levels) == 12  # 3 experiments of the 4 speeds of Table V
    if 'window_center_rad' in settings:
        assert all(0.59 <= level.position_min_rad < level.position_max_rad <= 0.61
                   for level in batch.levels)


def test_speed_tally_counts_each_level_at_the_nearest_speed():
    """A speed joins the nearest mean within the tolerance (the first of two as near)."""
    tally = SpeedTally(tolerance_rad_s=1.0)
    for speed in (10.0, 12.0, 11.0, 13.2, 12.4):  # 11.0: 1.0 from both 10.0 and 12.0
        tally.add(speed)
    assert tally.counts() == {10.5: 2, 12.2: 2, 13.2: 1}
