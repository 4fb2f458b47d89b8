"""
The few special functions of the estimation path, on numpy and the standard library.

The estimator, the intervals and the trend need the error function, a log-sum-exp, the
chi-square tail for an integer number of degrees of freedom and one chi-square quantile.
scipy.special has them all, but importing scipy (scipy.special and scipy.linalg) takes about
0.14 s, a third of a whole process that only reads a short bag (``bench/bench_replay.py``):
the replay, the nodes and ``estimate`` would pay it on every start.  So the estimation path
takes them from here, and scipy is imported by the modules that fit or design (``audit``,
``identify``, ``design``).

* :func:`erf`: ``math.erf`` element by element where it is not +-1 to double precision
  (|x| < 6), so equal to ``math.erf`` everywhere;
* :func:`log_sum_exp`: the usual shift by the maximum (as ``scipy.special.logsumexp``);
* :func:`chi2_survival`: the closed forms of the chi-square tail for integer degrees of
  freedom (Abramowitz and Stegun 26.4.4 and 26.4.5), with ``math.erfc`` and ``math.lgamma``;
* :func:`chi2_quantile_one_dof`: the square of a normal quantile (``statistics.NormalDist``).

Each is compared with scipy in ``test/estimation/test_special_functions.py``.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray


#: erf(x) is +-1 to double precision from here on (math.erf(6.0) == 1.0)
_ERF_SATURATED = 6.0
#: the most degrees of freedom :func:`chi2_survival` takes (a sum of dof / 2 terms)
MAX_DOF = 100_000


def erf(x: ArrayLike) -> FloatArray:
    """
    Return the error function of every element of ``x`` (any shape; NaN stays NaN).

    About 50 ns an element that is not saturated, some 7 times scipy's: the trend keeps the
    tables it builds with it (one per distinct experiment interval).
    """
    values = np.asarray(x, dtype=float)
    out = np.sign(values, out=np.empty_like(values))
    inner = np.abs(values) < _ERF_SATURATED
    if np.any(inner):
        picked = values[inner]
        out[inner] = np.fromiter(map(math.erf, picked.tolist()), dtype=float,
                                 count=picked.size)
    return out


def log_sum_exp(values: ArrayLike, *, axis: int = -1) -> FloatArray:
    """Return log(sum(exp(values))) along ``axis`` without overflow (-inf where all are -inf)."""
    a = np.asarray(values, dtype=float)
    if a.shape[axis] == 0:  # an empty sum: log 0
        return np.full(np.delete(a.shape, axis % a.ndim), -np.inf)
    peak = np.max(a, axis=axis, keepdims=True)
    peak = np.where(np.isfinite(peak), peak, 0.0)
    with np.errstate(divide='ignore'):
        total = np.log(np.sum(np.exp(a - peak), axis=axis, keepdims=True)) + peak
    return np.squeeze(total, axis=axis)


def _chi2_survival_one(chi2: float, dof: int) -> float:
    """
    P(X >= chi2) for X chi-square with ``dof`` >= 1 degrees of freedom (A&S 26.4.4/5).

    Q(chi2|2m) = sum_{j<m} e^-h h^j / j!; Q(chi2|2m+1) = erfc(sqrt h) + sum_{j=1..m}
    e^-h h^(j-1/2) / Gamma(j+1/2), with h = chi2 / 2.  The terms are summed by their
    logarithms, so that none underflows where e^-h alone would (large chi2 and dof).
    """
    if math.isnan(chi2):
        return math.nan
    if chi2 <= 0.0:
        return 1.0
    if chi2 == math.inf:
        return 0.0
    half = 0.5 * chi2
    log_half = math.log(half)
    if dof % 2 == 0:
        tail = 0.0
        logs = [j * log_half - half - math.lgamma(j + 1.0) for j in range(dof // 2)]
    else:
        tail = math.erfc(math.sqrt(half))
        logs = [(j - 0.5) * log_half - half - math.lgamma(j + 0.5)
                for j in range(1, (dof - 1) // 2 + 1)]
    if not logs:
        return tail
    peak = max(logs)
    return min(tail + math.exp(peak) * math.fsum(math.exp(v - peak) for v in logs), 1.0)


def chi2_survival(chi2: ArrayLike, dof: ArrayLike) -> FloatArray:
    """
    Return P(X >= chi2) for X chi-square with integer ``dof`` >= 1 (broadcast shapes).

    :raises ValueError: a dof below 1, above :data:`MAX_DOF` or not an integer.

    """
    x, k = np.broadcast_arrays(np.asarray(chi2, dtype=float), np.asarray(dof, dtype=float))
    if k.size and not (np.all(k >= 1) and np.all(k <= MAX_DOF) and np.all(k == np.round(k))):
        raise ValueError(f'chi2_survival: dof must be integers 1-{MAX_DOF}')
    flat = [_chi2_survival_one(c, int(d)) for c, d in zip(x.ravel().tolist(),
                                                          k.ravel().tolist())]
    return np.array(flat, dtype=float).reshape(x.shape)


def chi2_quantile_one_dof(level: float) -> float:
    """Return the ``level`` quantile of the chi-square distribution with 1 degree of freedom."""
    if not 0.0 < level < 1.0:
        raise ValueError(f'chi2_quantile_one_dof: level must be in (0, 1), got {level:.6g}')
    # the lower tail 0.5 (1 - level) keeps its digits as the level nears 1
    return NormalDist().inv_cdf(0.5 * (1.0 - level)) ** 2
