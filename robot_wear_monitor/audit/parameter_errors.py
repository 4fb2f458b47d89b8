"""
The standard errors of an identified friction model's natural parameters (``audit``, ``identify``).

Gauss-Newton covariance of a :class:`~robot_wear_monitor.audit.fitting.Fit`, mapped to the
parameters that ``Base.describe`` names by the delta method; a parameter on its bound is said so.
Units: those of the table (speeds motor side [rad/s], friction in the table's unit).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
from robot_wear_monitor.audit.fitting import AuditTable, Base, Fit


def _flatten(description: Mapping) -> dict[str, float]:
    """Flatten ``describe`` output ({group: {name: value}}) to {name} or {group.name}."""
    out: dict[str, float] = {}
    for group, values in description.items():
        for name, value in values.items():
            out[name if group == 'all' else f'{group}.{name}'] = float(value)
    return out


def parameter_errors(base: Base, table: AuditTable, fit: Fit,
                     nonnegative: bool = False) -> dict[str, tuple]:
    """
    Return the standard errors of the natural parameters (those of ``base.describe``).

    Gauss-Newton covariance s^2 (J^T J)^-1 of all parameters (theta and amplitudes), J the
    Jacobian of the prediction, s^2 = RSS / (n - p), mapped to the natural parameters by the
    delta method.  A parameter that depends on a direction the data do not determine (relative
    singular value below 1e-7) has an infinite standard error.  With ``nonnegative``, the
    amplitudes fitted to exactly 0 are on their bound: held fixed, and flagged.

    :return: name -> (value, standard error, at a bound of theta), in the table's units.

    """
    theta, coef = fit.theta, fit.coef
    x = base.columns(theta, table)
    lower, upper = base.bounds(table)
    cols = []
    for j in range(len(theta)):
        step = 1e-6 * max(abs(theta[j]), 1e-3)
        plus, minus = theta.copy(), theta.copy()
        plus[j] = min(theta[j] + step, upper[j])
        minus[j] = max(theta[j] - step, lower[j])
        cols.append((base.columns(plus, table) - base.columns(minus, table)) @ coef
                    / (plus[j] - minus[j]))
    active = np.concatenate([np.ones(len(theta), dtype=bool),
                             coef > 0 if nonnegative else np.ones(len(coef), dtype=bool)])
    jac = np.column_stack(cols + [x])[:, active]
    n, p = jac.shape
    scale = np.linalg.norm(jac, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    values, vectors = np.linalg.eigh((jac / scale).T @ (jac / scale))
    keep = values > 1e-14 * max(values[-1], 1e-300)
    dof = max(n - int(keep.sum()), 1)
    s2 = float(fit.residual @ fit.residual) / dof
    u = np.concatenate([theta, coef])
    names = list(_flatten(base.describe(theta, coef)))
    reference = np.array(list(_flatten(base.describe(theta, coef)).values()))
    derivative = np.empty((len(names), len(u)))
    for j in range(len(u)):
        step = 1e-6 * max(abs(u[j]), 1e-12)
        shifted = u.copy()
        shifted[j] += step
        value = np.array(list(_flatten(base.describe(shifted[:len(theta)],
                                                     shifted[len(theta):])).values()))
        derivative[:, j] = (value - reference) / step
    on_zero = ~active
    derivative_all, derivative = derivative, derivative[:, active]
    scaled = derivative / scale  # derivative with respect to the scaled parameters
    projected = scaled @ vectors[:, keep]
    variance = s2 * np.sum(projected ** 2 / values[keep], axis=1)
    lost = np.abs(scaled @ vectors[:, ~keep]).max(axis=1, initial=0.0)
    size = np.abs(scaled).max(axis=1, initial=0.0)
    variance = np.where(lost > 1e-6 * np.maximum(size, 1e-300), np.inf, variance)
    on_bound = (np.isclose(theta, lower, rtol=1e-6, atol=0)
                | np.isclose(theta, upper, rtol=1e-6, atol=0))
    on_bound = np.concatenate([on_bound, on_zero[len(theta):]])
    bound_of = {}
    for column in np.flatnonzero(on_bound):
        for row in np.flatnonzero(np.abs(derivative_all[:, column]) > 0):
            bound_of[names[int(row)]] = True
    return {name: (float(reference[i]), float(np.sqrt(variance[i])), bound_of.get(name, False))
            for i, name in enumerate(names)}
