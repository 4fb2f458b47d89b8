"""Tests of the friction experiment service: segmentation, status, the cut of a recording."""

import numpy as np
import pytest
from robot_wear_monitor.monitoring import node_config
from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
from robot_wear_monitor.recordings import messages


def test_experiment_service_segments_a_simulated_joint():
    from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                          simulate_scenario)
    config = accelerated_wear_scenario(n_experiments=3, seed=3)
    scenario = simulate_scenario(config=config, seed=3)
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE)
    svc = FrictionExperimentService.from_node_parameters(values)
    found = []
    for stamp, name, position, velocity, effort in scenario.messages():
        found += svc.add_joint_state(stamp_s=stamp, name=name, position=position,
                                     velocity=velocity, effort=effort)
    found += svc.finish()
    assert len(found) == 3
    for exp, truth in zip(found, scenario.truth):
        assert np.allclose(exp.speeds_rad_s, truth.speeds_rad_s, atol=0.2)
        assert np.allclose(exp.frictions, truth.friction_true, atol=3e-3)
    assert svc.add_joint_state(stamp_s=1e10, name=['joint_2'], position=[0.0],
                               velocity=[], effort=[0.0]) == []
    assert svc.all_rejections()['missing_velocity'] == 1


def test_experiment_service_status_warns_only_in_a_period_with_malformed_input():
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE)
    svc = FrictionExperimentService.from_node_parameters(values)
    status = svc.current_status()
    assert status.level == messages.DIAGNOSTIC_OK and status.value('joint_states') == '0'
    svc.add_joint_state(stamp_s=1.0, name=['joint_2'], position=[0.0], velocity=[0.0, 1.0],
                        effort=[0.0])
    svc.add_joint_state(stamp_s=2.0, name=['joint_2'], position=[0.0], velocity=[0.0],
                        effort=[0.0])
    svc.add_joint_state(stamp_s=9.0, name=['joint_2'], position=[0.0], velocity=[0.0],
                        effort=[0.0])  # a pause: routine
    status = svc.current_status()
    assert status.level == messages.DIAGNOSTIC_WARN and 'length_mismatch' in status.message
    assert status.value('rejected_length_mismatch') == '1'
    assert status.value('rejected_time_gap') == '1'
    assert status.value('joint_states') == '3'
    assert svc.current_status().level == messages.DIAGNOSTIC_OK  # nothing new since
    svc.add_joint_state(stamp_s=30.0, name=['joint_2'], position=[0.0], velocity=[0.0],
                        effort=[0.0])
    assert svc.current_status().level == messages.DIAGNOSTIC_OK  # another pause only


def test_the_service_default_idle_gap_is_the_node_parameter_default():
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE)
    from robot_wear_monitor.experiment.segmentation import SegmenterConfig
    config = SegmenterConfig(**{name: values[name] for name in node_config.SEGMENTER_FIELDS})
    assert FrictionExperimentService(segmenter_config=config).idle_gap_s == values['idle_gap_s']


# --------------------------------------------------------------------------- a cut recording

def _cut_service(recording, cut, chunk):
    """Feed the first ``cut`` samples of the joint in chunks, then handle the cut as replay."""
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                              overrides={'joint': recording.joint})
    service = FrictionExperimentService.from_node_parameters(values)
    column = recording.joint_index
    arrays = (recording.stamps_s, recording.position[:, column],
              recording.velocity[:, column], recording.effort[:, column])
    found = []
    for start in range(0, cut, chunk):
        stop = min(cut, start + chunk)
        t, q, v, e = (a[start:stop] for a in arrays)
        found += service.add_recording(time_s=t, position_rad=q, velocity_rad_s=v, effort=e)
    dropped = service.drop_interrupted()
    return found + service.finish(), dropped, service


@pytest.mark.parametrize('gap_s', [1.0, 5.0])
@pytest.mark.parametrize('chunk', [700, 100_000])
def test_a_cut_in_the_next_experiments_first_move_keeps_the_complete_one(gap_s, chunk):
    from wear_testing import independent_robot as robot
    recording = robot.generate_wear_test(n_experiments=2, seed=1, rate_hz=500.0, gap_s=gap_s)
    first_end = recording.truth[0].end_s
    speed = np.abs(recording.velocity[:, recording.joint_index]) * recording.gear_ratio
    moving = np.flatnonzero((speed > 0.1) & (recording.stamps_s > first_end))
    found, dropped, _ = _cut_service(recording, int(moving[0]) + 100, chunk)  # 0.2 s in
    assert [len(x.levels) for x in found] == [len(recording.truth[0].speeds_rad_s)]
    assert dropped == 0


def test_a_cut_in_a_pause_inside_an_experiment_drops_that_experiment_only():
    from wear_testing import independent_robot as robot
    recording = robot.generate_wear_test(n_experiments=2, seed=1, rate_hz=500.0,
                                         standstill_s=1.0)
    whole, _, service = _cut_service(recording, recording.stamps_s.size, 100_000)
    assert [len(x.levels) for x in whole] == [4, 4]
    second = [level for level in service.levels if level.start_time_s > whole[0].end_time_s]
    cut = int(np.searchsorted(recording.stamps_s, second[1].end_time_s + 0.7))
    found, dropped, cut_service = _cut_service(recording, cut, 100_000)
    assert [len(x.levels) for x in found] == [4] and dropped == 2
    assert cut_service.rejections['experiment_cut'] == 1
