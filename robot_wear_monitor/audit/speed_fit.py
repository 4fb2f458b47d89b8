"""
The one fitter of the speed model (4), shared by ``identify --speed-only`` and ``audit``.

:func:`fit_speed_model` fits model (4) per group in the paper's domain (F_c, F_s, F_v >= 0 by
non-negative least squares inside the variable projection, phi_s and alpha within their
bounds) from a grid of starts, and drops a group's Stribeck term when the data do not support
it (a lower BIC without it), as the full model (5) does.  Both verbs call it on the same table
and get the same parameters and the same held-out error.

Units: speeds [rad/s] (the table's), friction in the table's unit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import math
from typing import Sequence

import numpy as np
from robot_wear_monitor.audit.fitting import (AuditTable, Base, Fit, fit_model, group_codes,
                                              multistart_fit, speed_base)

#: Parameters of model (4) per group, and those left when the Stribeck term is dropped.
FULL_PARAMETERS, WITHOUT_STRIBECK = 5, 2
#: Starting exponents of the grid of starts (alpha), beside 9 Stribeck speeds per group.
START_ALPHAS = (0.7, 1.0, 1.4, 2.0, 2.8)


@dataclass(frozen=True)
class SpeedFit:
    """
    Model (4) per group fitted in its physical domain.

    :ivar base: model (4) per group (the Stribeck column of the ``dropped`` groups is zero);
        its ``theta0`` is the fitted theta.
    :ivar fit: the fit on the whole table (with the added ``terms``).
    :ivar keys: the group names (``('all',)`` without a group).
    :ivar dropped: groups whose Stribeck term the data do not support (BIC): F_s = 0, phi_s
        and alpha undetermined.

    """

    base: Base
    fit: Fit
    keys: tuple[str, ...]
    dropped: tuple[str, ...]

    @property
    def n_parameters(self) -> int:
        """Return the number of parameters of model (4) over the groups (BIC's count)."""
        return (FULL_PARAMETERS * len(self.keys)
                - (FULL_PARAMETERS - WITHOUT_STRIBECK) * len(self.dropped))


def _bic(residual: np.ndarray, n_parameters: int) -> float:
    """Return n log(RSS / n) + p log n."""
    n = len(residual)
    return n * math.log(max(float(residual @ residual), 1e-300) / n) + n_parameters * math.log(n)


def _one_group(table: AuditTable) -> tuple[np.ndarray, bool]:
    """
    Fit model (4) to one group's levels; return (theta, Stribeck term dropped).

    Starts: the coarse-grid start of :func:`speed_base` and 9 x 5 Stribeck speeds and exponents
    over the bounds; the three best by projected RSS are fitted.  The Stribeck term is dropped
    when F_c + F_v v has the lower BIC.
    """
    base = speed_base(table, None)
    lower, upper = base.bounds(table)
    starts = [base.theta0] + [np.array([log_phi, alpha])
                              for log_phi in np.linspace(lower[0], upper[0], 9)
                              for alpha in START_ALPHAS]
    full, _ = multistart_fit(base, table, starts, n_best=3, nonnegative=True)
    reduced_base = speed_base(table, None, without_stribeck=('all',))
    reduced = fit_model(reduced_base, table, [], full.theta, max_nfev=200, nonnegative=True)
    dropped = _bic(reduced.residual, WITHOUT_STRIBECK) <= _bic(full.residual, FULL_PARAMETERS)
    return full.theta, bool(dropped)


def fit_speed_model(table: AuditTable, group: str | None, terms: Sequence = (),
                    theta: np.ndarray | None = None) -> SpeedFit:
    """
    Fit model (4) per value of ``group`` (one model without) in its physical domain.

    Without ``terms``, every group is fitted on its own levels (:func:`_one_group`: starts,
    bounds, BIC) and the groups' fits are joined (``identify --speed-only`` and the audit's fit
    before any effect).  With the ``terms`` an audit added (their amplitudes free, those of
    model (4) >= 0) the whole table is fitted from ``theta`` (else the groups' fits) and each
    group's Stribeck term is kept or dropped by the BIC of the whole fit with the terms: an
    effect the common model lacked (an offset per direction) can make a Stribeck term
    supported that was not without it, or the other way round.
    """
    keys, codes = group_codes(table, group)
    thetas, dropped = [], []
    if theta is None or not terms:
        for i, key in enumerate(keys):
            one, drop = _one_group(table.subset(codes == i))
            thetas.append(one)
            if drop:
                dropped.append(key)
        theta = np.concatenate(thetas)
    if terms:
        dropped = []
        full = speed_base(table, group)
        fit = fit_model(full, table, list(terms), theta, max_nfev=200, nonnegative=True)
        best = _bic(fit.residual, FULL_PARAMETERS * len(keys))
        for key in keys:
            trial_base = speed_base(table, group, without_stribeck=tuple(dropped) + (key,))
            trial = fit_model(trial_base, table, list(terms), fit.theta, max_nfev=200,
                              nonnegative=True)
            bic = _bic(trial.residual, FULL_PARAMETERS * len(keys) - (
                FULL_PARAMETERS - WITHOUT_STRIBECK) * (len(dropped) + 1))
            if bic <= best:
                best, fit = bic, trial
                dropped.append(key)
        base = speed_base(table, group, without_stribeck=tuple(dropped))
        return SpeedFit(replace(base, theta0=fit.theta), fit, tuple(keys), tuple(dropped))
    base = speed_base(table, group, without_stribeck=tuple(dropped))
    lower, upper = base.bounds(table)
    theta = np.clip(theta, lower + 1e-9, upper - 1e-9)
    fit = fit_model(base, table, [], theta, max_nfev=200, nonnegative=True)
    return SpeedFit(replace(base, theta0=fit.theta), fit, tuple(keys), tuple(dropped))
