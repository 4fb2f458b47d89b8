"""
Files of a planned friction-experiment trajectory: JointTrajectory YAML, one-message bag, CSV.

* YAML: the fields of a ``trajectory_msgs/msg/JointTrajectory``, as ``ros2 topic pub`` takes
  them: ``ros2 topic pub --once /joint_trajectory_controller/joint_trajectory
  trajectory_msgs/msg/JointTrajectory "$(cat plan.yaml)"``.
* Bag: one JointTrajectory message on ``/<controller>/joint_trajectory`` (rosbags, Jazzy
  typestore), for ``ros2 bag play`` or ``robot-wear-monitor play``.
* CSV: ``time_s,position_rad,velocity_rad_s,acceleration_rad_s2,speed_index`` of the tested
  joint at the JointState rate (joint side).

Every file is written atomically (a temporary sibling renamed on success).
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.planning import ExperimentPlan, TrajectoryPoints
from robot_wear_monitor.recordings import messages
from robot_wear_monitor.recordings.bags import atomic_bag_writer, MONITOR_TYPESTORE
import yaml

#: Default controller of ros2_control whose ``joint_trajectory`` topic takes the plan.
DEFAULT_CONTROLLER = 'joint_trajectory_controller'


def controller_topic(controller: str) -> str:
    """Return ``/<controller>/joint_trajectory`` (the joint_trajectory_controller's input)."""
    name = controller.strip('/')
    if not name:
        raise InputError('controller: must be a non-empty name')
    return f'/{name}/joint_trajectory'


def trajectory_yaml(points: TrajectoryPoints) -> str:
    """Return the JointTrajectory of ``points`` as YAML text (``ros2 topic pub`` syntax)."""
    return yaml.safe_dump(messages.trajectory_to_dict(points), sort_keys=False,
                          default_flow_style=None, width=99)


def write_trajectory_yaml(path: str | os.PathLike, points: TrajectoryPoints) -> Path:
    """Write :func:`trajectory_yaml` to ``path`` atomically."""
    return write_text_atomic(path, trajectory_yaml(points))


def write_trajectory_bag(path: str | os.PathLike, points: TrajectoryPoints, *,
                         controller: str = DEFAULT_CONTROLLER, storage: str = 'mcap',
                         overwrite: bool = False) -> Path:
    """Write one JointTrajectory message (bag time 0, header stamp 0) as a bag folder."""
    msg = messages.trajectory_to_msg(messages.rosbags_kit(MONITOR_TYPESTORE), points=points)
    topic = controller_topic(controller)
    with atomic_bag_writer(path, storage=storage, overwrite=overwrite) as bag:
        bag.add_topic(topic, messages.TRAJECTORY_TYPE)
        bag.write(topic, msg, 0)
    return Path(path)


def trajectory_csv(plan: ExperimentPlan, *, rate_hz: float | None = None) -> str:
    """Return the tested joint's sampled plan as CSV text (see the module docstring)."""
    t, q, v, a, index = plan.sampled(rate_hz)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator='\n')
    writer.writerow(['time_s', 'position_rad', 'velocity_rad_s', 'acceleration_rad_s2',
                     'speed_index'])
    for row in zip(t, q, v, a, index):
        writer.writerow([f'{row[0]:.6f}', f'{row[1]:.9f}', f'{row[2]:.9f}', f'{row[3]:.6f}',
                         int(row[4])])
    return buffer.getvalue()


def write_trajectory_csv(path: str | os.PathLike, plan: ExperimentPlan, *,
                         rate_hz: float | None = None) -> Path:
    """Write :func:`trajectory_csv` to ``path`` atomically."""
    return write_text_atomic(path, trajectory_csv(plan, rate_hz=rate_hz))
