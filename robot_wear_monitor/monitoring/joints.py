"""
Several monitored joints: one segmentation and one estimator per joint.

The nodes and the replay share these objects.  A node (or a replay) monitors the joints of
its ``joints`` parameter, or every joint that appears with ``joints: [all]``, or the one
``joint`` when ``joints`` is empty (the single-joint layout of the first version, unchanged).
Each joint gets its own
:class:`~robot_wear_monitor.monitoring.experiment_service.FrictionExperimentService` and
:class:`~robot_wear_monitor.monitoring.estimator_service.WearEstimatorService`, built from the
node's parameters with the joint's ``<joint>.<name>`` values over them
(:func:`~robot_wear_monitor.monitoring.node_config.joint_parameters`); the estimators share one
history (rows keyed by joint).

Topic mapping (:func:`output_topic`): ``friction_levels`` stays one topic (its
``header.frame_id`` names the joint) and ``/diagnostics`` carries one status per joint; with
``joints`` set, ``temperature``, ``wear``, ``wear_alarm`` and ``wear_trend`` of a joint go
under its namespace, ``<joint>/wear`` etc. (relative to the node's namespace; characters that
a ROS name cannot hold become ``_``), and the alarm reset service is ``~/<joint>/reset_alarm``.
Without ``joints`` they keep their plain names.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Optional, Sequence

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import FrictionExperiment
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.model.params import ParameterError
from robot_wear_monitor.monitoring.estimator_service import (EstimatorConfig, WearEstimatorService,
                                                             WearUpdate)
from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
from robot_wear_monitor.monitoring.node_config import (FRICTION_EXPERIMENT_NODE, joint_namespace,
                                                       joint_parameters, monitored_joints,
                                                       per_joint_outputs, WEAR_ESTIMATOR_NODE)
from robot_wear_monitor.monitoring.topics import (FRICTION_LEVELS_TOPIC, OUTPUT_TOPICS,
                                                  RESET_SERVICE)
from robot_wear_monitor.recordings.messages import (friction_levels_from_msg, MessageError,
                                                    MessageKit)

ParametersFor = Callable[[str], Mapping[str, Any]]


def output_topic(topic: str, joint: str, *, per_joint: bool) -> str:
    """Return the topic of one joint's output ``topic`` (see the module docstring)."""
    if not per_joint or topic.startswith('/') or topic == FRICTION_LEVELS_TOPIC:
        return topic
    if topic.startswith('~/'):
        return f'~/{joint_namespace(joint)}/{topic[2:]}'
    return f'{joint_namespace(joint)}/{topic}'


def reset_service_name(joint: str, *, per_joint: bool) -> str:
    """Return the name of a joint's alarm reset service (``~/reset_alarm`` or per joint)."""
    return output_topic(RESET_SERVICE, joint, per_joint=per_joint)


def _joints_with_values(values: Mapping[str, Any]) -> list[str]:
    """Return the joints that have ``<joint>.<name>`` values, in order of appearance."""
    return list(dict.fromkeys(key.rpartition('.')[0] for key in values if '.' in key))


def rejections_by_joint(counts: Mapping[str, Mapping[str, int]]) -> dict[str, int]:
    """
    Return the rejection counts of several joints as one mapping for a rejection log.

    ``counts``: joint -> reason -> count.  With one joint the reasons keep their names; with
    several each is named ``"<joint>: <reason>"`` (:class:`RejectionLog` still tells routine
    reasons apart).
    """
    several = len(counts) > 1
    total: dict[str, int] = {}
    for joint, reasons in counts.items():
        for reason, count in reasons.items():
            key = f'{joint}: {reason}' if several else reason
            total[key] = total.get(key, 0) + count
    return total


def merge_diagnostics(arrays: Sequence[Any]) -> Any:
    """Return one DiagnosticArray holding the statuses of several (the first one's header)."""
    merged = arrays[0]
    merged.status = [status for array in arrays for status in array.status]
    return merged


