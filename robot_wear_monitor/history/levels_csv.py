"""Export of stored estimates as a table of friction levels for ``audit``."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Sequence

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.history.records import HistoryRecord
from robot_wear_monitor.json_values import finite_or_none

LEVEL_CSV_COLUMNS = ('speed', 'friction', 'experiment', 'time_s', 'wear_hat',
                     'temperature_hat_degc', 'fit_p_value')


def write_levels_csv(path: str | os.PathLike, *, records: Sequence[HistoryRecord]) -> Path:
    """
    Write the friction levels of stored estimates as a CSV table for ``audit``.

    One row per friction level: ``speed`` [rad/s, motor side], ``friction`` (normalised),
    ``experiment`` (the estimate id, so that the audit folds by experiment), ``time_s`` (stamp
    of the estimate), and the estimate it led to (``wear_hat``, ``temperature_hat_degc``,
    ``fit_p_value``; empty when not finite).  Written through the safe writer (staged, renamed).
    """
    buffer = io.StringIO(newline='')
    writer = csv.writer(buffer)
    writer.writerow(LEVEL_CSV_COLUMNS)
    for number, record in enumerate(records, 1):
        experiment = record.id if record.id is not None else number
        estimate = (record.wear, record.temperature_degc, record.p_value)
        extras = [finite_or_none(value) for value in estimate]
        for speed, friction in zip(record.speeds_rad_s, record.frictions):
            writer.writerow([repr(float(speed)), repr(float(friction)), experiment,
                             repr(float(record.stamp_s)),
                             *('' if v is None else repr(float(v)) for v in extras)])
    return write_text_atomic(path, buffer.getvalue())
