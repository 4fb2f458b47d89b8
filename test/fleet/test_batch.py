"""Re-analysis of many bags: pool and Dask give the numbers of replaying the bags one by one."""

from dataclasses import replace
import json
from pathlib import Path

import pytest
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                      simulate_scenario)
from robot_wear_monitor.fleet.batch import (BatchError, collect_bags, read_manifest,
                                            recording_fingerprint, ReplaySettings, run_batch)
from robot_wear_monitor.history import open_history
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
from robot_wear_monitor.recordings.bags import write_joint_state_bag

HOUR_S = 3600.0
#: two robots, two consecutive bags each: (robot, bag, first experiment, seed, final wear)
FLEET = (('r1', 'a', 0, 1, 30.0), ('r1', 'b', 4, 2, 45.0),
         ('r2', 'a', 0, 3, 10.0), ('r2', 'b', 4, 4, 20.0))
EXPERIMENTS = 4
START_S = 1.75e9


def _simulate(path: Path, *, first: int, seed: int, wear_final: float) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    config = accelerated_wear_scenario(n_experiments=EXPERIMENTS, seed=seed,
                                       wear_final=wear_final)
    config = replace(config, start_time_s=START_S + first * HOUR_S)
    scenario = simulate_scenario(config=config, model=load_parameter_set().model, seed=seed)
    return write_joint_state_bag(path, stamps_s=scenario.time_s, names=scenario.joint_names,
                                 position=scenario.position_rad,
                                 velocity=scenario.velocity_rad_s, effort=scenario.effort)


@pytest.fixture(scope='module')
def fleet_bags(tmp_path_factory) -> dict[tuple[str, str], Path]:
    root = tmp_path_factory.mktemp('fleet_bags')
    bags = {}
    for robot, name, first, seed, wear in FLEET:
        bags[(robot, name)] = _simulate(root / robot / name, first=first, seed=seed,
                                        wear_final=wear)
    return bags


def _manifest(tmp_path: Path, bags: dict, extra: tuple = ()) -> Path:
    lines = ['robot,bag'] + [f'{robot},{path}' for (robot, _), path in bags.items()]
    lines += list(extra)
    manifest = tmp_path / 'fleet.csv'
    manifest.write_text('\n'.join(lines) + '\n')
    return manifest


def _rows(history_url: str) -> list[tuple]:
    """Return every estimate of the history as comparable tuples (robot, joint, stamp order)."""
    with open_history(history_url, init=False) as history:
        records = [record for robot in history.robots()
                   for joint in history.joints(robot=robot)
                   for record in history.records(joint=joint, robot=robot)]
    return sorted((r.robot, r.joint, round(r.stamp_s, 6), r.wear, r.wear_low, r.wear_high,
                   r.trend_wear, r.trend_low, r.trend_high, r.alarm_active)
                  for r in records)


def _one_by_one(bags: dict, history: str) -> None:
    """Replay the bags as a user would, one after the other, each robot's in time order."""
    for (robot, _), path in sorted(bags.items()):
        experiment, estimator = replay_parameters(robot=robot)
        replay_bag(path, out_bag=None, experiment_parameters=experiment,
                   estimator_parameters=estimator, history_file=history)


@pytest.fixture(scope='module')
def reference_rows(fleet_bags, tmp_path_factory) -> list[tuple]:
    history = str(tmp_path_factory.mktemp('reference') / 'history.sqlite3')
    _one_by_one(fleet_bags, history)
    rows = _rows(history)
    assert len(rows) == len(FLEET) * EXPERIMENTS
    assert {row[0] for row in rows} == {'r1', 'r2'}
    return rows


@pytest.mark.parametrize('workers', [1, 2])
def test_pool_gives_the_rows_of_one_by_one(fleet_bags, reference_rows, tmp_path, workers):
    history = str(tmp_path / 'history.sqlite3')
    # given in an order that is not the time order: the batch orders each robot's bags
    tasks = collect_bags(manifest=_manifest(tmp_path, dict(reversed(list(fleet_bags.items())))))
    result = run_batch(tasks, settings=ReplaySettings(history=history), workers=workers)
    assert result.count('done') == len(FLEET), result.summary()
    assert _rows(history) == reference_rows
    assert sum(o.experiments for o in result.outcomes) == len(FLEET) * EXPERIMENTS
    # a re-run skips every bag and adds nothing
    again = run_batch(tasks, settings=ReplaySettings(history=history), workers=workers)
    assert again.count('skipped') == len(FLEET)
    assert _rows(history) == reference_rows