class JointExperiments:
    """
    The friction-experiment services of the monitored joints (see the module docstring).

    :ivar services: joint -> service, in the order the joints were configured or first seen.
    :ivar selection: the configured joints, or None for every joint that appears.
    :ivar per_joint: outputs under per-joint namespaces.

    """

    def __init__(self, values: Mapping[str, Any], *,
                 parameters_for: Optional[ParametersFor] = None,
                 source: str = '<parameters>') -> None:
        """
        Build the services of the configured joints (validated node ``values``).

        ``parameters_for(joint)`` returns a joint's validated parameters (the node declares
        ``<joint>.<name>`` first); default: :func:`joint_parameters` over ``values``.
        """
        self.values = values
        self.selection = monitored_joints(values)
        self.per_joint = per_joint_outputs(values)
        self._parameters_for = parameters_for or (lambda joint: joint_parameters(
            FRICTION_EXPERIMENT_NODE, values, joint, source=source))
        self.services: dict[str, FrictionExperimentService] = {}
        #: joints seen under ``[all]`` whose parameters were refused: joint -> the error
        self.refused: dict[str, str] = {}
        # under [all], the joints given their own values are built (and checked) at start
        for joint in self.selection or _joints_with_values(values):
            self.service(joint)

    def service(self, joint: str) -> FrictionExperimentService:
        """
        Return the service of ``joint``, built on first use.

        :raises ParameterError: the joint's parameters are invalid.

        """
        service = self.services.get(joint)
        if service is None:
            parameters = self._parameters_for(joint)
            try:
                service = FrictionExperimentService.from_node_parameters(parameters)
            except ParameterError:
                raise
            except InputError as error:  # e.g. speeds closer than the tolerance allows
                raise ParameterError(f'joint {joint!r}: {error}') from None
            self.services[joint] = service
        return service

    def _discover(self, joint: str) -> None:
        """Build the service of a joint first seen under ``[all]``; refuse it (once) if bad."""
        if joint in self.refused:
            return
        try:
            self.service(joint)
        except InputError as error:  # its parameters: the other joints go on
            self.refused[joint] = str(error).splitlines()[0]

    def seen(self, joint: str) -> Optional[FrictionExperimentService]:
        """Return the service of a joint of the stream (built under [all]); None: not ours."""
        if self.selection is None and isinstance(joint, str) and joint:
            if joint not in self.services:
                self._discover(joint)
            return self.services.get(joint)
        return self.services.get(joint) if self.wants(joint) else None

    def wants(self, joint: str) -> bool:
        """Return True when ``joint`` is monitored."""
        return self.selection is None or joint in self.selection

    def add_joint_state(self, *, stamp_s: float, name: Sequence[str], position: Sequence[float],
                        velocity: Sequence[float], effort: Sequence[float]
                        ) -> list[tuple[FrictionExperimentService, FrictionExperiment]]:
        """Add one JointState to every monitored joint; return the experiments it completes."""
        if self.selection is None:
            for joint in name:
                if isinstance(joint, str) and joint and joint not in self.services:
                    self._discover(joint)
        done = []
        for service in self.services.values():
            done += [(service, experiment) for experiment in service.add_joint_state(
                stamp_s=stamp_s, name=name, position=position, velocity=velocity,
                effort=effort)]
        return done

    def handle_experiment_event_msg(self, msg: Any
                                    ) -> list[tuple[FrictionExperimentService,
                                                    FrictionExperiment]]:
        """Apply one runner event to every joint's service (each takes its own joint's)."""
        done = []
        for service in self.services.values():
            done += [(service, e) for e in service.handle_experiment_event_msg(msg)]
        return done

    def finish(self) -> list[tuple[FrictionExperimentService, FrictionExperiment]]:
        """Flush every joint at the end of the stream."""
        return [(service, e) for service in self.services.values() for e in service.finish()]

    def diagnostics_message(self, kit: MessageKit, *, stamp_s: float) -> Any:
        """Return one DiagnosticArray with the status of every joint (None without joints)."""
        arrays = [s.diagnostics_message(kit, stamp_s=stamp_s) for s in self.services.values()]
        return merge_diagnostics(arrays) if arrays else None


