"""
Maximum-likelihood estimation of temperature T and wear w from friction levels.

N >= 2 levels: the weighted nonlinear least squares (16), the load marginalised into the
covariance (11)-(14), T bounded, w >= 0, started from a grid.  N = 1: the marginal
likelihood (17) with T integrated out by deterministic quadrature, maximised in w (19).
Vectorised: one call estimates a batch of friction vectors measured at the same speeds.

Numerical method, N >= 2.  Sigma(Phi) of (14) does not depend on theta = (T, w), so the
residuals are whitened once per speed set (Cholesky factor of Sigma).  The cost (16) is first
evaluated for the whole batch on a (T, w) grid with one matrix product (the model on the grid does
not depend on the data), and each fit is then refined from its best grid point by a batched
projected Gauss-Newton iteration with the analytic gradients of :mod:`.model`: a variable on its
bound whose descent direction points out of the box is held at the bound and the step is a 1-D
Gauss-Newton step in the other, and every step is accepted by a backtracking line search on the
cost.

Numerical method, N = 1.  The complete model (8) is additive, tau_f = tau_f0(v, mu, T) + tilde
tau_f(v, w), so the marginal likelihood (17) is p(y | w) = g(y - tilde tau_f(v, w)) with
g(z) = 1/(T_max - T_min) int N(z; tau_f0(v, mu, T), s^2) dT and s^2 = sigma^2 + sigma_tl^2 m(v)^2.
g is computed by composite Gauss-Legendre quadrature in T (exact to rounding for this model, see
the tests), its logarithm tabulated for a coarse search in w, and the maximiser refined by a
batched golden-section search on the exact quadrature.  The Fisher information of w is then exact:
F(w) = (d tilde tau_f / dw)^2 * J(v) with J(v) = int g'(z)^2 / g(z) dz, the location information of
g, computed by a second Gauss-Legendre quadrature over z.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.estimation.single_level import estimate_single_level
from robot_wear_monitor.estimation.start_grid import (arc_length_grid, GRID_MAX_STEP_DEGC,
                                                      GRID_MAX_STEP_WEAR, GRID_SPACING_SIGMA)
from robot_wear_monitor.estimation.temperature_only import estimate_temperature
from robot_wear_monitor.estimation.wear_estimates import (fit_p_value, validate_friction,
                                                          validate_speeds, WearEstimates)
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet

_GAUSS_NEWTON_ITERATIONS = 100
_LINE_SEARCH_HALVINGS = 8
#: the line search's step lengths: the full step, then 4^-1 .. 4^-(_LINE_SEARCH_HALVINGS - 1)
_STEP_LENGTHS = (np.ones(1), np.ldexp(1.0, -2 * np.arange(1, _LINE_SEARCH_HALVINGS)))
_BATCH_CHUNK = 64  # rows of the grid search at a time (cache-sized)
_GRID_CHUNK_CELLS = 1 << 21  # at most this many (row, grid point) costs at a time
_STARTS = 3
_TRACE: list[Any] = []


# --------------------------------------------------------------------------- public entry point

def estimate_wear(speeds_rad_s: ArrayLike, friction: ArrayLike, *,
                  params: ParameterSet) -> WearEstimates:
    """
    Estimate (T, w) for a batch of friction vectors measured at the same speeds.

    N >= 2: the ML estimate (16) (global optimum over T in the temperature bounds, w >= 0).
    N = 1: the marginal ML estimate (17)-(19) of w, T from its posterior at the estimate.
    A set without a wear model (``params.estimates_wear`` False): T-hat only, w-hat NaN (not
    determined; :mod:`.temperature_only`).

    :param speeds_rad_s: motor-side speeds [rad/s], shape (N,), all > 0.
    :param friction: friction levels (normalised), shape (N,) or (B, N).
    :param params: the parameter set (model, sigma, load mean/std, temperature bounds).

    :return: A :class:`WearEstimates` batch (arrays of length B); ``estimates[i]`` is a
        :class:`WearEstimate`.

    :raises InputError: non-finite or non-positive speeds, N = 0, non-finite friction or a friction
        shape that does not match the speeds.

    """
    speeds = validate_speeds(speeds_rad_s)
    values = validate_friction(friction, speeds.size)
    if not params.estimates_wear:  # a set without a wear model: T-hat only, w not determined
        t = estimate_temperature(speeds, values, params)
        covariance = np.zeros((values.shape[0], 2, 2))
        covariance[:, 0, 0], covariance[:, 1, 1] = t.temperature_var, np.nan
        return WearEstimates(
            temperature_degc=t.temperature_degc, wear=np.full(values.shape[0], np.nan),
            covariance=covariance, temperature_at_bound=t.temperature_at_bound,
            wear_at_bound=np.zeros(values.shape[0], dtype=bool), chi2=t.chi2, dof=t.dof,
            p_value=t.p_value, n_levels=speeds.size, speeds_rad_s=speeds.copy())
    if speeds.size == 1:
        return estimate_single_level(speeds, values[:, 0], params)
    return _estimate_multi_level(speeds, values, params)


# --------------------------------------------------------------------------- N >= 2

class _WhitenedProblem:
    """The weighted least squares (16) at fixed speeds, whitened by the Cholesky factor of (14)."""

    def __init__(self, speeds: FloatArray, params: ParameterSet) -> None:
        self.speeds = speeds
        #: the speeds of every row, broadcast against (B, N) ((1, N): one design for all rows)
        self.speed_rows = speeds[None, :]
        self.params = params
        covariance = fm.marginal_covariance(speeds, sigma=params.sigma,
                                            load_std=params.load_std, model=params.model)
        factor = np.linalg.cholesky(covariance)
        # whitening matrix W with W Sigma W^T = I: rows of r @ W.T are whitened residuals
        self.whiten = np.linalg.solve(factor, np.eye(speeds.size))
        self.t_min = params.temperature_min_degc
        self.t_max = params.temperature_max_degc
        self._grid_cache: tuple | None = None

    def model_w(self, t: ArrayLike, w: ArrayLike) -> FloatArray:
        """Return the whitened model prediction at load_mean, (..., N)."""
        return self.apply(fm.friction(self.speeds, self.params.load_mean, t, w,
                                      self.params.model))

    def apply(self, values: FloatArray) -> FloatArray:
        """
        Return whitened values (..., N).

        einsum, not BLAS: many small products, which a threaded BLAS makes erratic on a busy
        machine.
        """
        return np.einsum('...n,mn->...m', values, self.whiten)

    def evaluate(self, data_w: FloatArray, t: FloatArray, w: FloatArray) -> tuple:
        """Return whitened residuals (B, N), Jacobian of the model (B, N, 2) and cost (B,)."""
        g = fm.friction_with_gradients(self.speed_rows, self.params.load_mean,
                                       t[:, None], w[:, None], self.params.model)
        residual = data_w - self.apply(g.friction)
        jacobian = np.stack([self.apply(g.d_temperature), self.apply(g.d_wear)], axis=-1)
        return residual, jacobian, np.einsum('bn,bn->b', residual, residual)

    def evaluate_with_hessian(self, data_w: FloatArray, t: FloatArray, w: FloatArray) -> tuple:
        """
        Return :meth:`evaluate`'s residuals, Jacobian and cost, and the Hessian of cost/2.

        The Hessian (B, 2, 2) is J^T J - sum_n r_n d2f_n; the model curvature is a central
        difference of the analytic gradients at (t +- h_t, w) and (t, w +- h_w), evaluated with
        the point itself in one stacked model evaluation.  It matters: with N = 2 levels and a
        residual left at the optimum, the optimum lies where J is nearly singular and
        Gauss-Newton alone converges very slowly.
        """
        count = t.shape[0]
        h_t, h_w = 1e-3, 1e-4 * np.maximum(1.0, np.abs(w))
        points = self.rows(np.tile(np.arange(count), 5))
        g = fm.friction_with_gradients(
            points.speed_rows, self.params.load_mean,
            np.concatenate([t, t + h_t, t - h_t, t + 0.0, t - 0.0])[:, None],
            np.concatenate([w, w + 0.0, w - 0.0, w + h_w, w - h_w])[:, None], self.params.model)
        residual = data_w - self.apply(g.friction[:count])
        gradients = np.stack([points.apply(g.d_temperature), points.apply(g.d_wear)], axis=-1)
        jacobian = gradients[:count]
        plus_t, minus_t, plus_w, minus_w = (gradients[(i + 1) * count:(i + 2) * count]
                                            for i in range(4))
        # (B, N, 2, 2): d/d theta_j of column i
        curvature = np.stack([(plus_t - minus_t) / (2.0 * h_t),
                              (plus_w - minus_w) / (2.0 * (0.0 + h_w))[..., None, None]], axis=-1)
        curvature = 0.5 * (curvature + np.swapaxes(curvature, -1, -2))
        hessian = (np.einsum('bni,bnj->bij', jacobian, jacobian)
                   - np.einsum('bn,bnij->bij', residual, curvature))
        return residual, jacobian, np.einsum('bn,bn->b', residual, residual), hessian

    def cost(self, data_w: FloatArray, t: FloatArray, w: FloatArray) -> FloatArray:
        """Return the cost of (16), shape (B,), at the points (t, w)."""
        f = fm.friction(self.speed_rows, self.params.load_mean, t[:, None], w[:, None],
                        self.params.model)
        residual = data_w - self.apply(f)
        return np.einsum('bn,bn->b', residual, residual)

    def _grid(self) -> tuple:
        """Return the (T, w) grid, its whitened model and norms (data-independent, kept)."""
        if self._grid_cache is not None:
            return self._grid_cache
        mid_t = 0.5 * (self.t_min + self.t_max)

        model = self.params.model
        # the grid's many points are whitened by one matrix product (BLAS): the start grid
        # is the same in every path that uses it (estimate_wear, the batched rows)
        whiten_t = np.ascontiguousarray(self.whiten.T)

        def along_t(t: FloatArray) -> FloatArray:
            return fm.friction(self.speeds, self.params.load_mean, t[:, None], 0.0,
                               model) @ whiten_t

        def along_w(w: FloatArray) -> FloatArray:
            return fm.friction(self.speeds, self.params.load_mean, mid_t, w[:, None],
                               model) @ whiten_t

        grid_t = arc_length_grid(along_t, self.t_min, self.t_max,
                                 spacing=GRID_SPACING_SIGMA, max_step=GRID_MAX_STEP_DEGC)
        grid_w = arc_length_grid(along_w, 0.0, self.params.wear_max,
                                 spacing=GRID_SPACING_SIGMA, max_step=GRID_MAX_STEP_WEAR)
        n_t, n_w = grid_t.size, grid_w.size
        # w-major order, so that the minimum over T runs along contiguous memory
        ww, tt = (a.ravel() for a in np.meshgrid(grid_w, grid_t, indexing='ij'))
        # the model (8) is tau_f0(T) + tilde tau_f(w): each part once per grid line, summed
        nominal = fm.nominal_friction(self.speeds, self.params.load_mean, grid_t[:, None], model)
        wear = fm.wear_friction(self.speeds, grid_w[:, None], model)
        model_w = (nominal[None, :, :] + wear[:, None, :]).reshape(ww.size, -1) @ whiten_t
        # |d - g|^2 = |d|^2 - 2 d.g + |g|^2; the first term does not change the argmin
        norm2 = np.einsum('kn,kn->k', model_w, model_w)
        minus_2g = -2.0 * model_w.T
        self._grid_cache = (tt, ww, n_t, n_w, norm2, minus_2g)
        return self._grid_cache

    def grid_starts(self, data_w: FloatArray) -> tuple[FloatArray, FloatArray]:
        """
        Return K starting points (T, w) for every fit, each of shape (B, K).

        The cost is evaluated on the (T, w) grid, minimised over T at every grid w (the profile
        in w), and the K = _STARTS best local minima of the profile (best grid points fill in
        when there are fewer) are the starts of the local refinement.  Several starts guard
        against a narrow valley of the global optimum that the grid resolves only at its rim.
        """
        tt, ww, n_t, n_w, norm2, minus_2g = self._grid()
        starts = np.empty((data_w.shape[0], _STARTS), dtype=int)
        chunk = max(1, min(_BATCH_CHUNK, _GRID_CHUNK_CELLS // norm2.size))
        for start in range(0, data_w.shape[0], chunk):
            score = np.einsum('bn,nk->bk', data_w[start:start + chunk], minus_2g)
            score += norm2
            score = score.reshape(-1, n_w, n_t)
            best_t = np.argmin(score, axis=2)  # (b, n_w): best T at every grid w
            profile = np.min(score, axis=2)
            padded = np.pad(profile, ((0, 0), (1, 1)), constant_values=np.inf)
            local = (profile <= padded[:, :-2]) & (profile <= padded[:, 2:])
            ranked = np.where(local, profile, profile + 1e300)
            pick = np.argpartition(ranked, _STARTS - 1, axis=1)[:, :_STARTS]
            starts[start:start + chunk] = (
                pick * n_t + np.take_along_axis(best_t, pick, axis=1))
        return tt[starts], ww[starts]

    def rows(self, index: NDArray[np.intp]) -> '_WhitenedProblem':
        """Return the problem of the rows ``index`` (all rows share these speeds: itself)."""
        return self

    def project(self, t: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Project onto the box T_min <= T <= T_max, w >= 0."""
        return np.clip(t, self.t_min, self.t_max), np.maximum(w, 0.0)


