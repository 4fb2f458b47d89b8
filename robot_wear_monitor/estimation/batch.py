"""
Estimates of many experiments at once, each at its own measured speeds.

A monitor estimates one experiment at a time, and the measured speeds of its experiments differ
by a few mrad/s, so :func:`~robot_wear_monitor.estimation.estimator.estimate_wear` (one design
per call) cannot batch them.  A replay has many completed experiments at hand at once:
:func:`estimate_wear_rows` estimates them together, every row with its own speeds.  Each row's
start grid is its own (it depends on the speeds), and the local refinement of all rows runs as
one batched iteration on a stacked problem (the speeds and whitening matrix of every row), so
the hundred numpy calls of an iteration are paid once for the batch, not once per experiment.

Every operation of the refinement is row by row (each row iterates until it converges, as
alone), so row ``i`` of the result equals ``estimate_wear(speeds[i], friction[i])`` number for
number (the tests assert it on simulated and foreign recordings).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.estimation import estimator as core
from robot_wear_monitor.model.params import ParameterSet

FloatArray = NDArray[np.float64]


class _StackedProblem(core._WhitenedProblem):
    """The weighted least squares (16) of B rows, each at its own speeds (B, N)."""

    def __init__(self, speeds: FloatArray, whiten: FloatArray, params: ParameterSet) -> None:
        # no super().__init__: the rows' whitening matrices come from their own problems
        self.speeds = speeds
        self.speed_rows = speeds
        self.whiten = whiten
        self.params = params
        self.t_min = params.temperature_min_degc
        self.t_max = params.temperature_max_degc
        self._grid_cache = None

    @classmethod
    def of(cls, problems: Sequence[core._WhitenedProblem],
           params: ParameterSet) -> '_StackedProblem':
        """Return the stacked problem of one problem per row."""
        return cls(np.stack([p.speeds for p in problems]),
                   np.stack([p.whiten for p in problems]), params)

    def apply(self, values: FloatArray) -> FloatArray:
        """Return the whitened values (B, N), every row by its own matrix."""
        return np.einsum('bn,bmn->bm', values, self.whiten)

    def rows(self, index: NDArray[np.intp]) -> '_StackedProblem':
        """Return the problem of the rows ``index``."""
        return _StackedProblem(self.speeds[index], self.whiten[index], self.params)


def estimate_wear_rows(speeds_rad_s: Sequence[ArrayLike], friction: Sequence[ArrayLike], *,
                       params: ParameterSet) -> list[core.WearEstimates]:
    """
    Estimate (T, w) of B experiments, each with its own speeds; one batch of 1 per row.

    Row ``i`` of the result equals ``estimate_wear(speeds_rad_s[i], friction[i],
    params=params)``; rows with N >= 2 levels are refined together (rows of equal N), rows
    with one level are estimated one by one.

    :raises InputError: bad speeds or friction in a row (as :func:`estimate_wear`).

    """
    if len(speeds_rad_s) != len(friction):
        raise ValueError('speeds_rad_s and friction: one entry per experiment')
    speeds = [core.validate_speeds(s) for s in speeds_rad_s]
    values = [core._validate_friction(f, s.size) for s, f in zip(speeds, friction)]
    results: list[core.WearEstimates | None] = [None] * len(speeds)
    by_size: dict[int, list[int]] = {}
    for i, (s, v) in enumerate(zip(speeds, values)):
        if s.size == 1 or v.shape[0] != 1:
            results[i] = core.estimate_wear(s, v, params=params)
        else:
            by_size.setdefault(s.size, []).append(i)
    for rows in by_size.values():
        for i, estimates in zip(rows, _estimate_stacked([speeds[i] for i in rows],
                                                        [values[i] for i in rows], params)):
            results[i] = estimates
    return [r for r in results if r is not None]


def _estimate_stacked(speeds: list[FloatArray], values: list[FloatArray],
                      params: ParameterSet) -> list[core.WearEstimates]:
    """Return the N >= 2 estimates of :func:`estimate_wear` for rows of equal N (one row each)."""
    problems = [core._WhitenedProblem(s.copy(), params) for s in speeds]
    stacked = _StackedProblem.of(problems, params)
    data_w = stacked.apply(np.concatenate(values))
    starts = []
    for problem, row in zip(problems, data_w):
        starts.append(problem.grid_starts(row[None, :]))
        problem._grid_cache = None  # one start grid in memory at a time (flat memory)
    t0 = np.concatenate([s[0] for s in starts])
    w0 = np.concatenate([s[1] for s in starts])
    count, k = t0.shape
    repeated_rows = np.repeat(np.arange(count), k)
    repeated = data_w[repeated_rows]
    starts_problem = stacked.rows(repeated_rows)
    t, w = core._refine(starts_problem, repeated, t0.ravel(), w0.ravel())
    cost = starts_problem.cost(repeated, t, w).reshape(count, k)
    pick = np.argmin(cost, axis=1)
    rows = np.arange(count)
    t, w = t.reshape(count, k)[rows, pick], w.reshape(count, k)[rows, pick]
    # the end of _estimate_multi_level, row by row on the stack
    residual, jacobian, chi2 = stacked.evaluate(data_w, t, w)
    covariance = core._inverse_2x2(np.einsum('bni,bnj->bij', jacobian, jacobian))
    t_at_bound = (t <= stacked.t_min) | (t >= stacked.t_max)
    w_at_bound = w <= 0.0
    n_levels = speeds[0].size
    dof = (n_levels - (~t_at_bound).astype(np.int64) - (~w_at_bound).astype(np.int64))
    p_value = core._p_value(chi2, dof)
    return [core.WearEstimates(
        temperature_degc=t[i:i + 1], wear=w[i:i + 1], covariance=covariance[i:i + 1],
        temperature_at_bound=t_at_bound[i:i + 1], wear_at_bound=w_at_bound[i:i + 1],
        chi2=chi2[i:i + 1], dof=dof[i:i + 1], p_value=p_value[i:i + 1], n_levels=n_levels,
        speeds_rad_s=speeds[i].copy()) for i in rows]
