"""
The noise floor: the std of the level error that no model of the table's columns removes.

Compared with the held-out error, it tells whether structure is left (held-out error well above
the floor) or the model is as good as the data allow.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.fitting import as_text, AuditTable
from scipy import spatial


def noise_floor(*, table: AuditTable, residual: FloatArray, n_parameters: int,
                variables: Sequence[str]) -> tuple[float, str]:
    """
    Estimate the std of the level-to-level error that no model of these columns removes.

    1. ``replicates``: rows that agree in every column except the friction ones repeat one
       condition; the pooled within-group std of friction is model-free (used when they give
       at least 10 degrees of freedom and 10 % of the rows).
    2. ``nearest neighbour``: otherwise, half the mean squared difference of the final residuals
       between each level and its nearest neighbour in the space of all variables (each scaled
       to [0, 1], categories kept apart), corrected for the fitted parameters.  Structure the
       model missed is largely differenced out between neighbours.

    Returns (noise floor in friction units, method).
    """
    y = table.numeric['friction']
    n = len(y)
    keys = [k for k in table.columns if k not in ('friction', 'friction_std_error')]
    matrix = np.column_stack(
        [table.numeric[k] if k in table.numeric else
         np.unique(table.text[k], return_inverse=True)[1].astype(float) for k in keys])
    _, inverse, counts = np.unique(matrix, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    dof = int(np.sum(counts - 1))
    if dof >= max(10, n // 10):
        means = np.bincount(inverse, weights=y) / counts
        within = float(np.sum((y - means[inverse]) ** 2))
        return math.sqrt(within / dof), f'replicates ({dof} degrees of freedom)'
    cols = []
    for k in variables:
        if k in table.text or (k in table.numeric and len(np.unique(table.numeric[k])) <= 8):
            codes = np.unique(as_text(table, k), return_inverse=True)[1]
            cols.append(codes * 100.0)
        elif k in table.numeric:
            x = table.numeric[k]
            if k == 'speed':
                x = np.log(x)
            span = float(x.max() - x.min())
            cols.append((x - x.min()) / span if span > 0 else np.zeros(n))
    points = np.column_stack(cols) if cols else np.zeros((n, 1))
    points = points + 1e-9 * np.arange(n)[:, None]  # break exact ties deterministically
    _, index = spatial.cKDTree(points).query(points, k=2)
    diff = residual - residual[index[:, 1]]
    correction = n / max(n - n_parameters, 1)
    return math.sqrt(0.5 * float(np.mean(diff ** 2)) * correction), 'nearest neighbour'


#: Columns that name a run, an experiment or a time, not a condition: replicates differ in them.
RUN_COLUMNS = ('experiment', 'run', 'time_s', 'friction_std_error', 'replicate')
#: Relative tolerance within which two speeds are one set-point (measured speeds scatter).
SPEED_TOLERANCE = 0.01


def replicate_groups(table: AuditTable, variables: Sequence[str]) -> NDArray[np.int64]:
    """
    Return the replicate group of every level: same conditions, whatever the run.

    Conditions are ``variables`` except :data:`RUN_COLUMNS`; speeds within
    :data:`SPEED_TOLERANCE` of each other are one set-point; categories are compared as text.
    """
    n = table.n_rows
    codes = []
    for name in dict.fromkeys(variables):
        if name in RUN_COLUMNS or name not in table.columns:
            continue
        if name == 'speed':
            speed = table.numeric['speed']
            order = np.argsort(speed, kind='stable')
            steps = np.diff(speed[order]) > SPEED_TOLERANCE * speed[order][1:]
            cluster = np.empty(n, dtype=np.int64)
            cluster[order] = np.concatenate(([0], np.cumsum(steps)))
            codes.append(cluster)
        else:
            codes.append(np.unique(as_text(table, name), return_inverse=True)[1].ravel())
    if not codes:
        return np.zeros(n, dtype=np.int64)
    return np.unique(np.column_stack(codes), axis=0, return_inverse=True)[1].ravel()


@dataclass(frozen=True)
class LackOfFit:
    """
    The model's fit against the replicate (pure) error of the table (friction units).

    :ivar pure_error: std of the levels within replicate groups (model-free).
    :ivar pure_dof: its degrees of freedom (levels minus groups).
    :ivar groups: replicate groups (conditions).
    :ivar f_statistic: lack-of-fit F = (SS_lack / dof_lack) / (SS_pure / dof_pure); NaN when
        the model has as many parameters as groups.
    :ivar p_value: P(F_dof_lack,dof_pure >= f_statistic) (NaN when not testable).
    :ivar speed_range: (low, high) motor or joint speed [the table's unit] of the groups whose
        mean residual is more than 3 of its standard errors from 0, or None.

    """

    pure_error: float
    pure_dof: int
    groups: int
    f_statistic: float
    p_value: float
    speed_range: tuple[float, float] | None

    def statement(self, *, alpha: float = 0.01) -> str:
        """Return the lack-of-fit test in words, naming the speeds the model cannot explain."""
        if not math.isfinite(self.p_value):
            return (f'pure error {self.pure_error:.4g} from {self.groups} replicate groups; '
                    'the model has a parameter per group (no lack-of-fit test)')
        text = (f'lack of fit against the pure error {self.pure_error:.4g} ({self.pure_dof} '
                f'degrees of freedom): F = {self.f_statistic:.3g}, p = {self.p_value:.2g}')
        if self.p_value >= alpha:
            return text + ': the model explains the data to the replicate scatter'
        where = ('' if self.speed_range is None else
                 f'; the model cannot explain the speeds {self.speed_range[0]:.4g} to '
                 f'{self.speed_range[1]:.4g}')
        return text + ': significant' + where

    def to_dict(self) -> dict:
        """Return the JSON object of the test (non-finite numbers as None)."""
        def number(value: float) -> float | None:
            return value if math.isfinite(value) else None
        return {'pure_error': self.pure_error, 'pure_dof': self.pure_dof,
                'groups': self.groups, 'f_statistic': number(self.f_statistic),
                'p_value': number(self.p_value),
                'speed_range': None if self.speed_range is None else list(self.speed_range),
                'statement': self.statement()}


def lack_of_fit(*, table: AuditTable, residual: FloatArray, n_parameters: int,
                variables: Sequence[str]) -> LackOfFit | None:
    """
    Test the fit against the pure error of replicated conditions; None without replicates.

    Replicates (:func:`replicate_groups`) need at least 5 degrees of freedom.  The pure error
    is the pooled within-group std of the levels; the lack-of-fit sum of squares is the rest of
    the in-sample residual sum of squares (the classical F test of a regression with repeated
    points).
    """
    # deferred import: start-up time (scipy.stats)
    from scipy import stats
    y = table.numeric['friction']
    n = len(y)
    groups = replicate_groups(table, variables)
    counts = np.bincount(groups)
    pure_dof = int(n - counts.size)
    if pure_dof < 5:
        return None
    means = np.bincount(groups, weights=y) / counts
    ss_pure = float(np.sum((y - means[groups]) ** 2))
    pure = math.sqrt(ss_pure / pure_dof)
    lack_dof = int(counts.size - n_parameters)
    ss_residual = float(np.sum(residual ** 2))
    f_statistic = p_value = math.nan
    if lack_dof > 0 and ss_pure > 0:
        f_statistic = max(ss_residual - ss_pure, 0.0) / lack_dof / (ss_pure / pure_dof)
        p_value = float(stats.f.sf(f_statistic, lack_dof, pure_dof))
    mean_residual = np.bincount(groups, weights=residual) / counts
    off = np.abs(mean_residual) > 3.0 * pure / np.sqrt(counts)
    speed_range = None
    if np.any(off):
        speeds = table.numeric['speed'][np.isin(groups, np.flatnonzero(off))]
        speed_range = (float(speeds.min()), float(speeds.max()))
    return LackOfFit(pure_error=pure, pure_dof=pure_dof, groups=int(counts.size),
                     f_statistic=f_statistic, p_value=p_value, speed_range=speed_range)
