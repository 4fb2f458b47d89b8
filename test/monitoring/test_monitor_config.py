"""
The typed configuration replay, batch and demo pass along (MonitorConfig).

One node parameter file, read and checked once: each joint's segmentation, grouping and alarm
come out typed, with the file's ``<joint>.<name>`` values, and the object survives pickling
(a batch sends it to its workers).
"""

import pickle

import pytest
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
from robot_wear_monitor.monitoring.monitor_config import FrictionJointConfig, MonitorConfig
from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                       joint_parameters)

CONFIG = """friction_experiment_node:
  ros__parameters:
    joints: [joint_2, joint_3]
    idle_gap_s: 5.0
    joint_3: {gear_ratio: 120.0, torque_scale: 4.0}
wear_estimator_node:
  ros__parameters:
    joints: [joint_2, joint_3]
    joint_3: {wear_threshold: 30.0, wear_warning: 27.0}
"""


@pytest.fixture
def configuration(tmp_path):
    path = tmp_path / 'nodes.yaml'
    path.write_text(CONFIG)
    return MonitorConfig.load(config_file=path, joints=['joint_2', 'joint_3'])


def test_each_joint_gets_its_own_typed_settings(configuration):
    assert configuration.joints == ('joint_2', 'joint_3')
    two, three = configuration.friction_joint('joint_2'), configuration.friction_joint('joint_3')
    assert (two.segmenter.gear_ratio, two.segmenter.torque_scale) == (150.0, 10.0)
    assert (three.segmenter.gear_ratio, three.segmenter.torque_scale) == (120.0, 4.0)
    assert two.grouping.idle_gap_s == three.grouping.idle_gap_s == 5.0
    assert three.joint == 'joint_3'
    assert configuration.alarm_policy('joint_2').threshold == 35.0
    assert configuration.alarm_policy('joint_3').threshold == 30.0
    assert configuration.parameter_set_file('joint_3') is None  # the packaged set


def test_the_service_built_from_it_is_the_one_built_from_the_values(configuration):
    values = joint_parameters(FRICTION_EXPERIMENT_NODE, configuration.experiment, 'joint_3')
    typed = FrictionExperimentService.from_joint_config(configuration.friction_joint('joint_3'))
    plain = FrictionExperimentService.from_node_parameters(values)
    assert typed.segmenter_config == plain.segmenter_config
    assert (typed.idle_gap_s, typed.speed_tolerance_rad_s) == (5.0, 1.0)
    assert FrictionJointConfig.from_node_parameters(values) == \
        configuration.friction_joint('joint_3')


def test_changes_are_checked_and_it_travels_to_a_worker(configuration):
    with pytest.raises(ParameterError, match='experiment_speeds_rad_s: speeds must be > 0'):
        configuration.with_experiment_speeds([2.1, -1.0])
    fast = configuration.with_experiment_speeds([2.1, 28.5])
    assert fast.friction_joint('joint_3').experiment_speeds_rad_s == (2.1, 28.5)
    assert configuration.friction_joint('joint_3').experiment_speeds_rad_s == ()
    robot = pickle.loads(pickle.dumps(fast.for_robot('cell_7')))
    assert robot.robot == 'cell_7' and configuration.robot is None
    assert robot.alarm_policy('joint_3').threshold == 30.0


def test_a_bad_joint_value_is_refused_when_the_file_is_read(tmp_path):
    path = tmp_path / 'nodes.yaml'
    path.write_text(CONFIG.replace('gear_ratio: 120.0', 'gear_ratio: -1.0'))
    with pytest.raises(ParameterError, match='nodes.yaml: joint_3: gear_ratio: must be > 0'):
        MonitorConfig.load(config_file=path)  # refused where it is read, before any work
