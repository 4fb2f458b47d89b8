"""
One owner per setting: the declarations, what is made from them, and the docs' tables.

Each setting is declared once in its component's configuration dataclass
(:mod:`robot_wear_monitor.setting_fields`); the node parameters and the options are made from
the declarations, and the parameter tables of docs/nodes.md and docs/runner.md must name every
parameter with the declared default, type and unit.
"""

import argparse
from pathlib import Path
import re

import pytest
from robot_wear_monitor.cli import options
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.alarm import AlarmPolicy
from robot_wear_monitor.experiment.plan_config import PlanConfig
from robot_wear_monitor.experiment.segmentation_settings import (ExperimentGrouping,
                                                                 NODE_SCALES, SegmenterConfig)
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring import node_config
from robot_wear_monitor.monitoring.runner_config import RunnerConfig
from robot_wear_monitor.monitoring.wear_update import EstimatorConfig
from robot_wear_monitor.setting_fields import (check_settings, declared_settings, problem_of,
                                               setting_of)
from wear_testing.docs_settings import table as docs_table

DOCS = Path(__file__).resolve().parents[1] / 'docs'
OWNERS = (SegmenterConfig, ExperimentGrouping, PlanConfig, RunnerConfig, AlarmPolicy,
          EstimatorConfig)
NODE_OF_TABLE = {'friction_experiment': (node_config.FRICTION_EXPERIMENT_NODE,),
                 'friction_experiment_runner': (node_config.FRICTION_EXPERIMENT_RUNNER_NODE,),
                 'wear_estimator': (node_config.WEAR_ESTIMATOR_NODE,),
                 'both': (node_config.FRICTION_EXPERIMENT_NODE,
                          node_config.WEAR_ESTIMATOR_NODE)}


def _specs(node):
    return {spec.name: spec for spec in node_config.NODE_PARAMETERS[node]}


def _names(cell):
    return re.findall(r'`([a-z_0-9]+)`', cell)


def _number(text):
    try:
        return float(text.strip('`'))
    except ValueError:
        return None


def _check_defaults(names, defaults_cell, specs, where):
    """Compare each number of the defaults cell with its parameter's declared default."""
    values = [v.strip() for v in defaults_cell.split(', ')]
    if len(values) != len(names):
        return 0
    compared = 0
    for name, text in zip(names, values):
        number = _number(text)
        if number is None or specs[name].type not in ('double', 'integer'):
            continue
        assert number == specs[name].default, f'{where}: {name} default {text}, declared ' \
                                              f'{specs[name].default}'
        compared += 1
    return compared


def test_every_declared_setting_has_a_description_a_known_kind_and_a_valid_default():
    for owner in OWNERS:
        declared = declared_settings(owner)
        assert declared, owner
        for name, setting in declared.items():
            assert setting.description and not setting.description.endswith('.'), name
            assert '[' not in setting.description, f'{name}: the unit goes in unit='
            assert setting.kind in ('float', 'int', 'str', 'bool', 'other'), name
            if setting.default is not None:
                assert problem_of(setting, setting.default) is None, (owner.__name__, name)


def test_the_node_parameters_are_the_declarations():
    """Type, default, check and text of a node parameter come from the one declaration."""
    made = {(node_config.FRICTION_EXPERIMENT_NODE, 'min_samples'): (SegmenterConfig,
                                                                    'min_samples'),
            (node_config.FRICTION_EXPERIMENT_RUNNER_NODE, 'min_samples'): (PlanConfig,
                                                                           'min_samples'),
            (node_config.FRICTION_EXPERIMENT_RUNNER_NODE, 'min_duration_s'): (
                PlanConfig, 'min_duration_s'),
            (node_config.FRICTION_EXPERIMENT_NODE, 'idle_gap_s'): (ExperimentGrouping,
                                                                   'idle_gap_s'),
            (node_config.WEAR_ESTIMATOR_NODE, 'wear_healthy'): (AlarmPolicy, 'healthy'),
            (node_config.WEAR_ESTIMATOR_NODE, 'alarm_rule'): (AlarmPolicy, 'rule'),
            (node_config.FRICTION_EXPERIMENT_RUNNER_NODE, 'end_margin_s'): (RunnerConfig,
                                                                            'end_margin_s')}
    for (node, name), (owner, field) in made.items():
        spec, declared = _specs(node)[name], setting_of(owner, field)
        assert spec.default == declared.default and spec.check is declared.check, name
        assert declared.description in spec.description, name
    # the plan's segmentation settings are the segmentation's own (default and check)
    for name in ('min_duration_s', 'trim_s', 'min_samples'):
        plan, segmentation = setting_of(PlanConfig, name), setting_of(SegmenterConfig, name)
        assert (plan.default, plan.check, plan.unit) == (segmentation.default,
                                                         segmentation.check, segmentation.unit)
    # where a node's default differs from its dataclass's, the node names it once
    friction = _specs(node_config.FRICTION_EXPERIMENT_NODE)
    assert friction['gear_ratio'].default == NODE_SCALES['gear_ratio'] == 150.0
    assert friction['torque_scale'].default == NODE_SCALES['torque_scale'] == 10.0
    assert setting_of(SegmenterConfig, 'gear_ratio').default == 1.0
    # the alarm's levels: the node's default 0 stands for the parameter set's (issue 42)
    estimator = _specs(node_config.WEAR_ESTIMATOR_NODE)
    assert estimator['wear_threshold'].default == estimator['wear_warning'].default == 0.0