_PROBLEMS: dict[tuple[bytes, int], _WhitenedProblem] = {}
_PROBLEMS_KEPT = 4


def _problem(speeds: FloatArray, params: ParameterSet) -> _WhitenedProblem:
    """
    Return the problem of these speeds and this parameter set, built once and kept.

    The whitening and the start grid (a few ms) do not depend on the data: a calibration
    estimates thousands of experiments at one design, and a batch shares them.  Kept per
    exact speeds and parameter-set object (a new object, e.g. a reloaded file, builds anew;
    measured speeds differ by a few mrad/s from one experiment to the next, so a monitor
    builds one per experiment); the last ``_PROBLEMS_KEPT`` are kept.
    """
    key = (speeds.tobytes(), id(params))
    problem = _PROBLEMS.get(key)
    if problem is None or problem.params is not params:
        problem = _WhitenedProblem(speeds.copy(), params)
        if len(_PROBLEMS) >= _PROBLEMS_KEPT:
            _PROBLEMS.pop(next(iter(_PROBLEMS)))
        _PROBLEMS[key] = problem
    return problem


def _newton_step(jacobian: FloatArray, hessian: FloatArray, residual: FloatArray,
                 fixed: NDArray[np.bool_], damping: FloatArray) -> FloatArray:
    """
    Return the damped Newton step (B, 2) of the cost with the variables in ``fixed`` held.

    The Hessian of cost/2 is ``hessian`` (J^T J minus the residual-weighted model curvature);
    in variables scaled by sqrt(diag(J^T J)) it is shifted by max(damping, -lambda_min + eps)
    times the identity (Levenberg-Marquardt on the full Hessian), so the step is a descent step.
    """
    b = np.einsum('bni,bn->bi', jacobian, residual)
    gn = np.einsum('bni,bnj->bij', jacobian, jacobian)
    scale = np.sqrt(np.maximum(np.einsum('bii->bi', gn), 1e-300))
    hs = hessian / (scale[:, :, None] * scale[:, None, :])
    bs = b / scale
    free = ~fixed
    hs = np.where(free[:, :, None] & free[:, None, :], hs, 0.0)
    bs = np.where(free, bs, 0.0)
    half_trace = 0.5 * (hs[:, 0, 0] + hs[:, 1, 1])
    radius = np.sqrt(0.25 * (hs[:, 0, 0] - hs[:, 1, 1]) ** 2 + hs[:, 0, 1] ** 2)
    # eigenvalues of the free block only (a held variable contributes a zero row/column)
    lam_min = np.where(free[:, 0] & free[:, 1], half_trace - radius,
                       np.where(free[:, 0], hs[:, 0, 0], hs[:, 1, 1]))
    shift = np.maximum(damping, -lam_min + 1e-9 + 1e-3 * np.maximum(-lam_min, 0.0))
    m = hs + shift[:, None, None] * np.eye(2)
    det = m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] ** 2
    step_s = np.stack([m[:, 1, 1] * bs[:, 0] - m[:, 0, 1] * bs[:, 1],
                       m[:, 0, 0] * bs[:, 1] - m[:, 0, 1] * bs[:, 0]], axis=1) / det[:, None]
    step = np.where(free, step_s, 0.0) / scale
    return np.nan_to_num(step, nan=0.0, posinf=0.0, neginf=0.0)


