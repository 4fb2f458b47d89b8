"""
The tests: is there structure in the residual along a candidate basis.

Nested F-tests at the fitted model, linearised: the model's design columns and its Jacobian in
the nonlinear parameters (Stribeck speeds, alpha, T_V0) span the null space that is projected out
of every candidate basis, so a candidate in one of the model's own variables is tested only in
the shapes the model lacks.  The p-values of one step are controlled together by
Benjamini-Hochberg; a sinusoid's period is scanned and its p-value Bonferroni-corrected for the
number of independent frequencies.  When several candidates are significant, the others are
re-tested given the best one: those left without evidence are confounded with it.  Bases
are tested with the experiments as random effects (:class:`Tester`).
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.fitting import orthonormal
from scipy import optimize, stats


def nested_test(q0: FloatArray, residual: FloatArray, basis: FloatArray,
                n_theta: int = 0) -> tuple[float, int]:
    """
    F-test of adding ``basis`` to the linear model spanned by q0 (orthonormal).

    Returns (natural log of the p-value, numerator degrees of freedom); (0, 0) when nothing new
    is spanned.
    """
    perp = basis - q0 @ (q0.T @ basis)
    q1 = orthonormal(perp, tol=1e-5)
    df1 = q1.shape[1]
    n = len(residual)
    df2 = n - q0.shape[1] - df1 - n_theta
    if df1 == 0 or df2 <= 0:
        return 0.0, 0
    rss0 = float(residual @ residual)
    gain = float(np.sum((q1.T @ residual) ** 2))
    rss1 = max(rss0 - gain, 1e-300)
    f_value = (gain / df1) / (rss1 / df2)
    return _log_f_tail(f_value, df1, df2), df1


def _log_f_tail(f_value: float, df1: int, df2: int) -> float:
    """
    Return log P(F > f) of the F(df1, df2) distribution, finite far in the tail.

    Where scipy's value underflows (-inf), the leading term of the chi-square tail of
    df1 x F is used, so that candidates far in the tail are still ranked by their evidence.
    """
    value = float(stats.f.logsf(f_value, df1, df2))
    if math.isfinite(value):
        return value
    x = 0.5 * df1 * f_value
    return -x + (0.5 * df1 - 1.0) * math.log(x) - math.lgamma(0.5 * df1)


def sinusoid(x: FloatArray, frequency: float) -> FloatArray:
    """Return [sin, cos] of 2 pi f x, shape (n, 2)."""
    return np.column_stack([np.sin(2 * np.pi * frequency * x), np.cos(2 * np.pi * frequency * x)])


def periodic_scan(basis_of: Callable[[float], FloatArray], frequencies: FloatArray,
                  test: Callable[[FloatArray], tuple[float, int]]) -> tuple[float, float]:
    """
    Scan the frequency of a sinusoid; return (log p, period).

    ``basis_of(f)`` gives the [sin, cos] columns at frequency f and ``test(basis)`` its
    (log p, df).  The grid's best frequency is refined by a bounded scalar search; the p-value
    is Bonferroni-corrected for the number of whole periods the scan spans.
    """
    scanned = np.array([test(basis_of(f))[0] for f in frequencies])
    # peaks that agree to rounding (1e-9 of the log p) are a tie: the lowest frequency wins,
    # so that the choice does not follow the summation order of the BLAS
    lowest = float(scanned.min())
    first = int(np.flatnonzero(scanned <= lowest + 1e-9 * max(1.0, abs(lowest)))[0])
    best = (float(scanned[first]), 1.0 / float(frequencies[first]))
    step = float(frequencies[1] - frequencies[0]) if len(frequencies) > 1 else 0.1 / best[1]
    f0 = 1.0 / best[1]
    refined = optimize.minimize_scalar(lambda f: test(basis_of(f))[0],
                                       bounds=(f0 - step, f0 + step), method='bounded',
                                       options={'xatol': 1e-4 * step})
    if refined.fun < best[0]:
        best = (float(refined.fun), 1.0 / float(refined.x))
    n_independent = max(2.0, float(frequencies[-1] / frequencies[0]))
    return min(0.0, best[0] + math.log(n_independent)), best[1]


class Tester:
    """
    Nested F-tests of candidate bases against the model, with experiments as random effects.

    The levels of one experiment share its operating point; structure the model leaves at the
    experiment level (an effect of some per-experiment variable) makes the levels of an
    experiment correlated, and a level-by-level F-test would then count them as independent
    evidence for any per-experiment candidate that happens to correlate with it.  The tests are
    therefore generalised least squares with a random experiment offset (random-effects
    "quasi-demeaning"): every column and the residual become x - (1 - lambda) mean_e(x), with
    lambda^2 = s_within^2 / s_between^2 (clipped to 1) estimated from the model's residual.
    Without such structure lambda = 1 and the test is the ordinary one; with it, evidence
    between experiments counts with the experiments' own scatter.  Without experiments (or with
    one level each) every basis is tested level by level.
    """

    def __init__(self, q0: FloatArray, residual: FloatArray, experiments: NDArray | None,
                 scatter_from: FloatArray | None = None):
        """
        Prepare the tests against the orthonormal model span q0 and its residual.

        ``experiments``: the experiment index of every level, or None for level-by-level tests.
        ``scatter_from``: columns added to the model only to estimate lambda (the alternative
        model of a test: its residual is what is left when the tested term is true).
        """
        self.raw = (q0, residual, experiments)
        self.codes = experiments
        if experiments is not None and np.bincount(experiments).max() < 2:
            self.codes = None
        self.shrink = 1.0
        if self.codes is not None:
            self.counts = np.bincount(self.codes).astype(float)
            n, n_groups = len(residual), len(self.counts)
            rest, rank = residual, q0.shape[1]
            if scatter_from is not None:
                q = orthonormal(np.column_stack([q0, scatter_from]))
                rest, rank = residual - q @ (q.T @ residual), q.shape[1]
            means = self._means(rest[:, None])[:, 0]
            between = float(np.sum(self.counts * means ** 2))
            within = float(np.sum((rest - means[self.codes]) ** 2))
            s2_between = between / max(n_groups - min(rank, n_groups - 1), 1)
            s2_within = within / max(n - n_groups - rank, 1)
            self.shrink = 1.0 - math.sqrt(min(1.0, s2_within / max(s2_between, 1e-300)))
        self.q0 = orthonormal(self.transform(q0), tol=1e-5)
        r = self.transform(residual[:, None])[:, 0]
        self.residual = r - self.q0 @ (self.q0.T @ r)

    def with_columns(self, basis: FloatArray, alternative: FloatArray | None = None) -> 'Tester':
        """
        Return the tester of the model plus ``basis``.

        lambda is estimated anew, from the residual of the model plus ``basis`` plus
        ``alternative`` (the term to be tested) when given.
        """
        q0, residual, experiments = self.raw
        q = orthonormal(np.column_stack([q0, basis]))
        return Tester(q, residual - q @ (q.T @ residual), experiments, alternative)

    def _means(self, x: FloatArray) -> FloatArray:
        assert self.codes is not None  # the means are of the experiments, when known
        sums = np.zeros((len(self.counts), x.shape[1]))
        np.add.at(sums, self.codes, x)
        return sums / self.counts[:, None]

    @property
    def lambda_(self) -> float:
        """Return lambda: 1 without experiment-level structure, smaller with it."""
        return 1.0 - self.shrink

    def transform(self, x: FloatArray) -> FloatArray:
        """Return x - (1 - lambda) x its experiment means, column by column, shape (n, k)."""
        if self.codes is None or self.shrink == 0.0:
            return x
        return x - self.shrink * self._means(x)[self.codes]

    def test(self, basis: FloatArray, given: FloatArray | None = None) -> tuple[float, int]:
        """Return (log p, df) of adding ``basis`` to the model (plus ``given`` columns)."""
        q0, residual = self.q0, self.residual
        if given is not None:
            q0 = orthonormal(np.column_stack([q0, self.transform(given)]))
            residual = residual - q0 @ (q0.T @ residual)
        return nested_test(q0, residual, self.transform(basis))


def benjamini_hochberg(log_p: Sequence[float] | FloatArray) -> FloatArray:
    """Return the Benjamini-Hochberg adjusted p-values (q-values) of natural-log p-values."""
    return stats.false_discovery_control(np.exp(np.asarray(log_p, dtype=float)), method='bh')


def confounded(tester: Tester, chosen: FloatArray, others: Sequence[tuple[str, FloatArray]],
               level: float) -> list[dict]:
    """
    Re-test candidates given the chosen basis; return those left without evidence.

    :param tester: the tests against the model.
    :param chosen: basis of the named effect.
    :param others: (candidate key, basis) of the other significant candidates.
    :param level: p-value above which a candidate has no evidence of its own.

    :return: [{'candidate', 'log10_p_alone', 'log10_p_given_chosen'}] of the confounded ones.

    """
    out = []
    for key, basis in others:
        alone, _ = tester.test(basis)
        given, df = tester.test(basis, chosen)
        if df == 0 or given > math.log(level):
            out.append({'candidate': key, 'log10_p_alone': alone / math.log(10),
                        'log10_p_given_chosen': given / math.log(10)})
    return out
