"""The friction levels ``identify`` fits, read from a level CSV, raw runs or a bag.

:func:`load_identify_levels` reads one input of ``identify`` (the healthy-joint baseline or
the accelerated wear test) with :func:`~robot_wear_monitor.audit.data.load_audit_data`, adds
the joint temperature [degC] and the load torque (normalised) recorded on bag topics at each
level's time, numbers the experiments of a bag by the pauses between them, and names or checks
the ``temperature`` and ``load`` columns.  :func:`default_set_name` names the identified set
after its baseline.
"""

from __future__ import annotations

import os
from pathlib import Path
import re

from robot_wear_monitor.audit.data import is_bag, load_audit_data
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.audit.identification import (attach_series, number_experiments,
                                                     prepare_levels)
from robot_wear_monitor.errors import InputError


def load_identify_levels(path: str | os.PathLike, *, role: str, joint: str | None = None,
                         topic: str = '/joint_states', flip_sign: bool = True,
                         gear_ratio: float = 1.0, torque_scale: float = 1.0,
                         temperature_topic: str | None = None, load_topic: str | None = None,
                         experiment_gap_s: float = 10.0,
                         temperature_column: str | None = None,
                         load_column: str | None = None) -> AuditTable:
    """Return the levels of one ``identify`` input with ``temperature`` and ``load`` columns.

    Args:
        path: a level CSV, a raw run, a folder of raw runs or a bag.
        role: 'BASELINE' or 'WEAR' (for messages).
        joint, topic, flip_sign, gear_ratio, torque_scale: as for
            :func:`~robot_wear_monitor.audit.data.load_audit_data` (bag: motor speed =
            gear_ratio x joint speed, normalised torque = effort / torque_scale).
        temperature_topic: bag input: the joint temperature [degC] on this topic
            (sensor_msgs/Temperature or std_msgs/Float64), taken at each level's time.
        load_topic: bag input: the load torque (normalised) on this topic (std_msgs/Float64).
        experiment_gap_s: bag input: levels more than this many seconds apart start a new
            experiment [s].
        temperature_column, load_column: the table's columns holding temperature and load
            (default ``temperature`` and ``load``).

    """
    table = load_audit_data(path, model='speed', joint=joint, topic=topic, flip_sign=flip_sign,
                            gear_ratio=gear_ratio, torque_scale=torque_scale)
    topics = {'temperature': temperature_topic, 'load': load_topic}
    if any(topics.values()):
        if not is_bag(path):
            raise InputError(f'{role} {path}: --temperature-topic and --load-topic are '
                             f'for bag input')
        from robot_wear_monitor.recordings.bags import read_scalar_topic
        for column, name in topics.items():
            if name:
                time_s, values, _ = read_scalar_topic(path, topic=name)
                table = attach_series(table, column=column, time_s=time_s, values=values,
                                      source=f'topic {name}')
    if is_bag(path):
        table = number_experiments(table, gap_s=experiment_gap_s)
    return prepare_levels(table, role=role, temperature_column=temperature_column,
                          load_column=load_column)


def default_set_name(baseline: str | os.PathLike) -> str:
    """Return ``identified_<stem of the baseline>`` (non-identifier characters as '_')."""
    stem = Path(str(baseline).rstrip('/')).name.split('.')[0]
    return 'identified_' + (re.sub(r'[^A-Za-z0-9_]+', '_', stem) or 'set')