def test_dask_local_cluster_gives_the_rows_of_one_by_one(fleet_bags, reference_rows, tmp_path):
    distributed = pytest.importorskip('distributed')
    history = str(tmp_path / 'history.sqlite3')
    tasks = collect_bags(manifest=_manifest(tmp_path, fleet_bags))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        result = run_batch(tasks, settings=ReplaySettings(history=history),
                           dask_client=client)
        assert len({o.pid for o in result.outcomes}) == 2  # both workers did work
    assert result.executor.startswith('dask')
    assert result.count('done') == len(FLEET)
    assert _rows(history) == reference_rows


def test_a_failing_bag_is_reported_and_the_others_go_on(fleet_bags, tmp_path):
    corrupt = tmp_path / 'corrupt'
    corrupt.mkdir()
    (corrupt / 'metadata.yaml').write_text('rosbag2_bagfile_information: {version: 9}\n')
    history = str(tmp_path / 'history.sqlite3')
    tasks = collect_bags(manifest=_manifest(tmp_path, fleet_bags,
                                            extra=(f'r3,{corrupt}',)))
    result = run_batch(tasks, settings=ReplaySettings(history=history), workers=2)
    assert result.count('done') == len(FLEET)
    [failed] = result.failed
    assert failed.robot == 'r3' and failed.bag == str(corrupt)
    assert 'corrupt' in failed.reason and failed.reason
    assert {row[0] for row in _rows(history)} == {'r1', 'r2'}


def test_outputs_go_under_out_robot_bag(fleet_bags, tmp_path):
    tasks = collect_bags(paths=[fleet_bags[('r2', 'a')].parent], robot='r2',
                         out_dir=tmp_path / 'out')
    assert [t.bag.name for t in tasks] == ['a', 'b']
    result = run_batch(tasks, settings=ReplaySettings(history=None), workers=1)
    assert result.count('done') == 2
    for name in ('a', 'b'):
        assert (tmp_path / 'out' / 'r2' / name / 'metadata.yaml').is_file()


def test_manifest_paths_are_relative_to_the_manifest(tmp_path):
    (tmp_path / 'sub').mkdir()
    manifest = tmp_path / 'sub' / 'm.csv'
    manifest.write_text('robot,bag\nr1,bags/x\nr2,/abs/y\n')
    assert read_manifest(manifest) == [('r1', tmp_path / 'sub' / 'bags' / 'x'),
                                       ('r2', Path('/abs/y'))]
    manifest.write_text('robot,path\nr1,x\n')
    with pytest.raises(BatchError, match='missing column'):
        read_manifest(manifest)
    manifest.write_text('robot,bag\n,x\n')
    with pytest.raises(BatchError, match='line 2: empty robot'):
        read_manifest(manifest)


def test_collect_refuses_what_is_no_bag(tmp_path):
    with pytest.raises(BatchError, match='no such bag'):
        collect_bags(paths=[tmp_path / 'missing'])
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BatchError, match='neither a bag nor a folder of bags'):
        collect_bags(paths=[tmp_path / 'empty'])


def test_fingerprint_follows_the_content_not_the_place(fleet_bags, tmp_path):
    import shutil
    source = fleet_bags[('r1', 'a')]
    copy = tmp_path / 'copy'
    shutil.copytree(source, copy)
    assert recording_fingerprint(copy) == recording_fingerprint(source)
    assert recording_fingerprint(fleet_bags[('r1', 'b')]) != recording_fingerprint(source)


def test_summary_is_json(fleet_bags, tmp_path):
    tasks = collect_bags(paths=[fleet_bags[('r1', 'a')]], robot='r1')
    result = run_batch(tasks, settings=ReplaySettings(), workers=1)
    summary = json.loads(json.dumps(result.summary(), allow_nan=False))
    assert summary['bags'] == 1 and summary['done'] == 1
    assert summary['experiments'] == EXPERIMENTS
    assert '1 bags: 1 done' in result.summary_line()
