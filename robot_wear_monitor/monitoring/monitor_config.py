"""
The monitoring nodes' configuration as typed objects: what replay, batch and demo pass along.

A node parameter file is read and validated once (:meth:`MonitorConfig.load`); what a joint
gets is then a typed object, built (and its ``<joint>.<name>`` values checked) once per joint:
:class:`FrictionJointConfig` for the segmentation and the experiment grouping, and
:meth:`MonitorConfig.alarm_policy` / :meth:`MonitorConfig.parameter_set_file` for what the
estimator is judged by.  The validated values themselves stay inside (the services are built
from them, as the nodes build theirs from their declared parameters).  Speeds motor side
[rad/s], times [s], wear levels [-].
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
import os
from typing import Any, Mapping, Optional, Sequence

from robot_wear_monitor.estimation.alarm import AlarmPolicy
from robot_wear_monitor.experiment.segmentation_settings import (ExperimentGrouping,
                                                                 SegmenterConfig)
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE,
                                                       joint_parameters, load_node_parameters,
                                                       monitored_joints, validate_parameters,
                                                       WEAR_ESTIMATOR_NODE)
from robot_wear_monitor.monitoring.wear_update import node_alarm_levels


@dataclass(frozen=True)
class FrictionJointConfig:
    """
    One joint's friction-experiment configuration: segmentation, grouping, speeds.

    :ivar segmenter: the joint's segmentation settings (gear ratio and torque scale included).
    :ivar grouping: how its levels are grouped into experiments (tolerance, idle gap).
    :ivar experiment_speeds_rad_s: the speeds of one experiment, motor side [rad/s]; empty:
        found in the data.

    """

    segmenter: SegmenterConfig
    grouping: ExperimentGrouping = ExperimentGrouping()
    experiment_speeds_rad_s: tuple[float, ...] = ()

    @classmethod
    def from_node_parameters(cls, values: Mapping[str, Any]) -> 'FrictionJointConfig':
        """Build from one joint's validated ``friction_experiment_node`` parameters."""
        segmenter_fields = [item.name for item in fields(SegmenterConfig)
                            if item.name in values]
        grouping_fields = [item.name for item in fields(ExperimentGrouping)]
        return cls(segmenter=SegmenterConfig(**{name: values[name]
                                                for name in segmenter_fields}),
                   grouping=ExperimentGrouping(**{name: values[name]
                                                  for name in grouping_fields}),
                   experiment_speeds_rad_s=tuple(values['experiment_speeds_rad_s']))

    @property
    def joint(self) -> str:
        """Return the joint's name."""
        return self.segmenter.joint