@pytest.mark.parametrize('value, problem', [(0.0, 'must be > 0 and <= 10000'),
                                            (2e4, 'must be > 0 and <= 10000')])
def test_an_option_a_node_parameter_and_the_dataclass_refuse_alike(value, problem):
    with pytest.raises(argparse.ArgumentTypeError, match=problem):
        options.GEAR_RATIO(str(value))
    with pytest.raises(ParameterError, match=f'gear_ratio: {problem}'):
        node_config.validate_parameters(node_config.FRICTION_EXPERIMENT_NODE,
                                        {'gear_ratio': value})
    with pytest.raises(InputError, match=f'SegmenterConfig.gear_ratio: {problem}'):
        SegmenterConfig(joint='j', gear_ratio=value)
    assert options.GEAR_RATIO('150') == 150.0


def test_check_settings_names_the_field_and_the_value():
    with pytest.raises(InputError, match=r'SegmenterConfig\.min_samples: expected an integer, '
                                         r'got 20\.5'):
        SegmenterConfig(joint='j', min_samples=20.5)
    with pytest.raises(InputError, match=r'plan: min_samples: must be >= 3, got 2'):
        PlanConfig(joint='j', speeds_rad_s=(1.0,), center_rad=0.0, half_range_rad=0.1,
                   max_acceleration_rad_s2=1.0, min_samples=2)
    with pytest.raises(InputError, match='alarm policy: rule: must be "trend" or "estimate"'):
        AlarmPolicy(rule='never')
    check_settings(ExperimentGrouping())  # the defaults are valid


def test_an_option_made_from_a_setting_says_its_unit_and_default():
    parser = argparse.ArgumentParser()
    options.add_setting_option(parser, '--idle-gap', ExperimentGrouping, 'idle_gap_s')
    text = parser.format_help()
    assert '[s]' in text and '(default: 3.0)' in text
    assert parser.parse_args(['--idle-gap', '4']).idle_gap == 4.0
    with pytest.raises(SystemExit):
        parser.parse_args(['--idle-gap', '0'])


def test_the_nodes_table_of_docs_names_every_parameter_with_its_default():
    rows = docs_table(DOCS / 'nodes.md', '| node | parameter | default | meaning |')
    seen = {node: set() for node in node_config.NODE_PARAMETERS}
    compared = 0
    for row in rows:
        node_cell, names_cell, defaults_cell = row[0], row[1], row[2]
        names = _names(names_cell)
        assert names, row
        for node in NODE_OF_TABLE[node_cell]:
            specs = _specs(node)
            for name in names:
                assert name in specs, f'docs/nodes.md names {name} on {node}: not declared'
                seen[node].add(name)
            compared += _check_defaults(names, defaults_cell, specs, f'nodes.md {node}')
    for node, names in seen.items():
        missing = set(_specs(node)) - names
        assert not missing, f'docs/nodes.md lacks {sorted(missing)} of {node}'
    assert compared >= 30


def test_the_runner_table_of_docs_has_each_parameter_type_default_and_unit():
    rows = docs_table(DOCS / 'runner.md', '| parameter | type | default | meaning |')
    specs = _specs(node_config.FRICTION_EXPERIMENT_RUNNER_NODE)
    ros_type = {'double': 'double', 'integer': 'integer', 'string': 'string',
                'double[]': 'double_array', 'string[]': 'string_array'}
    seen = set()
    compared = 0
    for names_cell, types_cell, defaults_cell, meaning in rows:
        names = _names(names_cell)
        types = [t.strip() for t in types_cell.split(',')]
        for k, name in enumerate(names):
            assert name in specs, f'docs/runner.md names {name}: not declared'
            seen.add(name)
            assert ros_type[types[min(k, len(types) - 1)]] == specs[name].type, name
        compared += _check_defaults(names, defaults_cell, specs, 'runner.md')
        if len(names) == 1:  # the units the row states are the declared ones
            for unit in re.findall(r'\[([^\]]+)\]', meaning):
                assert f'[{unit}]' in specs[names[0]].description, (names[0], unit)
    assert seen == set(specs)
    assert compared >= 12