def _refine(problem: _WhitenedProblem, data_w: FloatArray, t: FloatArray, w: FloatArray
            ) -> tuple[FloatArray, FloatArray]:
    """Batched projected Levenberg-Marquardt with active bounds and a backtracking line search."""
    t, w = t.astype(float).copy(), w.astype(float).copy()
    damping = np.full(t.shape, 1e-9)
    active = np.ones(t.shape, dtype=bool)
    span_t = problem.t_max - problem.t_min
    for _ in range(_GAUSS_NEWTON_ITERATIONS):
        idx = np.flatnonzero(active)

        if idx.size == 0:
            break
        d, ti, wi, lam = data_w[idx], t[idx], w[idx], damping[idx]
        active_rows = problem.rows(idx)
        residual, jacobian, cost, hessian = active_rows.evaluate_with_hessian(d, ti, wi)
        descent = np.einsum('bni,bn->bi', jacobian, residual)  # = -grad(cost)/2
        at_low_t = ti <= problem.t_min + 1e-12 * span_t
        at_high_t = ti >= problem.t_max - 1e-12 * span_t
        at_zero_w = wi <= 0.0
        fixed = np.stack([(at_low_t & (descent[:, 0] <= 0)) | (at_high_t & (descent[:, 0] >= 0)),
                          at_zero_w & (descent[:, 1] <= 0)], axis=1)
        step = _newton_step(jacobian, hessian, residual, fixed, lam)
        # a free variable on its bound that the step pushes out: hold it, 1-D step in the other
        out = np.stack([(at_low_t & (step[:, 0] < 0)) | (at_high_t & (step[:, 0] > 0)),
                        at_zero_w & (step[:, 1] < 0)], axis=1)
        redo = np.any(out & ~fixed, axis=1)
        if np.any(redo):
            fixed = fixed | out
            step[redo] = _newton_step(jacobian[redo], hessian[redo], residual[redo],
                                      fixed[redo], lam[redo])
        # backtracking line search along the projected path: the full step of every row, then
        # the shorter steps 4^-k (k = 1 .. _LINE_SEARCH_HALVINGS - 1) of the rows it did not
        # improve, all at once; a row takes its first (longest) step that lowers the cost
        accepted = np.zeros(idx.size, dtype=bool)
        full_step = np.zeros(idx.size, dtype=bool)
        new_t, new_w, new_cost = ti.copy(), wi.copy(), cost.copy()
        pending = np.flatnonzero(np.any(step != 0, axis=1))
        for alphas in _STEP_LENGTHS:
            if pending.size == 0:
                break
            tries = np.repeat(pending, alphas.size)
            alpha = np.tile(alphas, pending.size)
            cand_t, cand_w = problem.project(ti[tries] + alpha * step[tries, 0],
                                             wi[tries] + alpha * step[tries, 1])
            cand_cost = active_rows.rows(tries).cost(d[tries], cand_t, cand_w)
            ok = (cand_cost < cost[tries]).reshape(pending.size, alphas.size)
            first = np.argmax(ok, axis=1)
            hit = ok[np.arange(pending.size), first]
            pick = np.flatnonzero(hit) * alphas.size + first[hit]
            good = pending[hit]
            new_t[good], new_w[good], new_cost[good] = cand_t[pick], cand_w[pick], cand_cost[pick]
            accepted[good] = True
            full_step[good] = alphas[0] == 1.0
            pending = pending[~hit]
        small = ((np.abs(new_t - ti) <= 1e-10 * (1.0 + np.abs(ti)))
                 & (np.abs(new_w - wi) <= 1e-10 * (1.0 + np.abs(wi))))
        flat = cost - new_cost <= 1e-13 * (1.0 + cost)
        t[idx], w[idx] = new_t, new_w
        damping[idx] = np.where(full_step, np.maximum(lam / 10.0, 1e-9),
                                np.where(accepted, lam, lam * 100.0))
        gave_up = ~accepted & (lam * 100.0 > 1e8)
        converged = gave_up | (accepted & (small | flat)) | ~np.any(step != 0, axis=1)
        active[idx[converged]] = False
    return t, w