@dataclass(frozen=True)
class MonitorConfig:
    """
    The validated parameters of the friction_experiment_node and the wear_estimator_node.

    Picklable (a batch sends it to its workers).  Build it with :meth:`load`; read a joint's
    settings with :meth:`friction_joint`, :meth:`alarm_policy`, :meth:`parameter_set_file`.

    :ivar experiment: the friction_experiment_node's validated values (per-joint
        ``<joint>.<name>`` included), as :func:`~robot_wear_monitor.monitoring.node_config.
        load_node_parameters` returns them.
    :ivar estimator: the wear_estimator_node's.
    :ivar source: where they were read (for messages).

    """

    experiment: Mapping[str, Any]
    estimator: Mapping[str, Any]
    source: str = '<parameters>'
    _joints: dict = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def load(cls, *, config_file: str | os.PathLike | None = None,
             joint: str | None = None, joints: Optional[Sequence[str]] = None,
             gear_ratio: float | None = None, torque_scale: float | None = None,
             params_file: str | None = None, robot: str | None = None,
             history_file: str = ':memory:') -> 'MonitorConfig':
        """
        Read and validate a node parameter file (the packaged one when None), with overrides.

        ``joint``: the one monitored joint (plain topics); ``joints``: several, or
        ``['all']`` (per-joint topics); ``gear_ratio``, ``torque_scale`` (the friction node)
        and ``params_file`` (the estimator's ``parameter_set_file``) apply to every joint
        unless the file gives a joint its own ``<joint>.<name>``; ``robot`` is the estimator's
        ``robot_id``; ``history_file`` its history (the replay opens its own).
        """
        experiment: dict[str, Any] = {}
        estimator: dict[str, Any] = {'history_file': history_file}
        if joint is not None:
            experiment['joint'] = estimator['joint'] = joint
        if joints:
            experiment['joints'] = estimator['joints'] = tuple(joints)
        if gear_ratio is not None:
            experiment['gear_ratio'] = float(gear_ratio)
        if torque_scale is not None:
            experiment['torque_scale'] = float(torque_scale)
        if params_file is not None:
            estimator['parameter_set_file'] = str(params_file)
        if robot is not None:
            estimator['robot_id'] = str(robot)
        return cls(experiment=load_node_parameters(FRICTION_EXPERIMENT_NODE, config_file,
                                                   overrides=experiment),
                   estimator=load_node_parameters(WEAR_ESTIMATOR_NODE, config_file,
                                                  overrides=estimator),
                   source=str(config_file or 'the packaged node config'))

    @property
    def joints(self) -> Optional[tuple[str, ...]]:
        """Return the monitored joints, or None for every joint that appears (``[all]``)."""
        return monitored_joints(self.experiment)

    def _one_joint(self, joint: str | None) -> str:
        if joint is not None:
            return joint
        selection = self.joints
        return selection[0] if selection else str(self.experiment['joint'])

    def friction_joint(self, joint: str | None = None) -> FrictionJointConfig:
        """Return a joint's typed friction-experiment configuration (validated once)."""
        name = self._one_joint(joint)
        key = ('friction', name)
        if key not in self._joints:
            values = joint_parameters(FRICTION_EXPERIMENT_NODE, self.experiment, name,
                                      source=self.source)
            self._joints[key] = FrictionJointConfig.from_node_parameters(values)
        return self._joints[key]

    def _estimator_values(self, joint: str | None) -> Mapping[str, Any]:
        name = self._one_joint(joint)
        key = ('estimator', name)
        if key not in self._joints:
            self._joints[key] = joint_parameters(WEAR_ESTIMATOR_NODE, self.estimator, name,
                                                 source=self.source)
        return self._joints[key]

    def alarm_policy(self, joint: str | None = None) -> AlarmPolicy:
        """Return the alarm rule a joint's estimates are judged by (its threshold [-])."""
        values = self._estimator_values(joint)
        threshold, _ = node_alarm_levels(values, load_parameter_set(
            self.parameter_set_file(joint)))
        return AlarmPolicy(threshold=threshold, healthy=values['wear_healthy'],
                           evidence_to_raise=values['alarm_evidence'],
                           rule=values['alarm_rule'], probability=values['alarm_probability'])

    def parameter_set_file(self, joint: str | None = None) -> str | None:
        """Return a joint's friction-model parameter-set file (None: the packaged set)."""
        return self._estimator_values(joint)['parameter_set_file'] or None

    @property
    def robot(self) -> str | None:
        """Return the estimator's ``robot_id`` (None: unnamed)."""
        return self.estimator.get('robot_id') or None

    def with_experiment_speeds(self, speeds_rad_s: Sequence[float]) -> 'MonitorConfig':
        """Return the configuration with both nodes' ``experiment_speeds_rad_s`` set (checked)."""
        speeds = tuple(float(v) for v in speeds_rad_s)
        return MonitorConfig(
            experiment=validate_parameters(FRICTION_EXPERIMENT_NODE, {
                **self.experiment, 'experiment_speeds_rad_s': speeds}, source=self.source),
            estimator=validate_parameters(WEAR_ESTIMATOR_NODE, {
                **self.estimator, 'experiment_speeds_rad_s': speeds}, source=self.source),
            source=self.source)

    def for_robot(self, robot: str | None) -> 'MonitorConfig':
        """Return the configuration with the estimator's ``robot_id`` set (None: unchanged)."""
        if robot is None:
            return self
        return MonitorConfig(experiment=self.experiment,
                             estimator=validate_parameters(WEAR_ESTIMATOR_NODE, {
                                 **self.estimator, 'robot_id': str(robot)},
                                 source=self.source),
                             source=self.source)
