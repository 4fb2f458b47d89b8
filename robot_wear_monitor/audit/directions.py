"""
Model (4) per direction of motion: a candidate of the speed audit, as ``identify`` fits it.

The levels of eq. (3) average the two directions; levels of one direction each (signed speeds,
one-way runs) may follow model (4) with other terms in each direction (``identify --speed-only``
tests it).  The audit tries the per-direction model as a candidate base: model (4) with its own
F_c, F_s, phi_s, alpha and F_v per direction (within each group, e.g. per joint).  It is taken
when the F-test of the per-direction against the common fit is significant and the held-out
error comes down; the other candidates are then tested against it.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.cross_validation import cv_rms
from robot_wear_monitor.audit.fitting import (as_text, AuditTable, Base, Fit, fit_model,
                                              speed_base)


#: The derived group column of the per-direction model: the group's value and the direction.
DIRECTION_GROUP = 'group_direction'
#: Parameters of model (4) per group.
SPEED_PARAMETERS = 5


def f_test(rss_common: float, rss_split: float, n: int, extra: int,
           n_split: int) -> tuple[float, float]:
    """
    Return (F, p) of a split model with ``extra`` more parameters than the common one.

    F = ((RSS_common - RSS_split) / extra) / (RSS_split / (n - n_split)); NaN when the split
    model leaves no degree of freedom or fits exactly.
    """
    from scipy import stats
    dof = n - n_split
    if dof <= 0 or extra <= 0 or not rss_split > 0:
        return math.nan, math.nan
    f_statistic = max(rss_common - rss_split, 0.0) / extra / (rss_split / dof)
    return float(f_statistic), float(stats.f.sf(f_statistic, extra, dof))


def with_direction_groups(table: AuditTable, group: str | None) -> AuditTable | None:
    """
    Return the table with :data:`DIRECTION_GROUP` (group value and direction), or None.

    None when the table has no ``direction`` column with both directions in a group, or a
    direction of a group has fewer than ``min_speeds`` distinct speeds (model (4) per direction
    would interpolate its training speeds).
    """
    if 'direction' not in table.text:
        return None
    direction = table.text['direction']
    if not {'positive', 'negative'} <= set(direction.tolist()):
        return None
    prefix = as_text(table, group) if group is not None else np.full(table.n_rows, 'all')
    combined = np.char.add(np.char.add(prefix.astype(str), ' '), direction.astype(str))
    return AuditTable(dict(table.numeric), {**table.text, DIRECTION_GROUP: combined},
                      table.source)


@dataclass(frozen=True)
class DirectionTrial:
    """
    The per-direction model tried against the common one.

    :ivar base: model (4) per :data:`DIRECTION_GROUP`.
    :ivar fit: its fit on the whole table.
    :ivar f_statistic: the F-test against the common fit (``5 x groups`` more parameters).
    :ivar log10_p: log10 of its p-value.
    :ivar cv: held-out RMS error [friction units].
    :ivar held_out: held-out residual per level.

    """

    base: Base
    fit: Fit
    f_statistic: float
    log10_p: float
    cv: float
    held_out: FloatArray


def try_per_direction(table: AuditTable, common: Fit, n_common_groups: int,
                      folds: NDArray[np.int_], terms: Sequence = ()) -> DirectionTrial:
    """
    Fit model (4) per direction (table with :data:`DIRECTION_GROUP`), test and validate.

    ``terms``: the effects added so far, kept beside the per-direction model.
    """
    base = speed_base(table, DIRECTION_GROUP)
    fit = fit_model(base, table, list(terms), base.theta0)
    n_groups = len(set(table.text[DIRECTION_GROUP].tolist()))
    rss_common = float(np.sum(common.residual ** 2))
    rss_split = float(np.sum(fit.residual ** 2))
    f_statistic, p_value = f_test(rss_common, rss_split, table.n_rows,
                                  SPEED_PARAMETERS * (n_groups - n_common_groups),
                                  SPEED_PARAMETERS * n_groups)
    cv, held_out = cv_rms(base, table, list(terms), fit.theta, folds)
    log10_p = math.log10(p_value) if p_value > 0 else (
        -300.0 if math.isfinite(p_value) else math.nan)
    return DirectionTrial(base, fit, f_statistic, log10_p, cv, held_out)
