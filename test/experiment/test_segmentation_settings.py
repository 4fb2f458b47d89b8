"""
One owner of the segmentation settings: every user takes its two default sets from it.

The bag-and-stream set is the friction_experiment_node's parameter defaults and the packaged
``config/wear_monitor.yaml`` values (the replay's and the nodes' numbers do not move); the
raw-run set is the one measured raw runs were segmented with.
"""

from pathlib import Path

import pytest
from robot_wear_monitor.experiment import segmentation
from robot_wear_monitor.experiment.segmentation_settings import (raw_run_segmenter_config,
                                                                 RAW_RUN_SETTINGS, SegmenterConfig,
                                                                 stream_segmenter_config,
                                                                 STREAM_SETTINGS)
from robot_wear_monitor.experiment.simulation import JointSimConfig, segmenter_config_for
from robot_wear_monitor.monitoring import node_config
from robot_wear_monitor.recordings.tables import kuka_segmenter_config
from robot_wear_monitor.yaml_files import load_yaml_file

CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'wear_monitor.yaml'
# the values the nodes and the replay have always used (node parameters, wear_monitor.yaml)
NODE_VALUES = {'standstill_speed_rad_s': 0.1, 'speed_tolerance_fraction': 0.05,
               'speed_tolerance_rad_s': 0.05, 'min_duration_s': 0.2, 'trim_s': 0.02,
               'min_samples': 20, 'min_window_rad': 0.0, 'max_gap_s': 0.1}


def _defaults(node):
    return node_config.validate_parameters(node, {})


def test_the_stream_set_is_the_node_parameters_and_the_packaged_config():
    assert dict(STREAM_SETTINGS) == NODE_VALUES
    node = _defaults(node_config.FRICTION_EXPERIMENT_NODE)
    yaml = load_yaml_file(CONFIG)['friction_experiment_node']['ros__parameters']
    for name, value in STREAM_SETTINGS.items():
        assert node[name] == value, name
        assert yaml[name] == value, name
    runner = _defaults(node_config.FRICTION_EXPERIMENT_RUNNER_NODE)
    runner_yaml = load_yaml_file(CONFIG)['friction_experiment_runner']['ros__parameters']
    for planned, segmented in (('min_duration_s', 'min_duration_s'), ('trim_s', 'trim_s'),
                               ('min_samples', 'min_samples')):
        assert runner[planned] == runner_yaml[planned] == STREAM_SETTINGS[segmented]


def test_every_constructor_takes_its_set_from_the_owner():
    plain = SegmenterConfig(joint='j')
    for name, value in STREAM_SETTINGS.items():
        assert getattr(plain, name) == value, name
    expected = SegmenterConfig(joint='j', gear_ratio=150.0)
    assert stream_segmenter_config('j', gear_ratio=150.0) == expected
    sim = JointSimConfig()
    simulated = segmenter_config_for(sim)
    for name, value in STREAM_SETTINGS.items():
        if name != 'max_gap_s':  # 5 samples at the simulated rate
            assert getattr(simulated, name) == value, name
    assert simulated.max_gap_s == pytest.approx(5.0 / sim.sample_rate_hz)
    raw = raw_run_segmenter_config()
    for name, value in RAW_RUN_SETTINGS.items():
        assert getattr(raw, name) == value, name
    assert raw.standstill_speed_rad_s == 0.03  # measured raw runs' results do not move


def test_the_split_modules_are_handed_on_by_segmentation():
    from robot_wear_monitor.experiment import assembly, passes, segmentation_settings
    assert segmentation.segment_batch is passes.segment_batch
    assert segmentation.ExperimentAssembler is assembly.ExperimentAssembler
    assert segmentation.SegmenterConfig is segmentation_settings.SegmenterConfig
    for module in (assembly, passes, segmentation_settings, segmentation):
        assert len(Path(module.__file__).read_text().splitlines()) < 800


def test_the_old_name_of_the_raw_run_settings_warns_and_gives_the_same_settings():
    with pytest.warns(DeprecationWarning, match='raw_run_segmenter_config'):
        old = kuka_segmenter_config(joint='iiwa_joint_2', gear_ratio=3.0)
    assert old == raw_run_segmenter_config(joint='iiwa_joint_2', gear_ratio=3.0)
    assert old != raw_run_segmenter_config(joint='iiwa_joint_2')
