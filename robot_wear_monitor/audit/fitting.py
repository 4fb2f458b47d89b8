"""
The identification core shared by ``audit`` and ``identify``: tables, base models, fitter.

Friction models are written as (columns nonlinear in a few parameters theta) x (amplitudes):
the speed model (4) per group, the nominal model (5) and the complete model (8).  They are
identified by variable projection (:func:`fit_model`): ``scipy.optimize.least_squares`` over theta,
all amplitudes by linear least squares inside every residual evaluation.  :func:`fold_indices` and
:func:`cv_rms` give the held-out (cross-validated by experiment) error.

Units: speeds motor side [rad/s], friction in the table's own unit (normalised for the packaged
model), temperature [degC].
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.model.params import FrictionModel
from scipy import optimize


# --------------------------------------------------------------------------- the table
@dataclass(frozen=True)
class AuditTable:
    """
    A table of friction levels: one row per level.

    :ivar numeric: column name -> float array, shape (n,); always holds ``speed`` and ``friction``.
    :ivar text: column name -> str array, shape (n,) (categorical columns such as a pose name).
    :ivar source: where the table came from (file name), for messages.
    :ivar levels: the segmented levels behind the rows of a table read from a bag or raw runs,
        one (FrictionLevel, experiment label, joint label) per row, in row order (what
        ``--levels-out`` writes); empty for a table read as levels (a CSV).

    """

    numeric: Mapping[str, FloatArray]
    text: Mapping[str, NDArray[np.str_]] = field(default_factory=dict)
    source: str = '<table>'
    levels: tuple = field(default=(), compare=False, repr=False)

    @property
    def n_rows(self) -> int:
        """Return the number of friction levels."""
        return int(len(self.numeric['friction']))

    @property
    def columns(self) -> tuple[str, ...]:
        """All column names, numeric first."""
        return tuple(self.numeric) + tuple(self.text)

    def subset(self, rows: NDArray) -> 'AuditTable':
        """Return the table restricted to ``rows`` (boolean mask or index array)."""
        levels = (tuple(self.levels[i] for i in np.arange(self.n_rows)[rows])
                  if self.levels else ())
        return AuditTable({k: v[rows] for k, v in self.numeric.items()},
                          {k: v[rows] for k, v in self.text.items()}, self.source, levels)


# --------------------------------------------------------------------------- base models

def _decay(speed: FloatArray, stribeck_speed: FloatArray | float,
           alpha: FloatArray | float) -> FloatArray:
    """Return exp(-|v/phi|^alpha), 0 where phi <= 0 is not admissible."""
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        value = np.exp(-np.abs(speed / stribeck_speed) ** alpha)
    return np.nan_to_num(value, nan=0.0)


@dataclass(frozen=True)
class Base:
    """A base model written as (linear columns) x (amplitudes), columns nonlinear in theta."""

    name: str
    theta0: FloatArray
    lower: FloatArray
    upper: FloatArray
    columns: Callable[[FloatArray, AuditTable], FloatArray]
    describe: Callable[[FloatArray, FloatArray], dict]
    decays: Callable[[FloatArray, AuditTable], dict]
    bounds_for: Callable[[AuditTable], tuple] | None = None
    #: groups whose Stribeck term is left out (model (4): the data do not support it, BIC)
    dropped: tuple[str, ...] = ()
    #: the columns of the model with every term (the left-out ones too), for the candidate
    #: tests: structure the model's own shapes explain is no candidate effect (None: columns)
    span_columns: Callable[[FloatArray, AuditTable], FloatArray] | None = None

    def bounds(self, table: AuditTable) -> tuple[FloatArray, FloatArray]:
        """Bounds of theta for fitting ``table`` (they may depend on its speeds)."""
        if self.bounds_for is None:
            return self.lower, self.upper
        return self.bounds_for(table)


def speed_base(table: AuditTable, group: str | None,
               without_stribeck: Sequence[str] = ()) -> Base:
    """
    Model (4) per group: F_c + F_s exp(-|v/phi_s|^alpha) + F_v v; theta = (log phi, alpha).

    ``without_stribeck``: groups whose Stribeck term is left out (its column zero: F_s = 0,
    their phi_s and alpha stay at the start, undetermined by the data).
    """
    keys, codes = group_codes(table, group)
    stribeck = np.array([key not in without_stribeck for key in keys], dtype=float)
    g = len(keys)
    lower, upper = _speed_bounds(table, group, keys)
    vmin, vmax = np.exp(lower[0::2]), np.exp(upper[0::2]) / 5.0
    theta0 = np.column_stack([np.log(np.sqrt(vmin * vmax)), np.full(g, 1.36)]).ravel()

    def all_columns(theta: FloatArray, data: AuditTable, kept: NDArray) -> FloatArray:
        _, c = group_codes(data, group, keys)
        speed = data.numeric['speed']
        out = np.zeros((len(speed), 3 * g))
        phi = np.exp(theta[0::2])[c]
        alpha = theta[1::2][c]
        rows = np.arange(len(speed))
        out[rows, 3 * c] = 1.0
        out[rows, 3 * c + 1] = _decay(speed, phi, alpha) * kept[c]
        out[rows, 3 * c + 2] = speed
        return out

    def columns(theta: FloatArray, data: AuditTable) -> FloatArray:
        return all_columns(theta, data, stribeck)

    def span_columns(theta: FloatArray, data: AuditTable) -> FloatArray:
        return all_columns(theta, data, np.ones(g))

    def describe(theta: FloatArray, coef: FloatArray) -> dict:
        result = {}
        for i, key in enumerate(keys):
            result[key] = {'F_c': coef[3 * i], 'F_s': coef[3 * i + 1],
                           'phi_s': math.exp(theta[2 * i]), 'alpha': theta[2 * i + 1],
                           'F_v': coef[3 * i + 2]}
        return result

    def decays(theta: FloatArray, data: AuditTable) -> dict:
        _, c = group_codes(data, group, keys)
        return {'Stribeck': _decay(data.numeric['speed'], np.exp(theta[0::2])[c],
                                   theta[1::2][c])}

    def bounds(data: AuditTable) -> tuple[FloatArray, FloatArray]:
        return _speed_bounds(data, group, keys)

    start = _speed_start(table, codes, g, theta0, lower, upper)
    return Base('speed', start, lower, upper, columns, describe, decays, bounds,
                tuple(k for k in keys if k in without_stribeck), span_columns)


def _speed_bounds(table: AuditTable, group: str | None,
                  keys: Sequence[str]) -> tuple[FloatArray, FloatArray]:
    """
    Bounds of (log phi_s, alpha) per group, from the speeds of the levels being fitted.

    phi_s >= the lowest speed of the group: below it the Stribeck column nearly vanishes on
    every level and its amplitude is not identifiable (a held-out lower speed would then be
    predicted with an unbounded amplitude); phi_s <= 5 x the highest speed; 0.5 <= alpha <= 3.
    """
    _, codes = group_codes(table, group, keys)
    v = table.numeric['speed']
    g = len(keys)
    present = np.bincount(codes, minlength=g) > 0
    vmin = np.array([v[codes == i].min() if present[i] else v.min() for i in range(g)])
    vmax = np.array([v[codes == i].max() if present[i] else v.max() for i in range(g)])
    vmax = np.maximum(vmax, 1.01 * vmin)
    lower = np.column_stack([np.log(vmin), np.full(g, 0.5)]).ravel()
    upper = np.column_stack([np.log(vmax * 5.0), np.full(g, 3.0)]).ravel()
    return lower, upper


def _speed_start(table: AuditTable, codes: NDArray, g: int, theta0: FloatArray,
                 lower: FloatArray, upper: FloatArray) -> FloatArray:
    """Pick per group the best Stribeck speed of a coarse grid (alpha = 1.36) as the start."""
    v = table.numeric['speed']
    y = table.numeric['friction']
    start = theta0.copy()
    for i in range(g):
        rows = codes == i
        best = math.inf
        for log_phi in np.linspace(lower[2 * i] + 0.2, upper[2 * i] - 0.2, 9):
            x = np.column_stack([np.ones(rows.sum()), _decay(v[rows], math.exp(log_phi), 1.36),
                                 v[rows]])
            rss = _rss(x, y[rows])
            if rss < best:
                best, start[2 * i] = rss, log_phi
    return np.clip(start, lower + 1e-9, upper - 1e-9)


def nominal_base(table: AuditTable, model: FrictionModel, with_wear: bool) -> Base:
    """
    Model (5) (and (8) with ``with_wear``), amplitudes linear, Stribeck speeds nonlinear.

    theta = (phi_s,tl, phi_s(T_lo), phi_s(T_hi), T_V0, alpha[, phi_s,w]); the temperature
    Stribeck speed phi_s,0 + phi_s,T T is parametrised by its values at the ends of the table's
    temperature range so that it stays positive where the data are.
    """
    t = table.numeric['temperature']
    t_lo, t_hi = float(t.min()), float(t.max())
    if t_hi - t_lo < 1e-9:
        t_hi = t_lo + 1.0
    phi_lo = model.phi_s0 + model.phi_s_temp * t_lo
    phi_hi = model.phi_s0 + model.phi_s_temp * t_hi
    vmax = float(table.numeric['speed'].max())
    theta0 = [model.phi_s_load, max(phi_lo, 0.5), max(phi_hi, 0.5), model.t_v0, model.alpha]
    lower = [0.05, 0.05, 0.05, 1.0, 0.3]
    upper = [50 * vmax, 50 * vmax, 50 * vmax, 1000.0, 5.0]
    if with_wear:
        theta0.append(model.phi_s_wear)
        lower.append(1e-3)
        upper.append(50 * vmax)
    theta0_a = np.clip(np.array(theta0, dtype=float), np.array(lower) + 1e-9,
                       np.array(upper) - 1e-9)

    def stribeck_speed(theta: FloatArray, temperature: FloatArray) -> FloatArray:
        return theta[1] + (theta[2] - theta[1]) * (temperature - t_lo) / (t_hi - t_lo)

    def columns(theta: FloatArray, data: AuditTable) -> FloatArray:
        v = data.numeric['speed']
        tl = data.numeric['load']
        temp = data.numeric['temperature']
        e_tl = _decay(v, theta[0], theta[4])
        e_t = _decay(v, np.maximum(stribeck_speed(theta, temp), 1e-6), theta[4])
        cols = [np.ones_like(v), tl, tl * e_tl, e_t, temp * e_t, v,
                v * np.exp(-temp / theta[3])]
        if with_wear:
            w = data.numeric['wear']
            e_w = np.where(w > 0, _decay(v, theta[5] * np.maximum(w, 1e-12), theta[4]), 0.0)
            cols += [w * e_w, w * v]
        return np.column_stack(cols)

    def describe(theta: FloatArray, coef: FloatArray) -> dict:
        phi_t = (theta[2] - theta[1]) / (t_hi - t_lo)
        out = {'f_c0': coef[0], 'f_c_load': coef[1], 'f_s_load': coef[2], 'f_s0': coef[3],
               'f_s_temp': coef[4], 'f_v0': coef[5], 'f_v_temp': coef[6],
               'phi_s_load': theta[0], 'phi_s0': theta[1] - phi_t * t_lo, 'phi_s_temp': phi_t,
               't_v0': theta[3], 'alpha': theta[4]}
        if with_wear:
            out.update(f_s_wear=coef[7], f_v_wear=coef[8], phi_s_wear=theta[5])
        return {'all': out}

    def decays(theta: FloatArray, data: AuditTable) -> dict:
        v = data.numeric['speed']
        temp = data.numeric['temperature']
        return {'Stribeck (load type)': _decay(v, theta[0], theta[4]),
                'Stribeck (temperature type)': _decay(
                    v, np.maximum(stribeck_speed(theta, temp), 1e-6), theta[4])}

    name = 'complete' if with_wear else 'nominal'
    return Base(name, theta0_a, np.array(lower), np.array(upper), columns, describe, decays)


def group_codes(table: AuditTable, group: str | None,
                keys: Sequence[str] | None = None) -> tuple[list[str], NDArray[np.int_]]:
    """Return the group names and the integer group of every row (one group when None)."""
    n = table.n_rows
    if group is None:
        return ['all'], np.zeros(n, dtype=int)
    values = as_text(table, group)
    if keys is None:
        keys = sorted(set(values.tolist()))
    index = {k: i for i, k in enumerate(keys)}
    return list(keys), np.array([index.get(v, 0) for v in values], dtype=int)


def as_text(table: AuditTable, name: str) -> NDArray[np.str_]:
    """Return column ``name`` of the table as text (numbers written as ``f'{x:g}'``)."""
    if name in table.text:
        return table.text[name]
    return np.array([f'{v:g}' for v in table.numeric[name]])


# --------------------------------------------------------------------------- linear algebra

def _lstsq(x: FloatArray, y: FloatArray) -> tuple[FloatArray, int]:
    """Least squares with column scaling; return (coefficients, rank)."""
    if x.shape[1] == 0:
        return np.zeros(0), 0
    scale = np.linalg.norm(x, axis=0)
    scale[scale == 0] = 1.0
    coef, _, rank, _ = np.linalg.lstsq(x / scale, y, rcond=1e-10)
    return coef / scale, int(rank)


def _rss(x: FloatArray, y: FloatArray) -> float:
    coef, _ = _lstsq(x, y)
    r = y - x @ coef
    return float(r @ r)


def orthonormal(x: FloatArray, tol: float = 1e-6) -> FloatArray:
    """
    Return an orthonormal basis of the column space of x, shape (n, rank).

    Directions with relative singular value below ``tol`` (of unit-norm columns) count as rank
    deficiency (eigen-decomposition of the small Gram matrix, see :func:`_solve`).
    """
    if x.shape[1] == 0:
        return np.zeros((x.shape[0], 0))
    scale = np.linalg.norm(x, axis=0)
    scale[scale == 0] = 1.0
    xs = x / scale
    values, vectors = np.linalg.eigh(xs.T @ xs)
    keep = values > tol ** 2 * max(values[-1], 1e-300)
    return xs @ (vectors[:, keep] / np.sqrt(values[keep]))


# --------------------------------------------------------------------------- fitting

@dataclass(frozen=True)
class Fit:
    """One variable-projection fit: nonlinear parameters, coefficients, residual and more."""

    theta: FloatArray
    coef: FloatArray
    prediction: FloatArray
    residual: FloatArray


def design_matrix(base: Base, theta: FloatArray, table: AuditTable,
                  terms: Sequence) -> FloatArray:
    """Return the columns of ``base`` at ``theta`` and of the added ``terms``, shape (n, k)."""
    blocks = [base.columns(theta, table)] + [t.columns(table) for t in terms]
    return np.column_stack(blocks)


def _solve(x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """
    Least squares on the scaled Gram matrix; return (coefficients, orthonormal span basis).

    The columns are scaled to unit norm and the small p x p Gram matrix is diagonalised;
    directions with eigenvalues below 1e-12 of the largest (singular values below 1e-6) are
    dropped as rank deficiency.  Cheaper than a QR of the tall matrix, and accurate enough
    for residuals at the 1e-6 relative level the friction data need.
    """
    scale = np.linalg.norm(x, axis=0)
    scale = np.maximum(scale, 1e-8 * max(float(scale.max(initial=0.0)), 1e-300))
    xs = x / scale
    values, vectors = np.linalg.eigh(xs.T @ xs)
    keep = values > 1e-12 * max(values[-1], 1e-300)
    vectors, values = vectors[:, keep], values[keep]
    q = xs @ (vectors / np.sqrt(values))
    coef = vectors @ ((q.T @ y) / np.sqrt(values))
    return coef / scale, q


def _solve_nonnegative(x: FloatArray, y: FloatArray,
                       n_constrained: int | None = None) -> tuple[FloatArray, FloatArray]:
    """
    Least squares with the first ``n_constrained`` amplitudes >= 0; the others free.

    Returns (coefficients, orthonormal span of the columns in use).  When the least-squares
    solution (:func:`_solve`) has every constrained amplitude >= 0 it is returned (it is the
    optimum).  Otherwise the free columns (the terms an audit added to model (4)) are projected
    out, non-negative least squares on the
    scaled constrained columns runs in their complement, and the free coefficients follow by
    least squares.  The span is of the constrained columns whose coefficient is positive (the
    active set) and the free columns, for Kaufman's projection.  ``n_constrained`` None: all.
    """
    k = x.shape[1] if n_constrained is None else n_constrained
    coef, q = _solve(x, y)
    coef[~np.any(x, axis=0)] = 0.0  # a column of zeros (a term left out) has no amplitude
    if np.all(coef[:k] >= 0):  # the least-squares solution is feasible: it is the optimum
        return coef, q
    constrained, extra = x[:, :k], x[:, k:]
    target, projected = y, constrained
    q_extra = orthonormal(extra) if extra.shape[1] else np.zeros((len(y), 0))
    if q_extra.shape[1]:
        target = y - q_extra @ (q_extra.T @ y)
        projected = constrained - q_extra @ (q_extra.T @ constrained)
    scale = np.linalg.norm(projected, axis=0)
    # a constrained column (almost) in the span of the free ones is left to them (amplitude 0):
    # its split with a term is not determined by the data
    usable = scale > 1e-6 * np.maximum(np.linalg.norm(constrained, axis=0), 1e-300)
    coef = np.zeros(k)
    if usable.any():
        part, _ = optimize.nnls(projected[:, usable] / scale[usable], target,
                                maxiter=50 * max(k, 1))
        coef[usable] = part / scale[usable]
    free = coef > 0
    out = coef
    if extra.shape[1]:
        rest, _ = _solve(extra, y - constrained @ coef)
        out = np.concatenate([coef, rest])
    used = np.column_stack([constrained[:, free], extra])
    return out, orthonormal(used) if used.shape[1] else np.zeros((len(y), 0))


def _anchor_weight(solved: tuple, y: FloatArray, lower: FloatArray,
                   upper: FloatArray) -> FloatArray:
    """
    Return the weights of the anchor residuals weight * (theta - start) of :func:`fit_model`.

    A Gaussian prior on theta centred on the start, one bound width wide: weight = s / width,
    s^2 the residual variance at the start.  Shifting theta by a whole bound width costs as
    much as one level's noise, so the prior is negligible wherever the data determine theta.
    Where they do not (a Stribeck speed above the group's speeds, a Stribeck amplitude near
    zero), the sum of squares is flat to rounding in theta, and without the anchor the end
    point would follow rounding (the number of BLAS threads) rather than the data; with it
    the minimum is unique and stays near the start.
    """
    x, coef, q = solved
    r = x @ coef - y
    dof = max(len(y) - q.shape[1] - len(lower), 1)
    s = math.sqrt(max(float(r @ r) / dof, 1e-300))
    width = upper - lower
    width = np.where(np.isfinite(width) & (width > 0), width, 1.0)
    return s / width


def fit_model(base: Base, table: AuditTable, terms: Sequence, theta0: FloatArray,
              max_nfev: int = 100, nonnegative: bool = False) -> Fit:
    """
    Variable projection: nonlinear theta by least_squares, amplitudes by QR inside.

    The Jacobian is Kaufman's approximation (I - P) dX/dtheta c of the projected residual,
    with dX/dtheta by finite differences of the (cheap) base columns.  ``nonnegative`` keeps
    every amplitude of ``base`` >= 0 (non-negative least squares inside; model (4) of the
    paper); the amplitudes of the added ``terms`` stay free.
    """
    y = table.numeric['friction']
    fixed = [t.columns(table) for t in terms]
    n_base = base.columns(theta0, table).shape[1]
    cache: dict = {}

    def solve(theta: FloatArray) -> tuple:
        key = theta.tobytes()
        if key not in cache:
            cache.clear()
            x = np.column_stack([base.columns(theta, table)] + fixed)
            coef, q = (_solve_nonnegative(x, y, n_base) if nonnegative else _solve(x, y))
            cache[key] = (x, coef, q)
        return cache[key]

    def residual(theta: FloatArray) -> FloatArray:
        x, coef, _ = solve(theta)
        return x @ coef - y

    def jacobian(theta: FloatArray) -> FloatArray:
        x, coef, q = solve(theta)
        base_now = x[:, :n_base] @ coef[:n_base]
        d = np.empty((len(y), len(theta)))
        for j in range(len(theta)):
            step = 1e-7 * max(abs(theta[j]), 1.0)
            shifted = theta.copy()
            shifted[j] = min(theta[j] + step, upper[j])
            if shifted[j] == theta[j]:
                shifted[j] = theta[j] - step
            d[:, j] = (base.columns(shifted, table) @ coef[:n_base] - base_now) / (
                shifted[j] - theta[j])
        return d - q @ (q.T @ d)

    lower, upper = base.bounds(table)
    start = np.clip(theta0, lower + 1e-9, upper - 1e-9)
    weight = _anchor_weight(solve(start), y, lower, upper)

    def anchored_residual(theta: FloatArray) -> FloatArray:
        return np.concatenate([residual(theta), weight * (theta - start)])

    def anchored_jacobian(theta: FloatArray) -> FloatArray:
        return np.vstack([jacobian(theta), np.diag(weight)])

    result = optimize.least_squares(anchored_residual, start, jac=anchored_jacobian,
                                    bounds=(lower, upper), x_scale='jac',
                                    max_nfev=max_nfev, method='trf', ftol=1e-14, xtol=1e-12,
                                    gtol=1e-12)
    theta = result.x
    x, coef, _ = solve(theta)
    prediction = x @ coef
    return Fit(theta, coef, prediction, y - prediction)


# --------------------------------------------------------------------------- shared by identify

def wear_base(table: AuditTable, *, alpha: float, phi_s_wear: float,
              free_alpha: bool = False) -> Base:
    """
    Model (7) at known wear levels (column ``wear``): phi_s,w (and alpha if free) nonlinear.

    Columns (w exp(-|v/(phi_s,w w)|^alpha), w v) with amplitudes (F_s,w, F_v,w); theta =
    (phi_s,w,) in rad/s per unit of w, bounded by the speeds of the table: the wear Stribeck
    speed phi_s,w w stays between a fifth of the lowest and 50x the highest speed.  alpha is
    shared with (5) and fixed; with ``free_alpha`` it is identified too (theta = (phi_s,w,
    alpha), alpha in [0.3, 5]), for when the nominal data do not determine it.
    """
    v = table.numeric['speed']
    w_max = float(np.max(table.numeric['wear']))
    w_max = w_max if w_max > 0 else 1.0
    lower = [0.2 * float(v.min()) / w_max]
    upper = [50.0 * float(v.max()) / w_max]
    theta0 = [phi_s_wear]
    if free_alpha:
        lower.append(0.3)
        upper.append(5.0)
        theta0.append(alpha)
    lower_a, upper_a = np.array(lower), np.array(upper)
    theta0_a = np.clip(np.array(theta0, dtype=float), lower_a * 1.001, upper_a * 0.999)

    def exponent(theta: FloatArray) -> float:
        return float(theta[1]) if free_alpha else alpha

    def columns(theta: FloatArray, data: AuditTable) -> FloatArray:
        speed = data.numeric['speed']
        w = data.numeric['wear']
        decay = np.where(w > 0, _decay(speed, theta[0] * np.maximum(w, 1e-12),
                                       exponent(theta)), 0.0)
        return np.column_stack([w * decay, w * speed])

    def describe(theta: FloatArray, coef: FloatArray) -> dict:
        out = {'f_s_wear': coef[0], 'f_v_wear': coef[1], 'phi_s_wear': theta[0]}
        if free_alpha:
            out['alpha'] = theta[1]
        return {'all': out}

    def decays(theta: FloatArray, data: AuditTable) -> dict:
        w = np.maximum(data.numeric['wear'], 1e-12)
        return {'Stribeck (wear)': _decay(data.numeric['speed'], theta[0] * w,
                                          exponent(theta))}

    return Base('wear', theta0_a, lower_a, upper_a, columns, describe, decays)


def multistart_fit(base: Base, table: AuditTable, starts: Sequence[FloatArray], *,
                   n_best: int = 3, max_nfev: int = 200, nonnegative: bool = False,
                   rank_rows: int = 2000) -> tuple[Fit, int]:
    """
    Fit from the ``n_best`` of ``starts`` with the lowest projected RSS; keep the best fit.

    Every start costs one linear solve to rank (on at most ``rank_rows`` evenly spaced rows);
    the full variable-projection fit runs from the best few.  Returns (fit, number of starts
    ranked).
    """
    lower, upper = base.bounds(table)
    sample = table
    if table.n_rows > rank_rows:
        sample = table.subset(np.linspace(0, table.n_rows - 1, rank_rows).astype(int))
    y = sample.numeric['friction']
    ranked = []
    for theta in starts:
        theta = np.clip(np.asarray(theta, dtype=float), lower + 1e-9, upper - 1e-9)
        x = base.columns(theta, sample)
        coef, _ = (_solve_nonnegative if nonnegative else _solve)(x, y)
        r = y - x @ coef
        ranked.append((float(r @ r), theta))
    ranked.sort(key=lambda item: item[0])
    best: Fit | None = None
    for _, theta in ranked[:n_best]:
        fit = fit_model(base, table, [], theta, max_nfev=max_nfev, nonnegative=nonnegative)
        if best is None or float(fit.residual @ fit.residual) < float(
                best.residual @ best.residual):
            best = fit
    assert best is not None, 'multistart_fit needs at least one start'
    return best, len(ranked)
