"""
Cross-validation of the audit and of ``identify``: folds by experiment, held-out error.

A table with an ``experiment`` column is split by experiment (all levels of one experiment are
held out together, so an effect that is constant within an experiment cannot be learnt from the
held-out experiment itself); otherwise by row.  The same column may also be a candidate
variable of the audit (drift over the experiments).
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.fitting import as_text, AuditTable, Base, design_matrix, fit_model


def fold_indices(table: AuditTable, n_folds: int, seed: int) -> tuple[NDArray[np.int_], str]:
    """Fold index of every row: by experiment when the column exists, else by row."""
    rng = np.random.default_rng(seed)
    n = table.n_rows
    if 'experiment' in table.columns:
        values = as_text(table, 'experiment')
        keys = np.array(sorted(set(values.tolist())))
        k = min(n_folds, len(keys))
        if k >= 2:
            order = rng.permutation(len(keys))
            fold_of = {keys[j]: i % k for i, j in enumerate(order)}
            return np.array([fold_of[v] for v in values]), f'experiment ({len(keys)} groups)'
    k = min(n_folds, n)
    return rng.permutation(n) % k, 'rows (no experiment column)'


def cv_rms(base: Base, table: AuditTable, terms: Sequence | Callable, theta: FloatArray,
           folds: NDArray[np.int_], nonnegative: bool = False) -> tuple[float, FloatArray]:
    """
    Held-out RMS error over the folds and the held-out residual of every row.

    ``terms``: the added terms, or a function of the training table that returns them (for a
    term whose shape constant, such as a period, is chosen on the training levels only).
    Every fold's fit runs to convergence (at most 200 evaluations, about 60 on the KUKA data):
    a fit cut off on its way depends on its path, which rounding changes.
    """
    y = table.numeric['friction']
    held_out = np.zeros_like(y)
    for k in np.unique(folds):
        test = folds == k
        train = ~test
        fold_terms = terms(table.subset(train)) if callable(terms) else terms
        fit = fit_model(base, table.subset(train), fold_terms, theta, max_nfev=200,
                        nonnegative=nonnegative)
        x = design_matrix(base, fit.theta, table.subset(test), fold_terms)
        held_out[test] = y[test] - x @ fit.coef
    return float(np.sqrt(np.mean(held_out ** 2))), held_out