class JointEstimators:
    """
    The wear estimators of the monitored joints, sharing one history.

    ``friction_levels`` messages are routed by their joint (``header.frame_id``); levels of a
    joint that is not monitored are counted in ``rejections`` (``other_joint``).

    :ivar services: joint -> estimator service.
    :ivar selection: the configured joints, or None for every joint that comes.
    :ivar per_joint: outputs under per-joint namespaces.
    :ivar rejections: counts of messages no joint's estimator took, by reason.

    """

    def __init__(self, values: Mapping[str, Any], *, history: WearHistory,
                 parameters_for: Optional[ParametersFor] = None, warm_up: bool = False,
                 source: str = '<parameters>',
                 on_new_service: Optional[Callable[[WearEstimatorService], None]] = None
                 ) -> None:
        """
        Build the estimators of the configured joints (validated node ``values``).

        ``warm_up``: run each new estimator once (imports, caches, the calibration of its
        configured design) before its first experiment.  ``on_new_service(service)`` is called
        for every estimator built (a node advertises its topics there).
        """
        self.values = values
        self.history = history
        self.selection = monitored_joints(values)
        self.per_joint = per_joint_outputs(values)
        self.warm_up = warm_up
        self.on_new_service = on_new_service
        self._parameters_for = parameters_for or (lambda joint: joint_parameters(
            WEAR_ESTIMATOR_NODE, values, joint, source=source))
        self.services: dict[str, WearEstimatorService] = {}
        self.rejections: dict[str, int] = {}
        self.last_rejection = ''
        #: joints whose parameters (or topic namespace) were refused: joint -> the error
        self.refused: dict[str, str] = {}
        # under [all], the joints of the history come back at once (latched alarms, resets),
        # and the joints given their own values are built (and checked) at start
        for joint in self.selection or dict.fromkeys(
                (*history.joints(), *_joints_with_values(values))):
            self.service(joint)

    def service(self, joint: str) -> WearEstimatorService:
        """
        Return the estimator of ``joint``, built (and restored from history) on first use.

        :raises ParameterError: the joint's parameters are invalid.
        :raises InputError: with per-joint outputs, its topic namespace is another joint's.

        """
        service = self.services.get(joint)
        if service is None:
            if self.per_joint:
                token = joint_namespace(joint)
                other = next((j for j in self.services if joint_namespace(j) == token), None)
                if other is not None:
                    raise InputError(f'joint {joint!r}: its topics would be those of joint '
                                     f'{other!r} (namespace {token!r}); rename one')
            config = EstimatorConfig.from_node_parameters(self._parameters_for(joint))
            service = WearEstimatorService(config, history=self.history)
            self.services[joint] = service
            if self.on_new_service is not None:  # advertised first: subscribers discover
                self.on_new_service(service)      # the topics during the warm-up
            if self.warm_up:
                service.warm_up()
        return service

    def handle_friction_levels(self, msg: Any
                               ) -> tuple[Optional[WearEstimatorService], Optional[WearUpdate]]:
        """
        Route one ``friction_levels`` message to its joint's estimator; return its update.

        Returns (None, None) when no monitored joint takes it (counted).
        """
        joint = str(getattr(getattr(msg, 'header', None), 'frame_id', '') or '')
        if not self.per_joint:  # the single-joint layout: its service checks and counts
            service = next(iter(self.services.values()))
            return service, service.handle_friction_levels(msg)
        if not joint or not (self.selection is None or joint in self.selection):
            self._reject('other_joint', f'levels of joint {joint!r}, monitored: '
                                        f'{", ".join(self.services) or "none"}')
            return None, None
        if joint in self.refused:
            self._reject('joint_refused', f'{joint!r}: {self.refused[joint]}')
            return None, None
        try:
            service = self.service(joint)
        except InputError as error:  # its parameters or its name: the other joints go on
            self.refused[joint] = str(error).splitlines()[0]
            self._reject('joint_refused', f'{joint!r}: {self.refused[joint]}')
            return None, None
        return service, service.handle_friction_levels(msg)

    def prepare(self, msgs: Sequence[Any]) -> int:
        """
        Estimate the levels of several ``friction_levels`` messages ahead, per joint.

        Each joint's estimator that exists already prepares its messages' estimates
        (:meth:`WearEstimatorService.prepare`); :meth:`handle_friction_levels` then handles
        every message as without.  Returns how many estimates were prepared.
        """
        by_service: dict[str, list] = {}
        for msg in msgs:
            try:
                levels = friction_levels_from_msg(msg)
            except MessageError:
                continue
            joint = (next(iter(self.services), None) if not self.per_joint
                     else levels.joint)
            if joint in self.services:
                by_service.setdefault(joint, []).append(levels)
        return sum(self.services[joint].prepare(levels)
                   for joint, levels in by_service.items())

    def _reject(self, reason: str, detail: str) -> None:
        self.rejections[reason] = self.rejections.get(reason, 0) + 1
        self.last_rejection = f'{reason}: {detail}'

    def output_messages(self, kit: MessageKit, service: WearEstimatorService,
                        update: WearUpdate) -> list[tuple[str, Any]]:
        """Return (topic, message) of one joint's outputs, topics mapped per joint."""
        return [(output_topic(topic, service.config.joint, per_joint=self.per_joint), msg)
                for topic, msg in service.output_messages(kit, update)]

    def diagnostics_message(self, kit: MessageKit, *, stamp_s: float) -> Any:
        """Return one DiagnosticArray with every joint's current status (None without one)."""
        arrays = [s.diagnostics_message(kit, stamp_s=stamp_s) for s in self.services.values()]
        return merge_diagnostics(arrays) if arrays else None

    def topics(self, joint: str) -> dict[str, str]:
        """Return base topic -> the joint's topic for every estimator output."""
        return {topic: output_topic(topic, joint, per_joint=self.per_joint)
                for topic in OUTPUT_TOPICS if topic != FRICTION_LEVELS_TOPIC}