def _global_refine(problem: _WhitenedProblem, data_w: FloatArray) -> tuple:
    """Refine from the K best grid minima of every fit and keep the best end point."""
    t0, w0 = problem.grid_starts(data_w)
    count, k = t0.shape
    repeated = np.repeat(data_w, k, axis=0)
    t, w = _refine(problem, repeated, t0.ravel(), w0.ravel())
    cost = problem.cost(repeated, t, w).reshape(count, k)
    pick = np.argmin(cost, axis=1)
    rows = np.arange(count)
    return t.reshape(count, k)[rows, pick], w.reshape(count, k)[rows, pick]


def _inverse_2x2(matrix: FloatArray) -> FloatArray:
    """Inverse of a batch of symmetric 2x2 matrices; pseudo-inverse where singular."""
    det = matrix[:, 0, 0] * matrix[:, 1, 1] - matrix[:, 0, 1] * matrix[:, 1, 0]
    scale = np.abs(matrix[:, 0, 0] * matrix[:, 1, 1]) + matrix[:, 0, 1] ** 2
    regular = np.abs(det) > 1e-10 * np.maximum(scale, 1e-300)
    result = np.empty_like(matrix)
    if np.any(regular):
        m, dr = matrix[regular], det[regular]
        adjugate = np.stack([np.stack([m[:, 1, 1], -m[:, 0, 1]], -1),
                             np.stack([-m[:, 1, 0], m[:, 0, 0]], -1)], 1)
        result[regular] = adjugate / dr[:, None, None]
    if np.any(~regular):
        result[~regular] = np.linalg.pinv(matrix[~regular], hermitian=True)
    return result


def _estimate_multi_level(speeds: FloatArray, values: FloatArray,
                          params: ParameterSet) -> WearEstimates:
    problem = _problem(speeds, params)
    data_w = problem.apply(values)
    t, w = _global_refine(problem, data_w)
    residual, jacobian, chi2 = problem.evaluate(data_w, t, w)
    covariance = _inverse_2x2(np.einsum('bni,bnj->bij', jacobian, jacobian))
    t_at_bound = (t <= problem.t_min) | (t >= problem.t_max)
    w_at_bound = w <= 0.0
    dof = (speeds.size - (~t_at_bound).astype(np.int64) - (~w_at_bound).astype(np.int64))
    return WearEstimates(temperature_degc=t, wear=w, covariance=covariance,
                         temperature_at_bound=t_at_bound, wear_at_bound=w_at_bound, chi2=chi2,
                         dof=dof, p_value=fit_p_value(chi2, dof), n_levels=speeds.size,
                         speeds_rad_s=speeds.copy())
