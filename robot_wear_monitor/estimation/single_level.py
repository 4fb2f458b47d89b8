"""
The N = 1 estimate of w: the marginal likelihood (17) with T integrated out, maximised (19).

The complete model (8) is additive, tau_f = tau_f0(v, mu, T) + tilde tau_f(v, w), so the
marginal likelihood (17) is p(y | w) = g(y - tilde tau_f(v, w)); :class:`MarginalModel`
computes g by composite Gauss-Legendre quadrature in T, :func:`estimate_single_level` the
estimate (a coarse search on a table of log g, then a batched golden-section search), and
:func:`marginal_fisher_information` the exact Fisher information of w (see
:mod:`.estimator` for the method).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.estimation.special_functions import log_sum_exp
from robot_wear_monitor.estimation.start_grid import (arc_length_grid, GRID_MAX_STEP_WEAR,
                                                      GRID_SPACING_SIGMA)
from robot_wear_monitor.estimation.wear_estimates import fit_p_value, WearEstimates
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet

# Composite Gauss-Legendre rules of the N = 1 marginal likelihood (T) and information (z).
_T_PANELS, _T_NODES = 8, 8
_Z_PANELS, _Z_NODES = 96, 8
_Z_TAIL_SIGMAS = 12.0
_GOLDEN_ITERATIONS = 36


def _composite_gauss_legendre(lower: ArrayLike, upper: ArrayLike, panels: int, nodes: int
                              ) -> tuple[FloatArray, FloatArray]:
    """Return nodes and weights (..., panels*nodes) of a composite Gauss-Legendre rule."""
    x, wts = np.polynomial.legendre.leggauss(nodes)
    lo = np.asarray(lower, dtype=float)[..., None]
    hi = np.asarray(upper, dtype=float)[..., None]
    edges = np.linspace(0.0, 1.0, panels + 1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    unit = (centres[:, None] + 0.5 * x[None, :] / panels).ravel()
    unit_w = np.tile(wts, panels) * 0.5 / panels
    return lo + (hi - lo) * unit, (hi - lo) * unit_w


@dataclass(frozen=True)
class MarginalModel:
    """
    The marginal density g(z) of z = y - tilde tau_f(v, w) at one or more speeds, eq. (17).

    g(z) = 1/(T_max - T_min) int_T N(z; tau_f0(v, mu_tl, T), s^2) dT, with the load marginalised
    (s^2 = sigma^2 + sigma_tl^2 m(v)^2).  Arrays have a leading speed shape S (from the speeds).

    :ivar speeds_rad_s: shape S [rad/s].
    :ivar nodes_degc: quadrature nodes in T, shape S + (K,).
    :ivar log_weights: log of the normalised quadrature weights (sum to 1), shape S + (K,).
    :ivar nominal: tau_f0 at the nodes, shape S + (K,).
    :ivar std: s, shape S.

    """

    speeds_rad_s: FloatArray
    nodes_degc: FloatArray
    log_weights: FloatArray
    nominal: FloatArray
    std: FloatArray

    @classmethod
    def build(cls, *, speeds_rad_s: ArrayLike, params: ParameterSet,
              panels: int = _T_PANELS, nodes: int = _T_NODES) -> 'MarginalModel':
        """Tabulate the quadrature of g at the given speeds (any shape S) [rad/s]."""
        speeds = np.asarray(speeds_rad_s, dtype=float)
        t, wt = _composite_gauss_legendre(params.temperature_min_degc,
                                          params.temperature_max_degc, panels, nodes)
        span = params.temperature_max_degc - params.temperature_min_degc
        nominal = fm.nominal_friction(speeds[..., None], params.load_mean, t, params.model)
        m = fm.load_sensitivity(speeds, params.model)
        std = np.sqrt(params.sigma ** 2 + params.load_std ** 2 * m ** 2)
        log_w = np.broadcast_to(np.log(wt / span), nominal.shape)
        return cls(speeds_rad_s=speeds, nodes_degc=np.broadcast_to(t, nominal.shape),
                   log_weights=np.array(log_w), nominal=nominal, std=np.asarray(std))

    def _log_terms(self, z: FloatArray) -> FloatArray:
        s = self.std[..., None]
        u = (z[..., None] - self.nominal) / s
        return self.log_weights - 0.5 * u * u - np.log(np.sqrt(2.0 * np.pi) * s)

    def log_density(self, z: ArrayLike) -> FloatArray:
        """Return log g(z); z broadcasts against the speed shape S."""
        return log_sum_exp(self._log_terms(np.asarray(z, dtype=float)), axis=-1)

    def score_and_log_density(self, z: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Return g'(z)/g(z) and log g(z) (stable in the tails)."""
        z = np.asarray(z, dtype=float)
        terms = self._log_terms(z)
        log_g = log_sum_exp(terms, axis=-1)
        post = np.exp(terms - log_g[..., None])
        mean_nominal = np.sum(post * self.nominal, axis=-1)
        return -(z - mean_nominal) / self.std ** 2, log_g

    def posterior_temperature(self, z: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Return the posterior mean [degC] and variance [degC^2] of T given z."""
        z = np.asarray(z, dtype=float)
        terms = self._log_terms(z)
        post = np.exp(terms - log_sum_exp(terms, axis=-1)[..., None])
        mean = np.sum(post * self.nodes_degc, axis=-1)
        var = np.sum(post * (self.nodes_degc - mean[..., None]) ** 2, axis=-1)
        return mean, var

    def location_information(self) -> FloatArray:
        """Return J = int g'(z)^2 / g(z) dz (shape S), the Fisher information of a z shift."""
        lo = self.nominal.min(axis=-1) - _Z_TAIL_SIGMAS * self.std
        hi = self.nominal.max(axis=-1) + _Z_TAIL_SIGMAS * self.std
        z, wz = _composite_gauss_legendre(lo, hi, _Z_PANELS, _Z_NODES)  # S + (Kz,)
        terms = self._log_terms_grid(z)
        log_g = log_sum_exp(terms, axis=-1)
        post = np.exp(terms - log_g[..., None])
        mean_nominal = np.sum(post * self.nominal[..., None, :], axis=-1)
        score = -(z - mean_nominal) / self.std[..., None] ** 2
        return np.sum(wz * np.exp(log_g) * score ** 2, axis=-1)

    def _log_terms_grid(self, z: FloatArray) -> FloatArray:
        s = self.std[..., None, None]
        u = (z[..., :, None] - self.nominal[..., None, :]) / s
        return self.log_weights[..., None, :] - 0.5 * u * u - np.log(np.sqrt(2.0 * np.pi) * s)


def marginal_fisher_information(*, speeds_rad_s: ArrayLike, wear: ArrayLike,
                                params: ParameterSet) -> FloatArray:
    """
    Return the exact Fisher information of w from one friction level, eqs. (17) and (25).

    F(v, w) = (d tilde tau_f(v, w) / dw)^2 * J(v), J(v) = int g'(z)^2 / g(z) dz; T is
    integrated out under its uniform prior (no dependence on a true T).

    :param speeds_rad_s: speed [rad/s], any shape S, > 0.
    :param wear: wear level(s) w, broadcast against S.
    :param params: the parameter set.

    :return: F, the broadcast shape of speeds and wear [1/w^2].

    """
    speeds = np.asarray(speeds_rad_s, dtype=float)
    marginal = MarginalModel.build(speeds_rad_s=speeds, params=params)
    info = marginal.location_information()
    d_wear = fm.friction_with_gradients(speeds, params.load_mean, params.design_temperature_degc,
                                        wear, params.model).d_wear
    return d_wear ** 2 * info


def _golden_maximise(objective, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """Batched golden-section search of the maximiser of objective(x) (B,) on [lower, upper]."""
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = lower.copy(), upper.copy()
    c = b - ratio * (b - a)
    d = a + ratio * (b - a)
    fc, fd = objective(c), objective(d)
    for _ in range(_GOLDEN_ITERATIONS):
        left = fc >= fd  # the maximiser is in [a, d]
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        new_c = np.where(left, b - ratio * (b - a), d)
        new_d = np.where(left, c, a + ratio * (b - a))
        x_new = np.where(left, new_c, new_d)
        f_new = objective(x_new)
        fc, fd = np.where(left, f_new, fd), np.where(left, fc, f_new)
        c, d = new_c, new_d
    return 0.5 * (a + b)


def estimate_single_level(speeds: FloatArray, values: FloatArray,
                          params: ParameterSet) -> WearEstimates:
    speed = float(speeds[0])
    marginal = MarginalModel.build(speeds_rad_s=speed, params=params)
    s = float(marginal.std)
    model = params.model

    # coarse search in w on a table of log g (exact quadrature at table points, linear
    # interpolation between them, a Gaussian tail beyond them)
    grid_w = arc_length_grid(lambda w: fm.wear_friction(speed, w, model)[:, None] / s, 0.0,
                             params.wear_max, spacing=GRID_SPACING_SIGMA,
                             max_step=GRID_MAX_STEP_WEAR)
    f_lo, f_hi = float(marginal.nominal.min()), float(marginal.nominal.max())
    z_lo, z_hi = f_lo - 30.0 * s, f_hi + 30.0 * s
    table_z = np.arange(z_lo, z_hi + s / 8.0, s / 8.0)
    table = marginal.log_density(table_z)

    def surrogate(z: FloatArray) -> FloatArray:
        zc = np.clip(z, z_lo, table_z[-1])
        return np.interp(zc, table_z, table) - 0.5 * ((z - zc) / s) ** 2

    best_w = np.empty(values.shape[0])
    lower = np.empty(values.shape[0])
    upper = np.empty(values.shape[0])
    pending = np.arange(values.shape[0])
    grid = grid_w
    while pending.size:
        wear_part = fm.wear_friction(speed, grid, model)
        scores = surrogate(values[pending, None] - wear_part[None, :])
        j = np.argmax(scores, axis=1)
        best_w[pending] = grid[j]
        lower[pending] = grid[np.maximum(j - 1, 0)]
        upper[pending] = grid[np.minimum(j + 1, grid.size - 1)]
        at_end = j == grid.size - 1
        if not np.any(at_end) or grid[-1] > 1e6:
            break
        pending = pending[at_end]
        grid = np.linspace(grid[-1], 4.0 * grid[-1], grid.size)

    def objective(w: FloatArray) -> FloatArray:
        return marginal.log_density(values - fm.wear_friction(speed, w, model))

    w_hat = _golden_maximise(objective, lower, upper)
    # w = 0 exactly when the left end of the bracket at 0 is at least as good
    at_zero = (lower == 0.0) & (objective(np.zeros_like(w_hat)) >= objective(w_hat))
    w_hat = np.where(at_zero, 0.0, w_hat)

    z_hat = values - fm.wear_friction(speed, w_hat, model)
    t_mean, t_var = marginal.posterior_temperature(z_hat)
    info = float(marginal.location_information())
    d_wear = fm.friction_with_gradients(speed, params.load_mean, t_mean, w_hat, model).d_wear
    fisher = d_wear ** 2 * info
    with np.errstate(divide='ignore'):
        var_w = np.where(fisher > 0, 1.0 / fisher, np.inf)
    covariance = np.zeros((values.shape[0], 2, 2))
    covariance[:, 0, 0] = t_var
    covariance[:, 1, 1] = var_w
    residual = values - fm.friction(speed, params.load_mean, t_mean, w_hat, model)
    chi2 = (residual / s) ** 2
    dof = np.where(at_zero, 1, 0).astype(np.int64)
    return WearEstimates(temperature_degc=t_mean, wear=w_hat, covariance=covariance,
                         temperature_at_bound=np.zeros(values.shape[0], dtype=bool),
                         wear_at_bound=at_zero, chi2=chi2, dof=dof, p_value=fit_p_value(chi2, dof),
                         n_levels=1, speeds_rad_s=speeds.copy())
