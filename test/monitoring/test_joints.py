"""Several joints in one service: refused joints, restored joints, names and parameters."""

import pytest
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring import node_config
from robot_wear_monitor.monitoring.joints import JointEstimators, JointExperiments, output_topic
from robot_wear_monitor.monitoring.replay import KIT
from robot_wear_monitor.recordings import messages
from wear_testing import independent_robot as robot

SPEEDS = (2.1, 28.5, 35.1, 41.7)


def _friction(**values):
    return node_config.validate_parameters(node_config.FRICTION_EXPERIMENT_NODE, values)


def _estimator(**values):
    return node_config.validate_parameters(node_config.WEAR_ESTIMATOR_NODE,
                                           {'history_file': ':memory:', **values})


def _levels(joint, stamp_s, wear):
    frictions = [float(robot.friction_model(v, 0.5, 40.0, wear)) for v in SPEEDS]
    return messages.friction_levels_to_msg(KIT, stamp_s=stamp_s, joint=joint,
                                           speeds_rad_s=SPEEDS, frictions=frictions)


def test_a_bad_value_for_a_joint_is_refused_at_start_when_given():
    values = _friction(joints=('all',), experiment_speeds_rad_s=SPEEDS,
                       **{'bad.experiment_speed_tolerance_rad_s': 5.0})
    with pytest.raises(ParameterError, match='bad'):
        JointExperiments(values)


def test_a_joint_refused_at_run_time_does_not_stop_the_others():
    def parameters_for(joint):
        if joint == 'bad':
            raise ParameterError('bad: gear_ratio: must be > 0, got -1.0')
        return node_config.joint_parameters(node_config.FRICTION_EXPERIMENT_NODE, values,
                                            joint)
    values = _friction(joints=('all',))
    experiments = JointExperiments(values, parameters_for=parameters_for)
    for k in range(5):
        experiments.add_joint_state(stamp_s=float(k), name=['good', 'bad'], position=[0.0, 0.0],
                                    velocity=[0.0, 0.0], effort=[0.0, 0.0])
    assert list(experiments.services) == ['good'] and experiments.services['good'].messages == 5
    assert experiments.refused == {'bad': 'bad: gear_ratio: must be > 0, got -1.0'}


def test_a_restarted_estimator_under_all_restores_the_joints_of_its_history(tmp_path):
    path = str(tmp_path / 'h.sqlite3')
    history = WearHistory(path)
    first = JointEstimators(_estimator(joints=('shoulder', 'elbow')), history=history)
    for k, wear in enumerate((20.0, 45.0, 60.0, 70.0)):
        first.handle_friction_levels(_levels('shoulder', 100.0 + k, wear))
    first.handle_friction_levels(_levels('elbow', 200.0, 5.0))
    assert first.services['shoulder'].latch.active
    history.close()
    history = WearHistory(path)
    try:
        again = JointEstimators(_estimator(joints=('all',)), history=history)
        assert sorted(again.services) == ['elbow', 'shoulder']
        assert again.services['shoulder'].latch.active  # latched before any new experiment
        assert not again.services['elbow'].latch.active
        assert again.services['shoulder'].restored_estimates == 4
    finally:
        history.close()


def test_two_joints_with_one_topic_namespace_refuse_the_second():
    history = WearHistory(':memory:')
    try:
        estimators = JointEstimators(_estimator(joints=('all',)), history=history)
        assert output_topic('wear', 'joint-1', per_joint=True) == 'joint_1/wear'
        service, update = estimators.handle_friction_levels(_levels('joint-1', 1.0, 10.0))
        assert update is not None and service.config.joint == 'joint-1'
        service, update = estimators.handle_friction_levels(_levels('joint_1', 2.0, 10.0))
        assert service is None and update is None
        assert estimators.rejections == {'joint_refused': 1}
        assert "namespace 'joint_1'" in estimators.refused['joint_1']
    finally:
        history.close()


def test_per_joint_values_under_the_wildcard_reach_the_replay(tmp_path):
    config = tmp_path / 'nodes.yaml'
    config.write_text('/**:\n  ros__parameters:\n    shoulder:\n      gear_ratio: 120.0\n'
                      'friction_experiment_node:\n  ros__parameters:\n    joints: [shoulder]\n')
    values = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE, config)
    assert node_config.joint_parameters(node_config.FRICTION_EXPERIMENT_NODE, values,
                                        'shoulder')['gear_ratio'] == 120.0
    estimator = node_config.load_node_parameters(node_config.WEAR_ESTIMATOR_NODE, config)
    assert not any(key.startswith('shoulder.') for key in estimator)  # not an estimator value
