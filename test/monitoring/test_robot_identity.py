"""Robot identity: robot_id keys the history rows and names the robot in /diagnostics."""

from dataclasses import replace

import pytest
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                      simulate_scenario)
from robot_wear_monitor.history import open_history, WearHistory
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
from robot_wear_monitor.recordings.bags import TYPESTORE, write_joint_state_bag
from robot_wear_monitor.recordings.messages import diagnostics_from_msg, rosbags_kit

EXPERIMENTS = 3


@pytest.fixture(scope='module')
def small_bag(tmp_path_factory):
    config = replace(accelerated_wear_scenario(n_experiments=EXPERIMENTS, seed=5,
                                               wear_final=30.0), start_time_s=1.75e9)
    scenario = simulate_scenario(config=config, model=load_parameter_set().model, seed=5)
    return write_joint_state_bag(tmp_path_factory.mktemp('robot') / 'bag',
                                 stamps_s=scenario.time_s, names=scenario.joint_names,
                                 position=scenario.position_rad,
                                 velocity=scenario.velocity_rad_s, effort=scenario.effort)


def _replay(bag, history, robot):
    experiment, estimator = replay_parameters(robot=robot)
    return replay_bag(bag, out_bag=None, experiment_parameters=experiment,
                      estimator_parameters=estimator, history_file=history)


def test_two_robots_with_the_same_recording_keep_their_own_rows(small_bag, tmp_path):
    history = str(tmp_path / 'fleet.sqlite3')
    first = _replay(small_bag, history, 'r7')
    second = _replay(small_bag, history, 'r8')
    again = _replay(small_bag, history, 'r7')
    assert len(first.updates) == len(second.updates) == EXPERIMENTS
    assert not again.updates  # already in the history for r7
    with open_history(history, init=False) as store:
        assert store.robots() == ('r7', 'r8')
        for robot in ('r7', 'r8'):
            rows = store.records(joint='joint_2', robot=robot)
            assert [r.robot for r in rows] == [robot] * EXPERIMENTS
        assert [r.wear for r in store.records(joint='joint_2', robot='r7')] == \
            [r.wear for r in store.records(joint='joint_2', robot='r8')]


def test_diagnostics_name_the_robot_in_hardware_id(small_bag):
    from robot_wear_monitor.monitoring.joints import JointEstimators
    kit = rosbags_kit(TYPESTORE)
    for robot, hardware_id in (('r7', 'r7/joint_2'), (None, 'joint_2')):
        _, parameters = replay_parameters(robot=robot)
        estimators = JointEstimators(parameters, history=WearHistory(':memory:'), source='test')
        service = estimators.service('joint_2')
        message = service.diagnostics_message(kit, stamp_s=1.0)
        assert [status.hardware_id for status in message.status] == [hardware_id]
        [(_, _, _, values)] = diagnostics_from_msg(message)
        assert (values.get('robot') == robot) if robot else 'robot' not in values
