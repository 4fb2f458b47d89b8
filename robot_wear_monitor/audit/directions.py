"""
Model (4) per direction of motion: a candidate of the speed audit, as ``identify`` fits it.

The levels of eq. (3) average the two directions; levels of one direction each (signed speeds,
one-way runs) may follow model (4) with other terms in each direction.  ``identify --speed-only``
and the audit decide it alike (:func:`compare_directions`): model (4) with its own F_c, F_s,
phi_s, alpha and F_v per direction (within each group, e.g. per joint) is taken only when the
F-test against the common fit is significant and its held-out error beats that of every simpler
candidate: the common model, the common model with one offset per direction (the simplest
direction term) and, in the audit, the step's most significant other effect.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.cross_validation import cv_rms
from robot_wear_monitor.audit.fitting import as_text, AuditTable, Base, Fit
from robot_wear_monitor.audit.shapes import Term
from robot_wear_monitor.audit.speed_fit import fit_speed_model, SpeedFit
from robot_wear_monitor.model.extensions import Factor


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
    # deferred import: start-up time (scipy.stats)
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

    ``terms``: the effects added so far, kept beside the per-direction model.  The fit is the
    shared one of :func:`~robot_wear_monitor.audit.speed_fit.fit_speed_model` (F_c, F_s,
    F_v >= 0; unsupported Stribeck terms dropped by BIC).
    """
    fitted = fit_speed_model(table, DIRECTION_GROUP, terms)
    base, fit = fitted.base, fitted.fit
    n_groups = len(set(table.text[DIRECTION_GROUP].tolist()))
    rss_common = float(np.sum(common.residual ** 2))
    rss_split = float(np.sum(fit.residual ** 2))
    f_statistic, p_value = f_test(rss_common, rss_split, table.n_rows,
                                  SPEED_PARAMETERS * (n_groups - n_common_groups),
                                  SPEED_PARAMETERS * n_groups)
    cv, held_out = cv_rms(base, table, list(terms), fit.theta, folds, nonnegative=True)
    log10_p = math.log10(p_value) if p_value > 0 else (
        -300.0 if math.isfinite(p_value) else math.nan)
    return DirectionTrial(base, fit, f_statistic, log10_p, cv, held_out)


def direction_offset(table: AuditTable) -> Term:
    """
    Return one offset per direction (within each group): the simplest direction term.

    Its columns are the indicators of the negative direction of every group of
    :data:`DIRECTION_GROUP` (the positive direction is the common model's own level).
    """
    negative = tuple(sorted(k for k in set(table.text[DIRECTION_GROUP].tolist())
                            if k.endswith(' negative')))
    return Term('offset per direction', 'categorical offset', ('direction',),
                (Factor(DIRECTION_GROUP, 'categories', levels=negative),))


@dataclass(frozen=True)
class DirectionVerdict:
    """
    Model (4) per direction against the simpler candidates, held out.

    :ivar trial: the per-direction model (F-test and held-out error).
    :ivar significant: its F-test is significant at the level used.
    :ivar rivals: simpler candidate -> its held-out RMS error [friction units] (the model
        without a direction term, one offset per direction, an audit step's other effect).
    :ivar preferred: the candidate preferred: ``'model (4) per direction'`` or a rival's name.
    :ivar reason: why, in words.
    :ivar offset: the offset term (one per direction and group).
    :ivar offset_fit: the common model with the terms and the offset.
    :ivar offset_held_out: its held-out residual per level.
    :ivar direction_verdict: the candidate preferred among the direction terms alone (the
        common model, one offset per direction, model (4) per direction), as ``identify
        --speed-only`` decides; ``preferred`` also weighs the ``rivals``.

    """

    trial: DirectionTrial
    significant: bool
    rivals: dict
    preferred: str
    reason: str
    offset: Term | None = None
    offset_fit: SpeedFit | None = None
    offset_held_out: FloatArray | None = None
    direction_verdict: str = ''

    @property
    def per_direction(self) -> bool:
        """Return True when model (4) per direction is taken."""
        return self.preferred == PER_DIRECTION


#: The name of the per-direction model among the candidates.
PER_DIRECTION = 'model (4) per direction'
#: The name of the model without a direction term among the candidates.
WITHOUT_DIRECTIONS = 'model (4) common to both directions'


def compare_directions(table: AuditTable, *, group: str | None, fit: Fit, terms: Sequence,
                       cv_now: float, folds: NDArray[np.int_], n_common_groups: int,
                       level: float, min_gain: float,
                       rivals: dict | None = None) -> DirectionVerdict:
    """
    Decide whether model (4) per direction earns its place held out.

    ``fit``: the common model of model (4) per ``group`` (with the added ``terms``) and its
    held-out RMS error ``cv_now``; ``rivals``: further simpler candidates' held-out errors (an
    audit step's).  The per-direction model is preferred when its F-test is significant at
    ``level`` and its held-out error is below every simpler candidate's by ``min_gain``;
    otherwise the simpler candidate with the lowest held-out error (the model without a
    direction term when none beats it by ``min_gain``).
    """
    trial = try_per_direction(table, fit, n_common_groups, folds, terms)
    offset = direction_offset(table)
    offset_fit = fit_speed_model(table, group, list(terms) + [offset], fit.theta)
    offset_cv, offset_held = cv_rms(offset_fit.base, table, list(terms) + [offset],
                                    offset_fit.fit.theta, folds, nonnegative=True)
    simpler = {WITHOUT_DIRECTIONS: cv_now, offset.name: offset_cv, **(rivals or {})}
    significant = math.isfinite(trial.log10_p) and trial.log10_p <= math.log10(level)
    preferred, reason = _decide(trial, simpler, significant, cv_now, level, min_gain)
    direction_terms = {k: simpler[k] for k in (WITHOUT_DIRECTIONS, offset.name)}
    verdict, _ = _decide(trial, direction_terms, significant, cv_now, level, min_gain)
    return DirectionVerdict(trial, bool(significant), simpler, preferred, reason, offset,
                            offset_fit, offset_held, verdict)


def _decide(trial: DirectionTrial, simpler: dict, significant: bool, cv_now: float,
            level: float, min_gain: float) -> tuple[str, str]:
    """Return (the candidate preferred, why) among the per-direction model and ``simpler``."""
    best_name = min(simpler, key=lambda k: simpler[k])
    beats = trial.cv <= (1.0 - min_gain) * simpler[best_name]
    if significant and beats:
        return PER_DIRECTION, (f'{PER_DIRECTION}: held-out error {trial.cv:.4g} below the '
                               f"simpler candidates' (best: {best_name}, "
                               f'{simpler[best_name]:.4g}; F-test log10 p '
                               f'{trial.log10_p:.1f})')
    if best_name != WITHOUT_DIRECTIONS and not (
            simpler[best_name] <= (1.0 - min_gain) * cv_now):
        best_name = WITHOUT_DIRECTIONS
    why = (f'held-out error {trial.cv:.4g} is not {min_gain:.0%} below '
           f'{simpler[best_name]:.4g} of {best_name}' if significant and not beats else
           f'the directions do not differ significantly (F = {trial.f_statistic:.3g}, '
           f'log10 p {trial.log10_p:.1f} > log10 {level:g})')
    return best_name, f'{best_name} preferred to {PER_DIRECTION}: {why}'
