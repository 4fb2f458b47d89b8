"""
Replays at once into one history (SQLite and a real PostgreSQL): nothing lost, nothing twice.

Eight replays of eight robots start together against one history and must store exactly the
rows of the same replays run one after the other; two replays of the same robot's recording at
once must give the rows of one (the second waits for the robot's writer lock, then skips what
the first stored), and two consecutive recordings of one robot replayed at once must give the
rows of one sequential order -- the trend included (without the lock each replay's trend would
miss the other's experiments).
"""

from dataclasses import replace
import multiprocessing

import pytest
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                      simulate_scenario)
from robot_wear_monitor.history import open_history
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
from robot_wear_monitor.recordings.bags import write_joint_state_bag


ROBOTS = 8
EXPERIMENTS = 3


@pytest.fixture(scope='module')
def robot_bags(tmp_path_factory):
    root = tmp_path_factory.mktemp('concurrent')
    model = load_parameter_set().model
    bags = {}
    for r in range(ROBOTS):
        config = replace(accelerated_wear_scenario(n_experiments=EXPERIMENTS, seed=10 + r,
                                                   wear_final=20.0 + 5 * r),
                         start_time_s=1.75e9)
        scenario = simulate_scenario(config=config, model=model, seed=10 + r)
        bags[f'robot_{r}'] = write_joint_state_bag(
            root / f'robot_{r}', stamps_s=scenario.time_s, names=scenario.joint_names,
            position=scenario.position_rad, velocity=scenario.velocity_rad_s,
            effort=scenario.effort)
    return bags


@pytest.fixture(scope='module')
def consecutive_bags(tmp_path_factory):
    """Two recordings of one robot: the second starts after the first ends."""
    root = tmp_path_factory.mktemp('consecutive')
    model = load_parameter_set().model
    bags = []
    for part in range(2):
        config = replace(accelerated_wear_scenario(n_experiments=EXPERIMENTS, seed=40 + part,
                                                   wear_final=30.0 + 10 * part),
                         start_time_s=1.75e9 + part * EXPERIMENTS * 3600.0)
        scenario = simulate_scenario(config=config, model=model, seed=40 + part)
        bags.append(write_joint_state_bag(
            root / f'part_{part}', stamps_s=scenario.time_s, names=scenario.joint_names,
            position=scenario.position_rad, velocity=scenario.velocity_rad_s,
            effort=scenario.effort))
    return bags


def _replay(bag, history, robot):
    experiment, estimator = replay_parameters(robot=robot)
    replay_bag(bag, out_bag=None, experiment_parameters=experiment,
               estimator_parameters=estimator, history_file=history)


def _replay_when_told(bag, history, robot, start):
    start.wait(60)
    _replay(bag, history, robot)


def _at_once(jobs, history):
    context = multiprocessing.get_context('fork')
    start = context.Event()
    processes = [context.Process(target=_replay_when_told, args=(bag, history, robot, start))
                 for robot, bag in jobs]
    for process in processes:
        process.start()
    start.set()
    for process in processes:
        process.join(300)
    assert [p.exitcode for p in processes] == [0] * len(processes)


def _rows(history):
    with open_history(history, init=False) as store:
        return sorted((r.robot, r.joint, r.stamp_s, r.wear, r.trend_wear, r.trend_low,
                       r.trend_high, r.alarm_active)
                      for robot in store.robots() for joint in store.joints(robot=robot)
                      for r in store.records(joint=joint, robot=robot))


def _location(backend, tmp_path, request, name):
    if backend == 'sqlite':
        return str(tmp_path / f'{name}.sqlite3')
    return request.getfixturevalue('postgresql_server').create_database(name)


@pytest.mark.parametrize('backend', ['sqlite', 'postgresql'])
def test_eight_replays_at_once_store_the_sequential_rows(robot_bags, tmp_path, request,
                                                         backend):
    sequential = _location(backend, tmp_path, request, 'sequential')
    for robot, bag in robot_bags.items():
        _replay(bag, sequential, robot)
    together = _location(backend, tmp_path, request, 'together')
    open_history(together).close()  # created before the writers race
    _at_once(list(robot_bags.items()), together)
    expected = _rows(sequential)
    assert len(expected) == ROBOTS * EXPERIMENTS
    assert _rows(together) == expected


@pytest.mark.parametrize('backend', ['sqlite', 'postgresql'])
def test_two_replays_of_one_robot_at_once_give_the_rows_of_one(
        robot_bags, tmp_path, request, backend):
    bag = robot_bags['robot_3']
    once = _location(backend, tmp_path, request, 'once')
    _replay(bag, once, 'robot_3')
    twice = _location(backend, tmp_path, request, 'twice')
    open_history(twice).close()
    _at_once([('robot_3', bag), ('robot_3', bag)], twice)
    assert _rows(twice) == _rows(once)


@pytest.mark.parametrize('backend', ['sqlite', 'postgresql'])
def test_two_recordings_of_one_robot_at_once_give_a_sequential_trend(
        consecutive_bags, tmp_path, request, backend):
    orders = []
    for name, order in (('ab', consecutive_bags), ('ba', consecutive_bags[::-1])):
        location = _location(backend, tmp_path, request, name)
        for bag in order:
            _replay(bag, location, 'robot_x')
        orders.append(_rows(location))
    assert orders[0] != orders[1]  # the order matters to the trend
    together = _location(backend, tmp_path, request, 'together_ab')
    open_history(together).close()
    _at_once([('robot_x', bag) for bag in consecutive_bags], together)
    assert _rows(together) in orders
