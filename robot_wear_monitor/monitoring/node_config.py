"""
Declaration table of the nodes' ROS parameters: names, types, defaults, descriptions, checks.

The rclpy nodes declare exactly these parameters (with the description as ParameterDescriptor);
the replay, the demo and the tests validate the very same values without rclpy, from the same
``config/wear_monitor.yaml`` (``<node>: ros__parameters: ...``).  Types follow ROS 2 strictly, as
rclpy does when it loads a parameter file: a ``double`` must be written ``35.0`` (``35`` is an
integer) and a ``double_array`` must hold doubles only.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import os
from pathlib import Path
from typing import Any, Callable, Mapping, Optional
import warnings

from robot_wear_monitor.estimation.alarm import AlarmPolicy
from robot_wear_monitor.experiment.plan_config import PlanConfig
from robot_wear_monitor.experiment.segmentation_settings import (ExperimentGrouping,
                                                                 NODE_SCALES, SegmenterConfig)
from robot_wear_monitor.model.params import packaged_config_file, ParameterError
from robot_wear_monitor.monitoring.drain_config import DrainConfig
from robot_wear_monitor.monitoring.runner_config import RunnerConfig
from robot_wear_monitor.monitoring.wear_update import EstimatorConfig
from robot_wear_monitor.setting_fields import declared_settings, non_empty, non_negative
from robot_wear_monitor.yaml_files import load_yaml_file, shorten

FRICTION_EXPERIMENT_NODE = 'friction_experiment_node'
WEAR_ESTIMATOR_NODE = 'wear_estimator_node'
FRICTION_EXPERIMENT_RUNNER_NODE = 'friction_experiment_runner'
NODE_CONFIG_FILE = 'wear_monitor.yaml'

#: N = 4 discrete optimum of Table V [rad/s], the experiment the demo scenario runs.
DEFAULT_EXPERIMENT_SPEEDS_RAD_S = (2.1, 28.5, 35.1, 41.7)

#: A pause longer than this [s] between two friction levels ends an experiment (the default of
#: ``idle_gap_s`` and of the friction experiment service; owned by
#: :class:`~robot_wear_monitor.experiment.segmentation_settings.ExperimentGrouping`).
IDLE_GAP_S = ExperimentGrouping().idle_gap_s

PARAMETER_TYPES = ('bool', 'integer', 'double', 'string', 'double_array', 'string_array')

#: The ROS 2 parameter type of a declared setting's kind.
_ROS_TYPES = {'float': 'double', 'int': 'integer', 'str': 'string', 'bool': 'bool'}


@dataclass(frozen=True)
class ParameterSpec:
    """
    One declared node parameter.

    :ivar name: ROS parameter name.
    :ivar type: one of ``bool``, ``integer``, ``double``, ``string``, ``double_array``,
        ``string_array``.
    :ivar default: default value (of the declared type).
    :ivar description: ParameterDescriptor description, with the unit.
    :ivar check: returns an error text for an invalid value, or None.
    :ivar read_only: cannot be changed after start (the nodes build their core objects once).

    """

    name: str
    type: str  # noqa: A003 - the ROS 2 parameter type, as rclpy names it
    default: Any
    description: str
    check: Optional[Callable[[Any], Optional[str]]] = None
    read_only: bool = True

    @classmethod
    def of(cls, owner: Any, name: str, *, default: Any = None,
           parameter: str | None = None) -> 'ParameterSpec':
        """
        Return the parameter of a declared setting of a configuration dataclass ``owner``.

        The type, default, description (with the unit) and check are the setting's
        (:mod:`robot_wear_monitor.setting_fields`); ``default`` replaces the default where the
        node's differs (the packaged robot's gear ratio), ``parameter`` the name.
        """
        declared = declared_settings(owner)[name]
        return cls(parameter or name, _ROS_TYPES[declared.kind],
                   declared.default if default is None else default, declared.text,
                   declared.check)


def _topic(value: str) -> Optional[str]:
    if value and (value != value.strip() or ' ' in value):
        return 'must be a topic name without spaces (empty: disabled)'
    return None


def _all_positive(values: tuple) -> Optional[str]:
    return None if all(v > 0 for v in values) else 'every element must be > 0'


def _names(values: tuple) -> Optional[str]:
    if not values or not all(v.strip() for v in values):
        return 'must be non-empty names'
    if len(set(values)) != len(values):
        return 'names must be distinct'
    return None


def _speeds(values: tuple) -> Optional[str]:
    if any(v <= 0 for v in values):
        return 'speeds must be > 0 rad/s (motor side)'
    if len(set(values)) != len(values):
        return 'speeds must be distinct'
    return None


def _joint_list(values: tuple) -> Optional[str]:
    if not all(v.strip() for v in values):
        return 'names must not be empty'
    if len(set(values)) != len(values):
        return 'names must be distinct'
    if ALL_JOINTS in values and len(values) > 1:
        return f'"{ALL_JOINTS}" stands alone'
    return None


#: ``joints: [all]``: every joint that appears in /joint_states.
ALL_JOINTS = 'all'

_JOINT = ParameterSpec('joint', 'string', 'joint_2',
                       'name of the monitored joint in /joint_states (when joints is empty)',
                       non_empty)
_JOINTS = ParameterSpec(
    'joints', 'string_array', (),
    'monitored joints (names in /joint_states), or ["all"]: every joint that appears; each '
    'gets its own segmentation, estimator, alarm and history rows, its outputs under the '
    'namespace <joint>/ and its own /diagnostics status; per-joint values as <joint>.<name> '
    '(e.g. joint_3.gear_ratio). Empty: the one joint of "joint", outputs on the plain topics',
    _joint_list)
_SPEEDS = ParameterSpec(
    'experiment_speeds_rad_s', 'double_array', (),
    'motor-side speed levels of one friction experiment [rad/s]; empty (default): found in '
    "the data (the levels' own speeds; an experiment ends at an idle gap or when its speeds "
    'start to repeat); set: only levels within experiment_speed_tolerance_rad_s of these '
    'speeds are kept (the others are counted and reported with their speeds)', _speeds)

FRICTION_EXPERIMENT_PARAMETERS: tuple[ParameterSpec, ...] = (
    _JOINT,
    _JOINTS,
    ParameterSpec.of(SegmenterConfig, 'gear_ratio', default=NODE_SCALES['gear_ratio']),
    ParameterSpec.of(SegmenterConfig, 'torque_scale', default=NODE_SCALES['torque_scale']),
    _SPEEDS,
    ParameterSpec.of(ExperimentGrouping, 'experiment_speed_tolerance_rad_s'),
    ParameterSpec.of(ExperimentGrouping, 'idle_gap_s'),
    *(ParameterSpec.of(SegmenterConfig, name) for name in (
        'standstill_speed_rad_s', 'speed_tolerance_fraction', 'speed_tolerance_rad_s',
        'min_duration_s', 'trim_s', 'min_samples', 'min_window_rad', 'max_gap_s')),
    ParameterSpec('experiment_events_topic', 'string', 'friction_experiment/events',
                  "the friction_experiment_runner's events (start/end/aborted of each "
                  'experiment): an end event closes the experiment at once; empty: not '
                  'subscribed, experiments end at an idle gap only', _topic),
    ParameterSpec.of(DrainConfig, 'drain_period_s'),
    ParameterSpec.of(DrainConfig, 'joint_states_depth'),
)

#: friction_experiment_node parameters that are fields of segmentation.SegmenterConfig.
SEGMENTER_FIELDS = tuple(name for name in declared_settings(SegmenterConfig)
                         if name in {spec.name for spec in FRICTION_EXPERIMENT_PARAMETERS})

WEAR_ESTIMATOR_PARAMETERS: tuple[ParameterSpec, ...] = (
    _JOINT,
    _JOINTS,
    ParameterSpec('parameter_set_file', 'string', '',
                  'friction-model parameter-set YAML; empty: the packaged IRB 6620 joint 2 set'),
    ParameterSpec('wear_threshold', 'double', 0.0,
                  'alarm level of the wear w [-]: the alarm is raised by an estimate >= it; 0 '
                  "(the default): the parameter set's alarm.wear_threshold (35 for the packaged "
                  'set)', non_negative),
    ParameterSpec('wear_warning', 'double', 0.0,
                  'diagnostics WARN when the wear estimate reaches this level [-]; 0 (the '
                  "default): the parameter set's alarm.wear_warning (28 for the packaged set)",
                  non_negative),
    ParameterSpec.of(AlarmPolicy, 'healthy', parameter='wear_healthy'),
    ParameterSpec.of(AlarmPolicy, 'evidence_to_raise', parameter='alarm_evidence'),
    ParameterSpec.of(AlarmPolicy, 'rule', parameter='alarm_rule'),
    ParameterSpec.of(AlarmPolicy, 'probability', parameter='alarm_probability'),
    ParameterSpec.of(EstimatorConfig, 'min_fit_p_value'),
    ParameterSpec.of(EstimatorConfig, 'invalid_fit_p_value'),
    _SPEEDS,
    ParameterSpec('history_file', 'string', '~/.ros/robot_wear_monitor/wear_history.sqlite3',
                  'wear history: an SQLite file, or a PostgreSQL URL '
                  'postgresql://USER@HOST:PORT/DB shared by a fleet (trend and latched alarm '
                  'survive restarts); ":memory:" keeps nothing', non_empty),
    ParameterSpec('robot_id', 'string', '',
                  'the robot these joints belong to: the key of its rows in a fleet history '
                  'and part of the /diagnostics hardware_id (ROBOT/JOINT); empty: the robot '
                  '"default" and hardware_id the joint alone'),
    ParameterSpec('reset_service_enabled', 'bool', True,
                  'offer ~/reset_alarm (std_srvs/Trigger; with joints ~/<joint>/reset_alarm); '
                  'false: no reset service, resets go through the dashboard (stored in the '
                  'history with user and reason)'),
)

#: The friction_experiment_runner's parameters (validated against each other and against the
#: planned motion in ``monitoring.runner``).
FRICTION_EXPERIMENT_RUNNER_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec('joint_names', 'string_array', tuple(f'joint_{i}' for i in range(1, 7)),
                  'every joint of the trajectory controller, in its order', _names),
    ParameterSpec('posture_rad', 'double_array', (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
                  "the held posture, one position per joint_names [rad]; a tested joint's "
                  'value is the centre of its position window; the joints must stand there '
                  'when the experiment starts'),
    ParameterSpec('joints', 'string_array', ('joint_2',),
                  'the tested joints (among joint_names), run one after the other in this '
                  'order', _names),
    ParameterSpec('gear_ratios', 'double_array', (150.0,),
                  'motor speed / joint speed, one per tested joint [-]', _all_positive),
    ParameterSpec('half_ranges_rad', 'double_array', (0.1,),
                  'half width of the position window the constant-speed passes stay in, one '
                  'per tested joint, joint side [rad]', _all_positive),
    ParameterSpec('speeds_rad_s', 'double_array', DEFAULT_EXPERIMENT_SPEEDS_RAD_S,
                  'speeds of the friction experiment, motor side [rad/s] (default: N = 4 '
                  'optimum of Table V)', _speeds),
    # PlanConfig (and plan's --max-acceleration) has no default: the node's is its own
    ParameterSpec.of(PlanConfig, 'max_acceleration_rad_s2', default=5.0),
    ParameterSpec('max_jerk_rad_s3', 'double', 0.0,
                  'joint jerk limit, joint side [rad/s^3]; 0: trapezoidal speed changes',
                  non_negative),
    ParameterSpec('max_speed_rad_s', 'double', 0.0,
                  'joint speed limit, joint side [rad/s]; 0: the fastest designed speed '
                  '(also the speed of the repositioning moves)', non_negative),
    ParameterSpec('position_lower_limits_rad', 'double_array', (),
                  'lower joint limits, one per tested joint [rad]; empty: not checked'),
    ParameterSpec('position_upper_limits_rad', 'double_array', (),
                  'upper joint limits, one per tested joint [rad]; empty: not checked'),
    ParameterSpec.of(PlanConfig, 'rate_hz'),
    ParameterSpec.of(PlanConfig, 'noise_std'),
    ParameterSpec('target_std_error', 'double', 0.001,
                  'wanted standard error of each friction level, normalised [-]; 0: only the '
                  "segmentation's shortest plateau", non_negative),
    ParameterSpec.of(PlanConfig, 'min_duration_s'),
    ParameterSpec.of(PlanConfig, 'trim_s'),
    ParameterSpec.of(PlanConfig, 'min_samples'),
    ParameterSpec.of(PlanConfig, 'dwell_s'),
    *(ParameterSpec.of(RunnerConfig, name) for name in (
        'point_rate_hz', 'controller', 'end_margin_s', 'pause_between_joints_s')),
)

#: Parameters a joint can override as ``<joint>.<name>`` (with ``joints``), per node.
PER_JOINT_PARAMETERS: dict[str, tuple[str, ...]] = {
    FRICTION_EXPERIMENT_NODE: ('gear_ratio', 'torque_scale', 'experiment_speeds_rad_s',
                               'experiment_speed_tolerance_rad_s', 'idle_gap_s',
                               'standstill_speed_rad_s', 'speed_tolerance_fraction',
                               'speed_tolerance_rad_s', 'min_duration_s', 'trim_s',
                               'min_samples', 'min_window_rad', 'max_gap_s'),
    WEAR_ESTIMATOR_NODE: ('parameter_set_file', 'wear_threshold', 'wear_warning', 'wear_healthy',
                          'alarm_evidence', 'alarm_rule', 'alarm_probability',
                          'min_fit_p_value', 'invalid_fit_p_value', 'experiment_speeds_rad_s'),
}

#: Deprecated parameter names, per node: old name -> the name that replaced it.  The old name
#: is still read (a parameter file, ``-p``), with a warning; giving both is an error.
DEPRECATED_PARAMETERS: dict[str, dict[str, str]] = {
    # one setting, one name: the segmentation's (friction_experiment_node) min_duration_s
    FRICTION_EXPERIMENT_RUNNER_NODE: {'min_plateau_s': 'min_duration_s'},
}

NODE_PARAMETERS: dict[str, tuple[ParameterSpec, ...]] = {
    FRICTION_EXPERIMENT_NODE: FRICTION_EXPERIMENT_PARAMETERS,
    WEAR_ESTIMATOR_NODE: WEAR_ESTIMATOR_PARAMETERS,
    FRICTION_EXPERIMENT_RUNNER_NODE: FRICTION_EXPERIMENT_RUNNER_PARAMETERS,
}


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return 'bool'
    if isinstance(value, int):
        return 'integer'
    if isinstance(value, float):
        return 'double'
    if isinstance(value, str):
        return 'string'
    if isinstance(value, (list, tuple)):
        return 'array'
    return type(value).__name__


def coerce_value(spec: ParameterSpec, value: Any, *, source: str = '<parameters>') -> Any:
    """
    Check ``value`` against ``spec`` (type as strict as rclpy, then the range check).

    Returns the value in canonical form (tuple for arrays).

    :raises ParameterError: naming the source, the parameter and the problem.

    """
    where = f'{source}: {spec.name}'
    got = _type_name(value)
    if spec.type == 'double_array':
        if not isinstance(value, (list, tuple)):
            raise ParameterError(f'{where}: expected a list of doubles, got {got} '
                                 f'{shorten(repr(value))}')
        bad = [v for v in value if _type_name(v) != 'double']
        if bad:
            raise ParameterError(f'{where}: every element must be a double (write 2.0, not 2), '
                                 f'got {shorten(repr(bad[0]))}')
        value = tuple(float(v) for v in value)
        if not all(math.isfinite(v) for v in value):
            raise ParameterError(f'{where}: elements must be finite')
    elif spec.type == 'string_array':
        if not isinstance(value, (list, tuple)):
            raise ParameterError(f'{where}: expected a list of strings, got {got} '
                                 f'{shorten(repr(value))}')
        bad = [v for v in value if not isinstance(v, str)]
        if bad:
            raise ParameterError(f'{where}: every element must be a string, got '
                                 f'{shorten(repr(bad[0]))}')
        value = tuple(value)
    elif got != spec.type:
        hint = ' (write it with a decimal point, e.g. 35.0)' if (
            spec.type == 'double' and got == 'integer') else ''
        raise ParameterError(f'{where}: expected a {spec.type}, got {got} '
                             f'{shorten(repr(value))}{hint}')
    elif spec.type == 'double' and not math.isfinite(value):
        raise ParameterError(f'{where}: must be finite, got {shorten(value)}')
    if spec.check is not None:
        problem = spec.check(value)
        if problem:
            raise ParameterError(f'{where}: {problem}, got {shorten(repr(value))}')
    return value


def defaults(node_name: str) -> dict[str, Any]:
    """Return the default parameter values of a node."""
    return {spec.name: spec.default for spec in _specs(node_name)}


def _specs(node_name: str) -> tuple[ParameterSpec, ...]:
    try:
        return NODE_PARAMETERS[node_name]
    except KeyError:
        raise ParameterError(f'unknown node {shorten(repr(node_name))} (expected one of '
                             f'{", ".join(NODE_PARAMETERS)})') from None


def validate_parameters(node_name: str, values: Mapping[str, Any], *,
                        source: str = '<parameters>') -> dict[str, Any]:
    """
    Return defaults overridden by ``values``, each checked; reject unknown names.

    Cross-parameter rule of the estimator: wear_healthy < wear_threshold and
    wear_warning <= wear_threshold, where both are set (0: the parameter set's, checked when
    the set is known, :meth:`~robot_wear_monitor.monitoring.wear_update.EstimatorConfig.
    from_node_parameters`).
    """
    specs = {spec.name: spec for spec in _specs(node_name)}
    values = renamed_parameters(node_name, values, source=source)
    per_joint = PER_JOINT_PARAMETERS.get(node_name, ())
    unknown = sorted(name for name in set(values) - set(specs)
                     if name.rpartition('.')[2] not in per_joint or '.' not in name)
    if unknown:
        hint = (f'; per joint: <joint>.<{"|".join(per_joint)}>' if per_joint else '')
        raise ParameterError(f'{source}: {node_name}: unknown parameter '
                             f'{shorten(repr(unknown[0]))} '
                             f'(known: {", ".join(specs)}{hint})')
    result = {name: coerce_value(spec, spec.default, source='<defaults>')
              for name, spec in specs.items()}
    for name, value in values.items():
        spec = specs.get(name) or specs[name.rpartition('.')[2]]
        coerced = coerce_value(spec, value, source=f'{source}: {name.rpartition(".")[0]}'
                               if name not in specs else source)
        result[name] = coerced
    if node_name == WEAR_ESTIMATOR_NODE and result['wear_threshold'] > 0:
        if not result['wear_healthy'] < result['wear_threshold']:
            raise ParameterError(f'{source}: wear_healthy: must be < wear_threshold, got '
                                 f'{result["wear_healthy"]} >= {result["wear_threshold"]}')
        if result['wear_warning'] > 0 and not result['wear_warning'] <= result['wear_threshold']:
            raise ParameterError(f'{source}: wear_warning: must be <= wear_threshold, got '
                                 f'{result["wear_warning"]} > {result["wear_threshold"]}')
    return result


def renamed_parameters(node_name: str, values: Mapping[str, Any], *,
                       source: str = '<parameters>') -> dict[str, Any]:
    """
    Return ``values`` with each deprecated name of the node replaced by its new name.

    Warns once per old name (:class:`FutureWarning`, shown by default; the rclpy nodes log it);
    the old and the new name both given is a ParameterError.
    """
    renamed = dict(values)
    for old, new in DEPRECATED_PARAMETERS.get(node_name, {}).items():
        if old not in renamed:
            continue
        value = renamed.pop(old)
        if new in renamed and renamed[new] != value:
            raise ParameterError(f'{source}: {old} is the deprecated name of {new}: give one '
                                 f'(got {shorten(repr(value))} and {shorten(repr(renamed[new]))})')
        warnings.warn(f'{source}: {node_name}: parameter {old} is deprecated; use {new}',
                      FutureWarning, stacklevel=3)
        renamed[new] = value
    return renamed


def monitored_joints(values: Mapping[str, Any]) -> Optional[tuple[str, ...]]:
    """Return the joints a node monitors: ``joints``, or ``(joint,)``; None for ``[all]``."""
    joints = tuple(values.get('joints') or ())
    if not joints:
        return (values['joint'],)
    return None if joints == (ALL_JOINTS,) else joints


def per_joint_outputs(values: Mapping[str, Any]) -> bool:
    """Return True when the outputs go under per-joint namespaces (``joints`` is set)."""
    return bool(values.get('joints'))


def joint_parameters(node_name: str, values: Mapping[str, Any], joint: str, *,
                     source: str = '<parameters>') -> dict[str, Any]:
    """
    Return the parameters of one monitored joint: ``<joint>.<name>`` over the node's values.

    ``joint`` is set to the joint; the result is validated as a whole (e.g. the estimator's
    wear_healthy < wear_threshold per joint) and has no dotted names left.
    """
    merged = {k: v for k, v in values.items() if '.' not in k}
    prefix = joint + '.'
    merged.update({k[len(prefix):]: v for k, v in values.items() if k.startswith(prefix)})
    merged['joint'] = joint
    merged['joints'] = ()
    return validate_parameters(node_name, merged, source=f'{source} (joint {joint})')


def joint_namespace(joint: str) -> str:
    """
    Return the topic namespace token of a joint name (invalid characters become ``_``).

    ROS 2 name tokens hold letters, digits and underscores and do not start with a digit.
    """
    token = ''.join(c if c.isascii() and (c.isalnum() or c == '_') else '_' for c in joint)
    return token if token and not token[0].isdigit() else f'joint_{token}'


def _flatten(parameters: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    """Flatten nested mappings to dotted names, as rclpy reads a parameter file."""
    flat: dict[str, Any] = {}
    for key, value in parameters.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            flat.update(_flatten(value, name + '.'))
        else:
            flat[name] = value
    return flat


def default_node_config_file() -> Path:
    """Return the packaged ``config/wear_monitor.yaml`` (see :func:`packaged_config_file`)."""
    return packaged_config_file(NODE_CONFIG_FILE)


def read_ros_parameters_file(path: str | os.PathLike, node_name: str) -> dict[str, Any]:
    """
    Return the raw ``ros__parameters`` of ``node_name`` in a ROS 2 parameter YAML.

    Entries under ``/**`` apply to every node; ``<node>`` and ``/<node>`` are both accepted;
    the node's own entries win.
    """
    source = str(path)
    document = load_yaml_file(path, what='node parameter file', error=ParameterError)
    if not isinstance(document, Mapping):
        raise ParameterError(f'{source}: expected a mapping of node names at the top level')
    merged: dict[str, Any] = {}
    for key in ('/**', node_name, '/' + node_name):
        if key not in document:
            continue
        entry = document[key]
        if not isinstance(entry, Mapping) or 'ros__parameters' not in entry:
            raise ParameterError(f'{source}: {key}: expected a mapping with ros__parameters')
        parameters = entry['ros__parameters']
        if not isinstance(parameters, Mapping):
            raise ParameterError(f'{source}: {key}.ros__parameters: expected a mapping')
        merged.update(_flatten(parameters))
    return merged


def load_node_parameters(node_name: str, path: str | os.PathLike | None = None, *,
                         overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """
    Load, override and validate the parameters of ``node_name`` (packaged file when None).

    Entries of ``/**`` that the node does not declare are ignored, as rclpy does with
    wildcard entries; unknown names under the node's own key are errors.
    """
    file = Path(path) if path is not None else default_node_config_file()
    raw = read_ros_parameters_file(file, node_name)
    own: dict[str, Any] = {}
    document = load_yaml_file(file, what='node parameter file', error=ParameterError) or {}
    for key in (node_name, '/' + node_name):
        if key in document:
            own.update(_flatten(document[key]['ros__parameters']))
    known = {spec.name for spec in _specs(node_name)}
    per_joint = PER_JOINT_PARAMETERS.get(node_name, ())
    values = {k: v for k, v in raw.items() if k in known or k in own
              or ('.' in k and k.rpartition('.')[2] in per_joint)}
    values.update(overrides or {})
    return validate_parameters(node_name, values, source=str(file))


#: A history_file with one of these prefixes is a PostgreSQL URL, not a path.
POSTGRESQL_SCHEMES = ('postgresql://', 'postgres://')


def expand_history_path(history_file: str) -> str:
    """Return the history path with ``~`` and environment variables expanded (URLs as given)."""
    if history_file == ':memory:' or history_file.startswith(POSTGRESQL_SCHEMES):
        return history_file
    return os.path.expandvars(os.path.expanduser(history_file))
