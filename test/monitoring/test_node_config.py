"""Tests of the node parameter table: the packaged file, checks, file layout, defaults."""

import pytest
from robot_wear_monitor.estimation import alarm
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring import node_config


def test_packaged_node_config_is_valid_for_both_nodes():
    experiment = node_config.load_node_parameters(node_config.FRICTION_EXPERIMENT_NODE)
    estimator = node_config.load_node_parameters(node_config.WEAR_ESTIMATOR_NODE)
    # the speeds are found in the data by default; configured, they filter the levels
    assert experiment['experiment_speeds_rad_s'] == estimator['experiment_speeds_rad_s'] == ()
    assert experiment['idle_gap_s'] == 3.0 and experiment['joints'] == ()
    # the alarm's levels default to the parameter set's: 0 in the node, 35 and 28 judged by
    assert estimator['wear_threshold'] == estimator['wear_warning'] == 0.0
    from robot_wear_monitor.monitoring.wear_update import EstimatorConfig
    config = EstimatorConfig.from_node_parameters(estimator)
    assert (config.alarm.threshold, config.wear_warning) == (
        config.params.wear_threshold, config.params.wear_warning) == (35.0, 28.0)
    assert config.levels_warning() == ''
    for specs in node_config.NODE_PARAMETERS.values():
        assert all(spec.description for spec in specs)
    for name in node_config.NODE_PARAMETERS:
        node_config.validate_parameters(name, {})


@pytest.mark.parametrize('node, values, match', [
    ('wear_estimator_node', {'wear_threshold': 35}, 'write it with a decimal point'),
    ('wear_estimator_node', {'wear_threshold': -1.0}, 'must be >= 0'),
    ('wear_estimator_node', {'wear_healthy': 40.0, 'wear_threshold': 35.0},
     'must be < wear_threshold'),
    ('wear_estimator_node', {'min_fit_p_value': 1.5}, r'in \[0, 1\)'),
    ('wear_estimator_node', {'alarm_treshold': 1.0}, 'unknown parameter'),
    ('friction_experiment_node', {'gear_ratio': 0.0}, 'must be > 0'),
    ('friction_experiment_node', {'experiment_speeds_rad_s': [2, 28.5]}, 'every element'),
    ('friction_experiment_node', {'experiment_speeds_rad_s': [2.0, -1.0]}, 'must be > 0'),
    ('friction_experiment_node', {'joint': ''}, 'must not be empty'),
    ('friction_experiment_node', {'min_samples': 2}, 'must be >= 3'),
])
def test_bad_parameters_are_named(node, values, match):
    with pytest.raises(ParameterError, match=match):
        node_config.validate_parameters(node, values)


def test_parameter_file_layout_errors(tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text('wear_estimator_node:\n  ros__parameters:\n    wear_threshold: 30.0\n'
                    '/**:\n  ros__parameters:\n    joint: joint_5\n    gear_ratio: 100.0\n')
    estimator = node_config.load_node_parameters('wear_estimator_node', path)
    assert (estimator['wear_threshold'], estimator['joint']) == (30.0, 'joint_5')
    experiment = node_config.load_node_parameters('friction_experiment_node', path)
    assert experiment['gear_ratio'] == 100.0
    path.write_text('wear_estimator_node:\n  wear_threshold: 30.0\n')
    with pytest.raises(ParameterError, match='ros__parameters'):
        node_config.load_node_parameters('wear_estimator_node', path)
    path.write_text('a: [1\n')
    with pytest.raises(ParameterError, match='not valid YAML'):
        node_config.load_node_parameters('wear_estimator_node', path)


def test_the_node_defaults_are_the_owning_constants():
    estimator = node_config.validate_parameters(node_config.WEAR_ESTIMATOR_NODE, {})
    # wear_threshold and wear_warning: 0, the parameter set's (issue 42)
    assert (estimator['wear_threshold'], estimator['wear_healthy'], estimator['wear_warning'],
            estimator['alarm_rule'], estimator['alarm_probability'],
            estimator['alarm_evidence']) == (
        0.0, alarm.WEAR_HEALTHY, 0.0, alarm.DEFAULT_ALARM_RULE,
        alarm.DEFAULT_ALARM_PROBABILITY, alarm.DEFAULT_ALARM_EVIDENCE)
    experiment = node_config.validate_parameters(node_config.FRICTION_EXPERIMENT_NODE, {})
    assert experiment['idle_gap_s'] == node_config.IDLE_GAP_S
    with pytest.raises(ParameterError, match='must be "trend" or "estimate"'):
        node_config.validate_parameters(node_config.WEAR_ESTIMATOR_NODE,
                                        {'alarm_rule': 'threshold'})


def test_a_deprecated_parameter_name_is_read_with_a_warning():
    runner = node_config.FRICTION_EXPERIMENT_RUNNER_NODE
    with pytest.warns(FutureWarning, match='min_plateau_s is deprecated; use min_duration_s'):
        values = node_config.validate_parameters(runner, {'min_plateau_s': 0.4})
    assert values['min_duration_s'] == 0.4 and 'min_plateau_s' not in values
    with pytest.raises(ParameterError, match='min_plateau_s is the deprecated name of '
                                             'min_duration_s: give one'):
        node_config.validate_parameters(runner, {'min_plateau_s': 0.4, 'min_duration_s': 0.3})


@pytest.mark.parametrize('node', [node_config.FRICTION_EXPERIMENT_NODE,
                                  node_config.FRICTION_EXPERIMENT_RUNNER_NODE])
def test_min_samples_has_one_check_on_every_node(node):
    """The segmentation needs 3 samples per pass; the runner's plan is checked the same."""
    with pytest.raises(ParameterError, match='min_samples: must be >= 3, got 2'):
        node_config.validate_parameters(node, {'min_samples': 2})
    assert node_config.validate_parameters(node, {'min_samples': 3})['min_samples'] == 3


def test_the_sets_levels_are_checked_against_the_nodes_where_the_node_leaves_them_to_it():
    """wear_threshold 0 takes the set's 35: a healthy level of 40 is refused then."""
    from robot_wear_monitor.errors import InputError
    from robot_wear_monitor.monitoring.wear_update import EstimatorConfig
    values = node_config.validate_parameters(node_config.WEAR_ESTIMATOR_NODE,
                                             {'wear_healthy': 40.0})
    with pytest.raises(InputError, match='healthy < threshold'):
        EstimatorConfig.from_node_parameters(values)
    values = node_config.validate_parameters(node_config.WEAR_ESTIMATOR_NODE,
                                             {'wear_warning': 36.0})
    with pytest.raises(InputError, match='wear_warning: must be <= wear_threshold, got 36 > 35'):
        EstimatorConfig.from_node_parameters(values)
