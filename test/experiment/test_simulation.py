"""Simulated experiments and accelerated wear scenarios: truth, ranges, JSON."""

import numpy as np
import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation import ExperimentAssembler, segment_batch
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario, JointSimConfig,
                                                      read_truth_json, ScenarioConfig,
                                                      segmenter_config_for, simulate_scenario,
                                                      TABLE_V_SPEEDS_RAD_S, truth_path_for,
                                                      write_truth_json)
from robot_wear_monitor.model.friction import friction
from robot_wear_monitor.model.params import load_parameter_set


@pytest.fixture(scope='module')
def wear_test():
    return simulate_scenario(config=accelerated_wear_scenario(n_experiments=100, seed=4),
                             seed=4)


def test_wear_temperature_and_load_like_section_v(wear_test):
    params = load_parameter_set()
    wear = np.array([t.wear for t in wear_test.truth])
    temperature = np.array([t.temperature_degc for t in wear_test.truth])
    load = np.array([t.load for t in wear_test.truth])
    assert wear.size == 100
    assert np.all(wear[:80] < 10) and wear[-1] > 35 and np.max(wear[:85]) < 35
    assert np.all((temperature >= 30) & (temperature <= 50)) and np.ptp(temperature) > 10
    assert abs(np.mean(load) - params.load_mean) < 0.05 and 0.03 < np.std(load) < 0.15
    for truth in wear_test.truth[::17]:
        model = friction(np.array(truth.speeds_rad_s), truth.load, truth.temperature_degc,
                         truth.wear, params.model)
        assert np.allclose(truth.friction_model, model)


def test_samples_shapes_and_other_joints_still(wear_test):
    n, joints = wear_test.position_rad.shape
    assert joints == 6 and n == wear_test.time_s.size
    assert np.all(np.diff(wear_test.time_s) > 0)
    others = [i for i in range(6) if i != wear_test.config.joint_index]
    assert np.ptp(wear_test.position_rad[:, others], axis=0).max() == 0.0
    step = wear_test.config.effort_resolution
    assert np.allclose(wear_test.effort / step, np.round(wear_test.effort / step))


def test_segmented_experiments_match_truth(wear_test):
    config = segmenter_config_for(wear_test.config)
    t, q, v, e = wear_test.joint_samples()
    levels = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e,
                           config=config).levels
    assembler = ExperimentAssembler(speeds_rad_s=TABLE_V_SPEEDS_RAD_S)
    experiments = [x for level in levels for x in assembler.add(level)] + assembler.flush()
    assert len(experiments) == len(wear_test.truth)
    quantisation = wear_test.config.effort_resolution / wear_test.config.torque_scale
    for experiment, truth in zip(experiments, wear_test.truth):
        assert truth.start_time_s <= experiment.start_time_s <= truth.end_time_s
        error = np.abs(experiment.frictions - np.array(truth.friction_true))
        se = np.array([level.friction_std_error for level in experiment.levels])
        assert np.all(error <= 4.5 * se + quantisation)


def test_reproducible_and_truth_json_round_trip(tmp_path):
    config = ScenarioConfig(speeds_rad_s=(10.0, 40.0), wear=(0.0, 5.0),
                            temperature_degc=(35.0, 45.0), load=(0.4, 0.6))
    first = simulate_scenario(config=config, seed=9)
    second = simulate_scenario(config=config, seed=9)
    assert np.array_equal(first.effort, second.effort)
    path = write_truth_json(truth_path_for(tmp_path / 'bag'), first)
    assert path.name == 'bag.truth.json'
    assert read_truth_json(path) == first.truth


def test_invalid_joint_is_rejected():
    with pytest.raises(InputError, match='JointSimConfig.joint'):
        JointSimConfig(joint='joint_9')


@pytest.mark.parametrize('kwargs,field', [
    ({'load': (0.5,)}, 'load'),
    ({'speeds_rad_s': (-1.0,)}, 'speeds_rad_s'),
])
def test_invalid_scenarios_are_rejected(kwargs, field):
    base = {'speeds_rad_s': (10.0,), 'wear': (0.0, 1.0), 'temperature_degc': (40.0, 40.0),
            'load': (0.5, 0.5)}
    with pytest.raises(InputError, match=field):
        base.update(kwargs)
        ScenarioConfig(**base)
