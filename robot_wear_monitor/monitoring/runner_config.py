"""
The friction_experiment_runner's run configuration: :class:`RunnerConfig`, settings declared once.

Split from :mod:`robot_wear_monitor.monitoring.runner` (which re-exports it) so that the node
parameter table, ``plan``'s options and the docs read the timing defaults without loading the
runner (numpy).  Times [s], rates [Hz], positions [rad].
"""

from __future__ import annotations

from dataclasses import dataclass

from robot_wear_monitor.experiment.plan_config import PlanConfig
from robot_wear_monitor.setting_fields import (check_settings, non_empty, non_negative,
                                               positive, setting)


def trajectory_topic(controller: str) -> str:
    """Return the JointTrajectory topic of a ros2_control joint_trajectory_controller."""
    return f'/{controller.strip("/")}/joint_trajectory'


@dataclass(frozen=True)
class RunnerConfig:
    """
    What one start request runs: a plan configuration per tested joint and the timing.

    :ivar plans: one PlanConfig per tested joint, in the order they are run.
    :ivar joint_names: every joint of the controller.
    :ivar posture_rad: the held posture, one per ``joint_names`` [rad].

    The timing settings are declared once (:func:`robot_wear_monitor.setting_fields.setting`);
    the ``friction_experiment_runner`` node's parameters of the same names are made from them.

    """

    plans: tuple[PlanConfig, ...]
    joint_names: tuple[str, ...]
    posture_rad: tuple[float, ...]
    point_rate_hz: float = setting(
        50.0, unit='Hz', check=positive,
        description='rate of the JointTrajectory points (every phase end is a point too)')
    controller: str = setting(
        'joint_trajectory_controller', check=non_empty,
        description='the ros2_control joint_trajectory_controller: the motion goes to '
                    '/<controller>/joint_trajectory')
    end_margin_s: float = setting(
        0.5, unit='s', check=non_negative,
        description='the end event comes this long after the planned end of the motion (the '
                    'last samples reach the segmentation)')
    pause_between_joints_s: float = setting(
        1.0, unit='s', check=non_negative,
        description='standstill between the end event of one tested joint and the start of '
                    'the next')

    def __post_init__(self) -> None:
        """Check the declared settings; raise InputError naming the first bad one."""
        check_settings(self)

    @property
    def trajectory_topic(self) -> str:
        """Return ``/<controller>/joint_trajectory``."""
        return trajectory_topic(self.controller)

    @property
    def joints(self) -> tuple[str, ...]:
        """Return the tested joints, in the order they are run."""
        return tuple(plan.joint for plan in self.plans)
