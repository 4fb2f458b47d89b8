"""Audit a friction model on measured friction levels: find, name and add what it misses.

The loop of the paper's own modelling (the load and temperature terms of (5) were added because
the speed-only model (4) left structure in its residuals), made a tool:

1. identify the chosen model on the table of friction levels (variable projection: the few
   nonlinear parameters, Stribeck speeds, exponent alpha, T_V0, by ``least_squares``; all
   amplitudes by linear least squares inside every residual evaluation);
2. test the residual for structure against every candidate variable (every numeric or text
   column the model does not use), alone (smooth spline, periodic), with speed (interaction) and
   in pairs, by nested F-tests at the fitted nonlinear parameters, with Benjamini-Hochberg false
   discovery control over all candidates of the step;
3. name the most significant effect with the simplest shape the data support (by BIC among a
   linear Coulomb-like offset, a Stribeck-shaped or viscous interaction with speed, a sinusoid,
   a bilinear term, or a smooth spline/tensor term), add it, re-identify everything jointly;
4. repeat while the evidence holds and the cross-validated (held-out) error improves.

Units: speeds motor side [rad/s], friction in the table's own unit (normalised for the packaged
model; N.m for the KUKA data), temperature [degC]; candidate variables in their own units.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
import gzip
import math
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import optimize, spatial, stats

from robot_wear_monitor.audit.fitting import (  # the identification core shared with identify
    _as_text, _Base, _cv_rms, _decay, _design, _fit, _Fit, _folds, _group_codes, _nominal_base,
    _orthonormal, _speed_base, AuditTable)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import FrictionModel, ParameterSet

FloatArray = NDArray[np.float64]

MODELS = ('speed', 'nominal', 'complete')
REQUIRED_COLUMNS = {'speed': ('speed', 'friction'),
                    'nominal': ('speed', 'friction', 'temperature', 'load'),
                    'complete': ('speed', 'friction', 'temperature', 'load', 'wear')}
# Columns that are never candidate explanatory variables.
_RESERVED = ('friction', 'friction_std_error', 'experiment')
_CATEGORICAL_MAX_LEVELS = 8
#: Fewest distinct speeds per group for the five-parameter speed model (4).
MIN_SPEEDS = 6


def table_from_columns(columns: Mapping[str, Sequence], *, source: str = '<table>',
                       model: str = 'speed') -> AuditTable:
    """Validate a mapping of columns into an :class:`AuditTable`.

    Numeric columns become float arrays; a column whose values are not all numbers is a text
    (categorical) column.  Raises :class:`InputError` for an empty table, unequal lengths,
    missing required columns, NaN/inf or non-positive speeds.
    """
    if model not in MODELS:
        raise InputError(f'unknown model {model!r} (expected one of {", ".join(MODELS)})')
    if not columns:
        raise InputError(f'{source}: the table has no columns')
    lengths = {len(v) for v in columns.values()}
    if len(lengths) != 1:
        raise InputError(f'{source}: columns have different lengths {sorted(lengths)}')
    if lengths.pop() == 0:
        raise InputError(f'{source}: the table has no rows')
    numeric: dict[str, FloatArray] = {}
    text: dict[str, NDArray[np.str_]] = {}
    for name, values in columns.items():
        name = str(name).strip()
        array = np.asarray(values)
        if array.dtype.kind in 'fiub':
            numeric[name] = array.astype(float)
            continue
        try:
            numeric[name] = np.array([float(v) for v in array], dtype=float)
        except (TypeError, ValueError):
            text[name] = np.array([str(v).strip() for v in array])
    missing = [c for c in REQUIRED_COLUMNS[model] if c not in numeric]
    if missing:
        what = 'non-numeric' if missing[0] in text else 'missing'
        raise InputError(f'{source}: column {missing[0]!r} is {what} (the {model} model needs '
                         f'{", ".join(REQUIRED_COLUMNS[model])})')
    for name, array in numeric.items():
        bad = ~np.isfinite(array)
        if bad.any():
            raise InputError(f'{source}: column {name!r} has NaN or inf values '
                             f'(first at row {int(np.argmax(bad)) + 1})')
    if np.any(numeric['speed'] <= 0):
        raise InputError(f'{source}: column \'speed\' must be > 0 (the friction level of eq. (3) '
                         'is direction independent: use |speed|)')
    return AuditTable(numeric, text, source)


def read_level_table(path: str | Path, *, model: str = 'speed') -> AuditTable:
    """Read a CSV (optionally .gz) table of friction levels with a header row."""
    file = Path(path)
    opener = gzip.open if file.suffix == '.gz' else open
    try:
        with opener(file, 'rt', encoding='utf-8', newline='') as stream:
            rows = list(csv.reader(stream))
    except OSError as error:
        raise InputError(f'{file}: cannot read: {error.strerror or error}') from None
    except (UnicodeDecodeError, csv.Error) as error:
        raise InputError(f'{file}: not a CSV text table ({error})') from None
    rows = [r for r in rows if r and any(cell.strip() for cell in r)]
    if not rows:
        raise InputError(f'{file}: empty table')
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    if not body:
        raise InputError(f'{file}: the table has no rows')
    if len(set(header)) != len(header):
        raise InputError(f'{file}: duplicate column names in the header')
    for number, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise InputError(f'{file}: line {number} has {len(row)} fields, the header '
                             f'{len(header)}')
    columns = {name: [row[i].strip() for row in body] for i, name in enumerate(header)}
    for name in REQUIRED_COLUMNS.get(model, ()):
        values = columns.get(name)
        if values is not None and any(v == '' or v.lower() == 'nan' for v in values):
            raise InputError(f'{file}: column {name!r} has empty or NaN values')
    return table_from_columns(columns, source=str(file), model=model)


def table_from_levels(levels: Sequence, *, extra: Mapping[str, Sequence] | None = None,
                      source: str = '<levels>', model: str = 'speed') -> AuditTable:
    """Build a table from :class:`~robot_wear_monitor.experiment.levels.FrictionLevel` objects.

    Columns: ``speed``, ``friction``, ``friction_std_error`` and the candidates
    ``position_centre`` [rad], ``position_span`` [rad], ``time`` (level centre time) [s];
    ``extra`` adds per-level columns (e.g. ``experiment``, ``joint``).
    """
    if not levels:
        raise InputError(f'{source}: no friction levels')
    columns: dict[str, Sequence] = {
        'speed': [lv.speed_rad_s for lv in levels],
        'friction': [lv.friction for lv in levels],
        'friction_std_error': [lv.friction_std_error for lv in levels],
        'position_centre': [0.5 * (lv.position_min_rad + lv.position_max_rad) for lv in levels],
        'position_span': [lv.position_max_rad - lv.position_min_rad for lv in levels],
        'time': [0.5 * (lv.start_time_s + lv.end_time_s) for lv in levels],
    }
    columns.update(extra or {})
    return table_from_columns(columns, source=source, model=model)


# --------------------------------------------------------------------------- candidate bases

@dataclass(frozen=True)
class _Variable:
    """A candidate explanatory variable: a numeric column scaled to [0, 1] or categories."""

    name: str
    kind: str  # 'continuous' | 'categorical'
    lo: float = 0.0
    hi: float = 1.0
    knots: tuple = ()
    levels: tuple = ()
    n_unique: int = 0

    def scaled(self, table: AuditTable) -> FloatArray:
        """Return the variable mapped to [0, 1] by the range of the audited table."""
        x = table.numeric[self.name]
        return np.clip((x - self.lo) / (self.hi - self.lo), -0.5, 1.5)

    def onehot(self, table: AuditTable) -> FloatArray:
        """Return the indicator columns of every category, shape (n, levels)."""
        values = _as_text(table, self.name)
        return np.column_stack([(values == lv).astype(float) for lv in self.levels])

    def smooth(self, table: AuditTable) -> FloatArray:
        """Natural cubic spline in the variable (linear beyond the outer knots), shape (n, df).

        Restricted cubic spline basis with knots at quantiles of the audited table, so that
        held-out levels outside the training range are extrapolated linearly, not cubically.
        Categorical variables: the indicators minus the first category.
        """
        if self.kind == 'categorical':
            return self.onehot(table)[:, 1:]
        z = self.scaled(table)
        if len(self.knots) < 3:
            degree = min(3, self.n_unique - 1)
            return np.column_stack([(z - 0.5) ** d for d in range(1, degree + 1)])
        t = np.asarray(self.knots)
        last, before = t[-1], t[-2]
        cols = [z - 0.5]
        for tj in t[:-2]:
            cols.append((np.clip(z - tj, 0, None) ** 3
                         - np.clip(z - before, 0, None) ** 3 * (last - tj) / (last - before)
                         + np.clip(z - last, 0, None) ** 3 * (before - tj) / (last - before)))
        return np.column_stack(cols)

    def small(self, table: AuditTable) -> FloatArray:
        """Basis for tensor products, constant included: [1, z, z^2] or all indicators."""
        if self.kind == 'categorical':
            return self.onehot(table)
        z = self.scaled(table) - 0.5
        degree = min(2, self.n_unique - 1)
        return np.column_stack([z ** d for d in range(degree + 1)])

    def linear(self, table: AuditTable) -> FloatArray:
        """Return the variable itself (centred), or the indicators minus the first category."""
        if self.kind == 'categorical':
            return self.onehot(table)[:, 1:]
        return (table.numeric[self.name] - 0.5 * (self.lo + self.hi))[:, None]


def _make_variable(table: AuditTable, name: str) -> _Variable | None:
    """Describe a candidate column; None when it is constant."""
    if name in table.text:
        levels = tuple(sorted(set(table.text[name].tolist())))
        return _Variable(name, 'categorical', levels=levels) if len(levels) > 1 else None
    x = table.numeric[name]
    unique = np.unique(x)
    if len(unique) < 2:
        return None
    integer = np.all(unique == np.round(unique))
    if integer and len(unique) <= min(_CATEGORICAL_MAX_LEVELS, len(x) // 4) and len(unique) > 2:
        return _Variable(name, 'categorical', levels=tuple(f'{u:g}' for u in unique))
    lo, hi = float(unique[0]), float(unique[-1])
    z = (x - lo) / (hi - lo)
    n_knots = int(min(6, len(unique) // 3))
    quantiles = np.quantile(z, np.linspace(0.05, 0.95, max(n_knots, 1)))
    knots = tuple(float(k) for k in np.unique(quantiles)) if n_knots >= 3 else ()
    return _Variable(name, 'continuous', lo, hi, knots, n_unique=len(unique))


@dataclass(frozen=True)
class Term:
    """A term added to the model: named shape, variables and fixed basis columns.

    ``columns(table)`` returns the basis, shape (n, df); the amplitudes are re-identified with
    the base model.  ``info`` holds shape constants (period, Stribeck speed) for the report.
    """

    name: str
    shape: str
    variables: tuple[str, ...]
    columns: Callable[[AuditTable], FloatArray]
    df: int
    info: Mapping[str, float] = field(default_factory=dict)


def _speed_poly(table: AuditTable, lo: float, hi: float) -> FloatArray:
    """Cubic polynomial in log speed scaled to [-0.5, 0.5], constant included, shape (n, 4)."""
    s = (np.log(table.numeric['speed']) - lo) / max(hi - lo, 1e-12) - 0.5
    return np.column_stack([s ** d for d in range(4)])


def _tensor(a: FloatArray, b: FloatArray) -> FloatArray:
    return (a[:, :, None] * b[:, None, :]).reshape(len(a), -1)


class _Candidates:
    """Builds candidate bases (for the tests) and named shapes (for the chosen effect)."""

    def __init__(self, table: AuditTable, variables: Sequence[_Variable],
                 group_variable: _Variable | None, base: _Base, theta: FloatArray):
        self.table = table
        self.variables = {v.name: v for v in variables}
        self.group_variable = group_variable
        self.base = base
        self.theta = theta
        log_v = np.log(table.numeric['speed'])
        self.log_v_range = (float(log_v.min()), float(log_v.max()))
        self.speed_varies = self.log_v_range[1] - self.log_v_range[0] > 1e-6

    # -- the families tested for structure: (key, variables, basis, extra multiplicity)
    def families(self) -> list[tuple[str, tuple[str, ...], Callable, int]]:
        """Return the candidate families: each a key, its variables, basis and multiplicity."""
        out = []
        names = list(self.variables)
        for name in names:
            var = self.variables[name]
            out.append((f'{name}', (name,), var.smooth, 1))
            if var.kind == 'continuous' and var.n_unique >= 8:
                out.append((f'periodic {name}', (name,), None, 0))
            if self.speed_varies:
                out.append((f'speed x {name}', ('speed', name),
                            self._speed_interaction_basis(var), 1))
        pair_vars = [self.variables[n] for n in names]
        if self.group_variable is not None:
            pair_vars.append(self.group_variable)
        for i, a in enumerate(pair_vars):
            for b in pair_vars[i + 1:]:
                if a.kind == 'categorical' and b.kind == 'categorical' and (
                        len(a.levels) * len(b.levels) > 4 * _CATEGORICAL_MAX_LEVELS):
                    continue
                out.append((f'{a.name} x {b.name}', (a.name, b.name),
                            self._pair_basis(a, b), 1))
        return out

    def _speed_interaction_basis(self, var: _Variable) -> Callable:
        lo, hi = self.log_v_range

        def basis(table: AuditTable) -> FloatArray:
            return _tensor(var.linear(table) if var.kind == 'continuous'
                           else var.onehot(table), _speed_poly(table, lo, hi))
        return basis

    @staticmethod
    def _pair_basis(a: _Variable, b: _Variable) -> Callable:
        def basis(table: AuditTable) -> FloatArray:
            return _tensor(a.small(table), b.small(table))[:, 1:]
        return basis

    # -- periodic scan
    def periodic(self, name: str, x0_basis: FloatArray, residual: FloatArray,
                 n_theta: int) -> tuple[float, float, int]:
        """Scan the period of a sinusoid in ``name``; return (log p, period, n frequencies).

        The p-value is Bonferroni-corrected for the number of independent frequencies scanned.
        """
        var = self.variables[name]
        x = self.table.numeric[name]
        span = var.hi - var.lo
        k_max = int(max(2, min(40, var.n_unique // 3)))
        freqs = np.arange(1.0, k_max + 0.01, 0.25) / span
        q0 = _orthonormal(x0_basis)
        best = (math.inf, 0.0)
        for f in freqs:
            basis = np.column_stack([np.sin(2 * np.pi * f * x), np.cos(2 * np.pi * f * x)])
            log_p, _ = _nested_test(q0, residual, basis, n_theta)
            if log_p < best[0]:
                best = (log_p, 1.0 / f)
        step = 0.25 / span

        def cost(f: float) -> float:
            basis = np.column_stack([np.sin(2 * np.pi * f * x), np.cos(2 * np.pi * f * x)])
            return _nested_test(q0, residual, basis, n_theta)[0]
        f0 = 1.0 / best[1]
        refined = optimize.minimize_scalar(cost, bounds=(f0 - step, f0 + step),
                                           method='bounded', options={'xatol': 1e-4 * step})
        if refined.fun < best[0]:
            best = (float(refined.fun), 1.0 / float(refined.x))
        log_p = min(0.0, best[0] + math.log(k_max))
        return log_p, best[1], k_max

    # -- named shapes of a chosen family
    def shapes(self, variables: tuple[str, ...], periods: Mapping[str, float]) -> list[Term]:
        """Return the shapes to choose from for an effect in ``variables`` (and subsets)."""
        terms: list[Term] = []
        singles = [n for n in variables if n in self.variables]
        for name in singles:
            terms += self._single_shapes(name, periods.get(name))
        if 'speed' in variables and self.speed_varies:
            for name in singles:
                terms += self._speed_shapes(name)
        pair = [n for n in variables if n != 'speed']
        if len(pair) == 2:
            a = self.variables.get(pair[0]) or self.group_variable
            b = self.variables.get(pair[1]) or self.group_variable
            terms += self._pair_shapes(a, b)
        return terms

    def _single_shapes(self, name: str, period: float | None) -> list[Term]:
        var = self.variables[name]
        if var.kind == 'categorical':
            return [Term(f'offset per {name} (Coulomb-like)', 'offset per category', (name,),
                         var.linear, len(var.levels) - 1)]
        out = [Term(f'linear in {name} (Coulomb-like offset)', 'linear', (name,), var.linear, 1)]
        smooth = var.smooth(self.table)
        if smooth.shape[1] > 1:
            out.append(Term(f'smooth in {name}', 'smooth', (name,), var.smooth,
                            smooth.shape[1]))
        if period is not None and period > 0:
            out.append(self._sinusoid(name, period))
        return out

    def _sinusoid(self, name: str, period: float) -> Term:
        def basis(table: AuditTable) -> FloatArray:
            x = table.numeric[name]
            return np.column_stack([np.sin(2 * np.pi * x / period),
                                    np.cos(2 * np.pi * x / period)])
        return Term(f'periodic in {name} (period {period:.4g}, ripple)', 'periodic', (name,),
                    basis, 3, {'period': period})

    def _speed_shapes(self, name: str) -> list[Term]:
        var = self.variables[name]
        lo, hi = self.log_v_range
        x_basis = var.linear if var.kind == 'continuous' else var.onehot
        out = []
        v = self.table.numeric['speed']
        alpha = _base_alpha(self.base, self.theta)
        grid = np.exp(np.linspace(math.log(v.min() / 5), math.log(v.max()), 24))
        out += [self._stribeck_term(name, x_basis, phi, alpha) for phi in grid]

        def viscous(table: AuditTable) -> FloatArray:
            return x_basis(table) * table.numeric['speed'][:, None]
        k = x_basis(self.table).shape[1]
        out.append(Term(f'viscous slope varies with {name}', 'viscous interaction',
                        ('speed', name), viscous, k))

        def smooth(table: AuditTable) -> FloatArray:
            return _tensor(x_basis(table), _speed_poly(table, lo, hi))
        out.append(Term(f'smooth speed x {name} interaction', 'smooth interaction',
                        ('speed', name), smooth, 4 * k))
        return out

    @staticmethod
    def _stribeck_term(name: str, x_basis: Callable, phi: float, alpha: float) -> Term:
        def basis(table: AuditTable) -> FloatArray:
            return x_basis(table) * _decay(table.numeric['speed'], phi, alpha)[:, None]
        return Term(f'Stribeck amplitude varies with {name} (phi_s {phi:.3g} rad/s)',
                    'Stribeck interaction', ('speed', name), basis, 2,
                    {'stribeck_speed_rad_s': phi, 'alpha': alpha})

    def _pair_shapes(self, a: _Variable, b: _Variable) -> list[Term]:
        out = []
        if a.kind == 'continuous' and b.kind == 'continuous':
            def bilinear(table: AuditTable) -> FloatArray:
                xa, xb = a.linear(table)[:, 0], b.linear(table)[:, 0]
                return np.column_stack([xa, xb, xa * xb])
            out.append(Term(f'bilinear {a.name} x {b.name}', 'bilinear', (a.name, b.name),
                            bilinear, 3))
        else:
            cat, cont = (a, b) if a.kind == 'categorical' else (b, a)
            if cont.kind == 'continuous':
                def slope(table: AuditTable) -> FloatArray:
                    ind = cat.onehot(table)
                    return np.column_stack([ind[:, 1:], ind * cont.linear(table)])
                out.append(Term(f'linear in {cont.name}, slope per {cat.name}',
                                'slope per category', (cont.name, cat.name), slope,
                                2 * len(cat.levels) - 1))
        basis = self._pair_basis(a, b)
        out.append(Term(f'smooth {a.name} x {b.name} interaction', 'smooth tensor',
                        (a.name, b.name), basis, basis(self.table).shape[1]))
        return out


def _base_alpha(base: _Base, theta: FloatArray) -> float:
    if base.name == 'speed':
        return float(np.median(theta[1::2]))
    return float(theta[4])


def _nested_test(q0: FloatArray, residual: FloatArray, basis: FloatArray,
                 n_theta: int) -> tuple[float, int]:
    """F-test of adding ``basis`` to the linear model spanned by q0 (orthonormal).

    Returns (log p-value, numerator degrees of freedom); (0, 0) when nothing new is spanned.
    """
    perp = basis - q0 @ (q0.T @ basis)
    q1 = _orthonormal(perp, tol=1e-5)
    df1 = q1.shape[1]
    n = len(residual)
    df2 = n - q0.shape[1] - df1 - n_theta
    if df1 == 0 or df2 <= 0:
        return 0.0, 0
    rss0 = float(residual @ residual)
    gain = float(np.sum((q1.T @ residual) ** 2))
    rss1 = max(rss0 - gain, 1e-300)
    f_value = (gain / df1) / (rss1 / df2)
    return float(stats.f.logsf(f_value, df1, df2)), df1


# --------------------------------------------------------------------------- noise floor

def noise_floor(*, table: AuditTable, residual: FloatArray, n_parameters: int,
                variables: Sequence[str]) -> tuple[float, str]:
    """Estimate the std of the level-to-level error that no model of these columns removes.

    1. ``replicates``: rows that agree in every column except the friction ones repeat one
       condition; the pooled within-group std of friction is model-free (used when they give
       at least 10 degrees of freedom and 10 % of the rows).
    2. ``nearest neighbour``: otherwise, half the mean squared difference of the final residuals
       between each level and its nearest neighbour in the space of all variables (each scaled
       to [0, 1], categories kept apart), corrected for the fitted parameters.  Structure the
       model missed is largely differenced out between neighbours.

    Returns (noise floor in friction units, method).
    """
    y = table.numeric['friction']
    n = len(y)
    keys = [k for k in table.columns if k not in ('friction', 'friction_std_error')]
    matrix = np.column_stack(
        [table.numeric[k] if k in table.numeric else
         np.unique(table.text[k], return_inverse=True)[1].astype(float) for k in keys])
    _, inverse, counts = np.unique(matrix, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    dof = int(np.sum(counts - 1))
    if dof >= max(10, n // 10):
        means = np.bincount(inverse, weights=y) / counts
        within = float(np.sum((y - means[inverse]) ** 2))
        return math.sqrt(within / dof), f'replicates ({dof} degrees of freedom)'
    cols = []
    for k in variables:
        if k in table.text or (k in table.numeric and len(np.unique(table.numeric[k])) <= 8):
            codes = np.unique(_as_text(table, k), return_inverse=True)[1]
            cols.append(codes * 100.0)
        elif k in table.numeric:
            x = table.numeric[k]
            if k == 'speed':
                x = np.log(x)
            span = float(x.max() - x.min())
            cols.append((x - x.min()) / span if span > 0 else np.zeros(n))
    points = np.column_stack(cols) if cols else np.zeros((n, 1))
    points = points + 1e-9 * np.arange(n)[:, None]  # break exact ties deterministically
    _, index = spatial.cKDTree(points).query(points, k=2)
    diff = residual - residual[index[:, 1]]
    correction = n / max(n - n_parameters, 1)
    return math.sqrt(0.5 * float(np.mean(diff ** 2)) * correction), 'nearest neighbour'


# --------------------------------------------------------------------------- the audit

@dataclass(frozen=True)
class Effect:
    """An effect the audit traced and added to the model.

    Attributes:
        name: human-readable name of the term (shape and variables).
        shape: 'linear', 'periodic', 'Stribeck interaction', 'smooth', ... .
        variables: the table columns it depends on.
        df: number of parameters the term adds (amplitudes, plus a period or Stribeck speed).
        log10_p: log10 of the F-test p-value that found it (BH-controlled family).
        rms_cv_before: held-out RMS error before adding it [friction units].
        rms_cv_after: held-out RMS error after adding it [friction units].
        size_rms: RMS over the table of the change of the fitted friction when the term is
            added and everything re-identified [friction units].
        size_range: max - min of that change [friction units].
        info: shape constants (period, Stribeck speed).

    """

    name: str
    shape: str
    variables: tuple[str, ...]
    df: int
    log10_p: float
    rms_cv_before: float
    rms_cv_after: float
    size_rms: float
    size_range: float
    info: Mapping[str, float]

    @property
    def rms_gain(self) -> float:
        """Reduction of the held-out RMS error the term brings [friction units]."""
        return self.rms_cv_before - self.rms_cv_after

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (finite numbers only)."""
        return {'name': self.name, 'shape': self.shape, 'variables': list(self.variables),
                'df': self.df, 'log10_p': _finite(self.log10_p),
                'rms_cv_before': self.rms_cv_before, 'rms_cv_after': self.rms_cv_after,
                'rms_gain': self.rms_gain,
                'relative_gain': self.rms_gain / self.rms_cv_before
                if self.rms_cv_before > 0 else 0.0,
                'size_rms': self.size_rms, 'size_range': self.size_range,
                'info': {k: float(v) for k, v in self.info.items()}}


@dataclass(frozen=True)
class AuditResult:
    """Outcome of :func:`run_audit`.

    Attributes:
        model: 'speed', 'nominal' or 'complete'.
        n_levels: rows audited.
        group: column the base model is identified per group of (or None).
        candidates: the candidate variables examined.
        rms_before: held-out RMS error of the model alone [friction units].
        rms_after: held-out RMS error with the effects added.
        fit_rms_before: in-sample RMS error of the model alone.
        fit_rms_after: in-sample RMS error with the effects.
        noise_floor: estimated std of the irreducible level error [friction units].
        noise_floor_method: how it was estimated (see :func:`noise_floor`).
        folds: description of the cross-validation folds.
        effects: the effects added, in order.
        steps: per step, the best candidates and the decision (for the report).
        residual_before: in-sample residuals of the model alone, shape (n,).
        residual_after: in-sample residuals of the extended model, shape (n,).
        parameters_before: identified base-model parameters without effects.
        parameters_after: identified base-model parameters with the effects.
        estimate_changes: how the (T, w) estimates change (None when not applicable).
        stop_reason: why the loop stopped.
        excluded: groups left out (too few distinct speeds), with the reason.

    """

    model: str
    n_levels: int
    group: str | None
    candidates: tuple[str, ...]
    rms_before: float
    rms_after: float
    fit_rms_before: float
    fit_rms_after: float
    noise_floor: float
    noise_floor_method: str
    folds: str
    effects: tuple[Effect, ...]
    steps: tuple[dict, ...]
    residual_before: FloatArray
    residual_after: FloatArray
    parameters_before: dict
    parameters_after: dict
    estimate_changes: dict | None
    stop_reason: str
    excluded: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """Return the JSON report (valid JSON: no NaN or inf)."""
        return _json_clean({
            'model': self.model, 'n_levels': self.n_levels, 'group': self.group,
            'candidates': list(self.candidates),
            'rms_before': self.rms_before, 'rms_after': self.rms_after,
            'fit_rms_before': self.fit_rms_before, 'fit_rms_after': self.fit_rms_after,
            'noise_floor': self.noise_floor, 'noise_floor_method': self.noise_floor_method,
            'folds': self.folds, 'effects': [e.to_dict() for e in self.effects],
            'steps': list(self.steps), 'stop_reason': self.stop_reason,
            'parameters_before': self.parameters_before,
            'parameters_after': self.parameters_after,
            'estimate_changes': self.estimate_changes, 'excluded': list(self.excluded)})

    def summary(self) -> str:
        """Return a short plain-text report."""
        lines = [f'audit of the {self.model} model on {self.n_levels} friction levels'
                 + (f' (identified per {self.group})' if self.group else ''),
                 f'  candidates: {", ".join(self.candidates) or "(none)"}',
                 f'  held-out RMS error before: {self.rms_before:.4g}',
                 f'  held-out RMS error after:  {self.rms_after:.4g}',
                 f'  noise floor: {self.noise_floor:.4g} ({self.noise_floor_method})',
                 f'  folds: {self.folds}']
        lines += [f'  left out: {text}' for text in self.excluded]
        if not self.effects:
            lines.append('  no effect added')
        for i, effect in enumerate(self.effects, start=1):
            lines.append(f'  effect {i}: {effect.name} [{", ".join(effect.variables)}], '
                         f'size {effect.size_rms:.3g} rms, held-out error '
                         f'{effect.rms_cv_before:.4g} -> {effect.rms_cv_after:.4g} '
                         f'(log10 p {effect.log10_p:.1f})')
        lines.append(f'  stopped: {self.stop_reason}')
        if self.estimate_changes:
            for key, value in self.estimate_changes.items():
                if isinstance(value, bool):
                    continue
                if isinstance(value, (int, float)):
                    lines.append(f'  {key}: {value:.4g}')
                elif isinstance(value, str):
                    lines.append(f'  {key}: {value}')
        return '\n'.join(lines)


def _finite(value: float) -> float:
    return float(value) if math.isfinite(value) else (-1e300 if value < 0 else 1e300)


def _json_clean(value):
    if isinstance(value, dict):
        return {str(k): _json_clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_clean(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return _finite(float(value)) if math.isfinite(float(value)) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.ndarray):
        return _json_clean(value.tolist())
    return value


def candidate_columns(table: AuditTable, *, model: str, group: str | None = None) -> list[str]:
    """Return the candidate explanatory columns: all but the model's, friction and IDs."""
    used = set(REQUIRED_COLUMNS[model]) | set(_RESERVED)
    if group is not None:
        used.add(group)
    return [c for c in table.columns if c not in used]


def run_audit(*, table: AuditTable, model: str = 'speed', params: ParameterSet | None = None,
              group: str | None = None, fdr: float = 0.01, min_gain: float = 0.01,
              max_effects: int = 4, n_folds: int = 5, seed: int = 0,
              estimate: bool = True) -> AuditResult:
    """Identify ``model`` on ``table``, trace the structure of its residuals and add it.

    Args:
        table: friction levels (see :func:`read_level_table`).
        model: 'speed' (eq. 4, per ``group``), 'nominal' (eq. 5) or 'complete' (eq. 8).
        params: parameter set whose coefficients start the nominal/complete fit and that the
            (T, w) estimator uses; the packaged set when None.
        group: column whose every value gets its own speed model (e.g. ``joint``).
        fdr: false-discovery rate of the Benjamini-Hochberg control over each step's candidates.
        min_gain: minimum relative reduction of the held-out error for an effect to be kept.
        max_effects: at most this many effects are added.
        n_folds: cross-validation folds (by ``experiment`` when that column exists).
        seed: seed of the fold assignment.
        estimate: also report how the (T, w) estimates change (nominal/complete model with an
            ``experiment`` column; runs the wear estimator twice per experiment).

    Returns:
        The :class:`AuditResult`.

    """
    if model not in MODELS:
        raise InputError(f'unknown model {model!r} (expected one of {", ".join(MODELS)})')
    missing = [c for c in REQUIRED_COLUMNS[model] if c not in table.numeric]
    if missing:
        raise InputError(f'{table.source}: column {missing[0]!r} is missing (the {model} '
                         f'model needs {", ".join(REQUIRED_COLUMNS[model])})')
    if group is not None and group not in table.columns:
        raise InputError(f'{table.source}: group column {group!r} is missing')
    if group is not None and model != 'speed':
        raise InputError('--group applies to the speed model only')
    if params is None and model != 'speed':
        from robot_wear_monitor.model.params import load_parameter_set
        params = load_parameter_set()
    table, excluded = _enough_speeds(table, group, model)
    base = (_speed_base(table, group) if model == 'speed'
            else _nominal_base(table, params.model, model == 'complete'))
    n = table.n_rows
    if n < len(base.theta0) + 3 * _n_linear(base, table) // 2 + 5:
        raise InputError(f'{table.source}: {n} friction levels are too few to audit the '
                         f'{model} model')
    names = candidate_columns(table, model=model, group=group)
    variables = [v for v in (_make_variable(table, c) for c in names) if v is not None]
    group_variable = _make_variable(table, group) if group is not None else None
    folds, fold_text = _folds(table, n_folds, seed)

    fit = _fit(base, table, [], base.theta0)
    fit_before = fit
    cv_before, _ = _cv_rms(base, table, [], fit.theta, folds)
    cv_now = cv_before
    terms: list[Term] = []
    effects: list[Effect] = []
    steps: list[dict] = []
    stop = 'maximum number of effects reached'
    for _ in range(max_effects):
        step = _step(table, base, fit, terms, variables, group_variable, fdr)
        steps.append(step['report'])
        if step['term'] is None:
            stop = step['report']['decision']
            break
        trial_terms = terms + [step['term']]
        trial_fit = _fit(base, table, trial_terms, fit.theta)
        cv_trial, _ = _cv_rms(base, table, trial_terms, trial_fit.theta, folds)
        step['report']['rms_cv_with_term'] = cv_trial
        if cv_trial > cv_now * (1.0 - min_gain):
            step['report']['decision'] = (f'rejected: held-out error {cv_now:.4g} -> '
                                          f'{cv_trial:.4g} (needs {min_gain:.0%} gain)')
            stop = 'the most significant effect does not lower the held-out error'
            break
        step['report']['decision'] = 'added'
        change = trial_fit.prediction - fit.prediction
        effects.append(Effect(step['term'].name, step['term'].shape, step['term'].variables,
                              step['term'].df, step['log10_p'], cv_now, cv_trial,
                              float(np.sqrt(np.mean(change ** 2))), float(np.ptp(change)),
                              dict(step['term'].info)))
        terms, fit, cv_now = trial_terms, trial_fit, cv_trial
    n_params = _rank(_design(base, fit.theta, table, terms)) + len(base.theta0)
    floor_vars = ['speed'] + [c for c in REQUIRED_COLUMNS[model] if c not in
                              ('speed', 'friction')] + [v.name for v in variables]
    if group is not None:
        floor_vars.append(group)
    floor, floor_method = noise_floor(table=table, residual=fit.residual, n_parameters=n_params,
                                      variables=floor_vars)
    changes = (_estimate_changes(table, model, params, base, fit_before, fit, terms)
               if estimate else None)
    return AuditResult(
        model=model, n_levels=n, group=group, candidates=tuple(v.name for v in variables),
        rms_before=cv_before, rms_after=cv_now,
        fit_rms_before=float(np.sqrt(np.mean(fit_before.residual ** 2))),
        fit_rms_after=float(np.sqrt(np.mean(fit.residual ** 2))),
        noise_floor=floor, noise_floor_method=floor_method, folds=fold_text,
        effects=tuple(effects), steps=tuple(steps), residual_before=fit_before.residual,
        residual_after=fit.residual,
        parameters_before=_json_clean(base.describe(fit_before.theta, fit_before.coef)),
        parameters_after=_json_clean(base.describe(fit.theta, fit.coef)),
        estimate_changes=changes, stop_reason=stop, excluded=excluded)


def _distinct_speeds(speed: FloatArray) -> int:
    """Return the number of distinct speed levels (equal within 2 %)."""
    return len(np.unique(np.round(np.log(speed) / 0.02)))


def _enough_speeds(table: AuditTable, group: str | None,
                   model: str) -> tuple[AuditTable, tuple[str, ...]]:
    """Drop the groups with fewer than MIN_SPEEDS distinct speeds (speed model only).

    The speed model (4) has five parameters per group; with fewer distinct speeds it
    interpolates its training speeds exactly and the held-out error is meaningless.
    """
    if model != 'speed':
        return table, ()
    speed = table.numeric['speed']
    if group is None:
        if _distinct_speeds(speed) < MIN_SPEEDS:
            raise InputError(f'{table.source}: {_distinct_speeds(speed)} distinct speeds; the '
                             f'speed model (4) needs at least {MIN_SPEEDS}')
        return table, ()
    keys, codes = _group_codes(table, group)
    keep = np.ones(table.n_rows, dtype=bool)
    excluded = []
    for i, key in enumerate(keys):
        rows = codes == i
        count = _distinct_speeds(speed[rows])
        if count < MIN_SPEEDS:
            keep &= ~rows
            excluded.append(f'{group} {key}: {count} distinct speeds (< {MIN_SPEEDS})')
    if not keep.any():
        raise InputError(f'{table.source}: no {group} has {MIN_SPEEDS} or more distinct speeds')
    return table.subset(keep), tuple(excluded)


def _n_linear(base: _Base, table: AuditTable) -> int:
    return base.columns(base.theta0, table.subset(np.arange(1))).shape[1]


def _rank(x: FloatArray) -> int:
    return _orthonormal(x).shape[1]


def _step(table: AuditTable, base: _Base, fit: _Fit, terms: Sequence[Term],
          variables: Sequence[_Variable], group_variable: _Variable | None,
          fdr: float) -> dict:
    """Test every candidate family against the current model; choose the effect to add."""
    x0 = _design(base, fit.theta, table, terms)
    q0 = _orthonormal(x0)
    # the linearised base model: also project out the Jacobian in theta (nonlinear params)
    jac = _theta_jacobian(base, table, terms, fit)
    q0 = _orthonormal(np.column_stack([q0, jac]))
    n_theta = 0  # the theta directions are already in q0
    builder = _Candidates(table, variables, group_variable, base, fit.theta)
    rows = []
    for key, names, basis, _ in builder.families():
        period = None
        if basis is None:
            log_p, period, _ = builder.periodic(names[0], q0, fit.residual, n_theta)
            df1 = 2
        else:
            log_p, df1 = _nested_test(q0, fit.residual, basis(table), n_theta)
        if df1 == 0:
            continue
        rows.append({'candidate': key, 'variables': names, 'log_p': log_p, 'df': df1,
                     'period': period})
    report: dict = {'n_candidates': len(rows)}
    if not rows:
        report['decision'] = 'no candidate variables to test'
        return {'term': None, 'report': report, 'log10_p': 0.0}
    log_p = np.array([r['log_p'] for r in rows])
    adjusted = stats.false_discovery_control(np.exp(log_p), method='bh')
    order = np.argsort(log_p)
    report['best'] = [{'candidate': rows[i]['candidate'],
                       'log10_p': float(log_p[i] / math.log(10)),
                       'q_value': float(adjusted[i]), 'df': rows[i]['df']}
                      for i in order[:6]]
    significant = adjusted <= fdr
    if not significant.any():
        report['decision'] = (f'no significant structure (smallest BH q-value '
                              f'{adjusted.min():.3g} > {fdr})')
        return {'term': None, 'report': report, 'log10_p': 0.0}
    best = rows[int(order[0])]
    # a sinusoid is a shape of every single variable whose periodic candidate is significant
    periods = {r['variables'][0]: r['period'] for r, ok in zip(rows, significant)
               if ok and r['period'] is not None}
    term = _choose_shape(builder.shapes(best['variables'], periods), q0, fit.residual, table)
    report['chosen'] = {'candidate': best['candidate'], 'term': term.name,
                        'variables': list(term.variables)}
    report['decision'] = 'candidate'
    return {'term': term, 'report': report, 'log10_p': float(best['log_p'] / math.log(10))}


def _theta_jacobian(base: _Base, table: AuditTable, terms: Sequence[Term],
                    fit: _Fit) -> FloatArray:
    """Jacobian of the prediction in theta at the fit (finite differences), shape (n, p)."""
    cols = []
    for j in range(len(fit.theta)):
        step = 1e-6 * max(abs(fit.theta[j]), 1e-3)
        theta = fit.theta.copy()
        theta[j] += step
        x = _design(base, theta, table, terms)
        cols.append((x @ fit.coef - fit.prediction) / step)
    return np.column_stack(cols) if cols else np.zeros((table.n_rows, 0))


def _choose_shape(shapes: Sequence[Term], q0: FloatArray, residual: FloatArray,
                  table: AuditTable) -> Term:
    """Return the shape with the lowest BIC on the current residual (ties: fewer df)."""
    n = len(residual)
    best, best_bic = None, math.inf
    for term in shapes:
        basis = term.columns(table)
        perp = basis - q0 @ (q0.T @ basis)
        q1 = _orthonormal(perp, tol=1e-5)
        rss = float(residual @ residual) - float(np.sum((q1.T @ residual) ** 2))
        bic = n * math.log(max(rss, 1e-300) / n) + term.df * math.log(n)
        if bic < best_bic - 1e-9:
            best, best_bic = term, bic
    return best


# --------------------------------------------------------------------------- T and w estimates

def _estimate_changes(table: AuditTable, model: str, params: ParameterSet | None,
                      base: _Base, fit_before: _Fit, fit_after: _Fit,
                      terms: Sequence[Term]) -> dict | None:
    """How the (T, w) estimates per experiment change when the traced effects are included.

    Before: the estimator of :mod:`robot_wear_monitor.estimation` with the fitted model alone
    on the raw levels.  After: the model fitted with the effects, on the levels with the
    effects' contributions removed.  Needs the nominal or complete model and an ``experiment``
    column (levels of one experiment share T and w).
    """
    if model == 'speed':
        return {'applies': False, 'reason': 'the speed model has no temperature or wear'}
    if 'experiment' not in table.columns:
        return {'applies': False, 'reason': 'no experiment column to group levels'}
    try:
        from robot_wear_monitor.estimation.estimator import estimate_wear
    except ImportError as error:  # pragma: no cover - estimation is part of the package
        return {'applies': False, 'reason': f'estimation unavailable: {error}'}
    before_params = _params_with(params, base.describe(fit_before.theta, fit_before.coef))
    after_params = _params_with(params, base.describe(fit_after.theta, fit_after.coef))
    start = base.columns(fit_after.theta, table).shape[1]
    term_part = np.zeros(table.n_rows)
    for term in terms:
        cols = term.columns(table)
        term_part += cols @ fit_after.coef[start:start + cols.shape[1]]
        start += cols.shape[1]
    y = table.numeric['friction']
    experiments = _as_text(table, 'experiment')
    results = {'before': [], 'after': []}
    truth_t, truth_w = [], []
    try:
        for key in sorted(set(experiments.tolist())):
            rows = experiments == key
            if rows.sum() < 2:
                continue
            speeds = table.numeric['speed'][rows]
            load = float(np.mean(table.numeric['load'][rows]))
            for label, p, friction in (('before', before_params, y[rows]),
                                       ('after', after_params, y[rows] - term_part[rows])):
                p_exp = p.with_overrides(load_mean=load)
                estimate = estimate_wear(speeds, friction, params=p_exp)[0]
                results[label].append((estimate.temperature_degc, estimate.wear))
            truth_t.append(float(np.mean(table.numeric['temperature'][rows])))
            truth_w.append(float(np.mean(table.numeric['wear'][rows])) if 'wear' in
                           table.numeric else 0.0)
    except NotImplementedError:
        return {'applies': False, 'reason': 'the wear estimator is not implemented yet'}
    except Exception as error:  # noqa: BLE001 - report, do not fail the audit
        return {'applies': False, 'reason': f'estimation failed: {error}'.splitlines()[0]}
    if not results['before']:
        return {'applies': False, 'reason': 'no experiment with two or more levels'}
    before = np.array(results['before'])
    after = np.array(results['after'])
    t_true, w_true = np.array(truth_t), np.array(truth_w)
    return {'applies': True, 'n_experiments': len(before),
            'temperature_rms_error_before_degc': _rms(before[:, 0] - t_true),
            'temperature_rms_error_after_degc': _rms(after[:, 0] - t_true),
            'wear_rms_error_before': _rms(before[:, 1] - w_true),
            'wear_rms_error_after': _rms(after[:, 1] - w_true),
            'temperature_mean_abs_change_degc': float(np.mean(np.abs(after[:, 0] - before[:, 0]))),
            'wear_mean_abs_change': float(np.mean(np.abs(after[:, 1] - before[:, 1]))),
            'reference': 'errors are against the table\'s temperature and wear columns'}


def _rms(x: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _params_with(params: ParameterSet, description: dict) -> ParameterSet:
    values = description['all']
    current = {f: getattr(params.model, f) for f in FrictionModel.__dataclass_fields__}
    current.update({k: float(v) for k, v in values.items() if k in current})
    return params.with_overrides(model=FrictionModel(**current))


# --------------------------------------------------------------------------- raw runs and bags

def table_from_raw_runs(paths: Sequence[str | Path], *, flip_sign: bool = True,
                        config=None, model: str = 'speed') -> AuditTable:
    """Segment KUKA-style raw runs (``t_s, q_rad, dq_rad_s, tau_measured_Nm``) into levels.

    Every forward/backward pair of a run gives one level (segmentation of
    :mod:`robot_wear_monitor.segmentation`, settings of
    :func:`robot_wear_monitor.recordings.tables.kuka_segmenter_config`); link-side rad/s and N.m.

    Columns: ``speed``, ``friction`` (sign flipped when ``flip_sign``, as the data's author did,
    so that friction is positive), ``friction_std_error``, ``experiment`` (the run),
    ``joint`` and ``pose`` (text, from the run name) and the candidates ``position_centre``
    and ``position_span`` of the common window [rad], ``time`` (level centre time in the run)
    [s], ``cycle`` (index of the level in its run), ``load_torque`` = |tau+ + tau-|/2 [N.m]
    (the gravity load the level was measured under, the tau_l of eq. (5)) and
    ``run_duration`` [s].
    """
    from robot_wear_monitor.recordings.tables import kuka_segmenter_config, read_kuka_run
    from robot_wear_monitor.experiment.segmentation import segment_batch

    settings = config if config is not None else kuka_segmenter_config()
    sign = -1.0 if flip_sign else 1.0
    columns: dict[str, list] = {k: [] for k in (
        'speed', 'friction', 'friction_std_error', 'experiment', 'joint', 'pose',
        'position_centre', 'position_span', 'time', 'cycle', 'load_torque', 'run_duration')}
    rejected: list[str] = []
    for path in paths:
        run = read_kuka_run(path)
        result = segment_batch(time_s=run.t_s, position_rad=run.q_rad,
                               velocity_rad_s=run.dq_rad_s, effort=run.tau_measured_Nm,
                               config=settings)
        if not result.levels:
            rejected.append(Path(path).name)
            continue
        pose = 'new_pose' if 'new_pose' in run.test_set else 'standard'
        duration = float(run.t_s[-1] - run.t_s[0])
        for i, level in enumerate(result.levels):
            columns['speed'].append(level.speed_rad_s)
            columns['friction'].append(sign * level.friction)
            columns['friction_std_error'].append(level.friction_std_error)
            columns['experiment'].append(Path(path).name.split('.')[0])
            columns['joint'].append(f'joint{run.joint}' if run.joint else run.test_set)
            columns['pose'].append(pose)
            columns['position_centre'].append(0.5 * (level.position_min_rad
                                                     + level.position_max_rad))
            columns['position_span'].append(level.position_max_rad - level.position_min_rad)
            columns['time'].append(0.5 * (level.start_time_s + level.end_time_s))
            columns['cycle'].append(float(i))
            columns['load_torque'].append(0.5 * abs(level.tau_forward + level.tau_backward))
            columns['run_duration'].append(duration)
    if not columns['speed']:
        raise InputError(f'no friction level found in {len(paths)} raw run(s)')
    if len(set(columns['pose'])) == 1:
        del columns['pose']
    if len(set(columns['joint'])) == 1:
        del columns['joint']
    table = table_from_columns(columns, source=f'{len(paths)} raw runs', model=model)
    return table


def table_from_bag(path: str | Path, *, joint: str, topic: str = '/joint_states',
                   config=None, model: str = 'speed') -> AuditTable:
    """Segment the joint states of a recorded bag into friction levels (one per pass pair).

    Uses :func:`robot_wear_monitor.recordings.bags.read_joint_samples` and the segmenter;
    ``config`` is a :class:`~robot_wear_monitor.experiment.segmentation.SegmenterConfig`
    (default: link side, scale 1).
    """
    try:
        from robot_wear_monitor.recordings.bags import read_joint_samples
    except ImportError as error:
        raise InputError(f'{path}: reading bags needs robot_wear_monitor.recordings.bags '
                         f'({error})') from None
    from robot_wear_monitor.experiment.segmentation import SegmenterConfig, segment_batch

    samples = read_joint_samples(path, joint=joint, topic=topic)
    time_s, position, velocity, effort = (_sample_field(samples, name) for name in (
        'time_s', 'position_rad', 'velocity_rad_s', 'effort'))
    settings = config if config is not None else SegmenterConfig(joint=joint)
    result = segment_batch(time_s=time_s, position_rad=position, velocity_rad_s=velocity,
                           effort=effort, config=settings)
    if not result.levels:
        raise InputError(f'{path}: no friction level found for joint {joint!r} on {topic}')
    return table_from_levels(result.levels, source=str(path), model=model)


def _sample_field(samples, name: str) -> FloatArray:
    """Return one sample array from the bag reader's result (attribute, key or position)."""
    aliases = {'time_s': ('time_s', 't_s', 'time'),
               'position_rad': ('position_rad', 'position', 'q_rad'),
               'velocity_rad_s': ('velocity_rad_s', 'velocity', 'dq_rad_s'),
               'effort': ('effort', 'effort_Nm', 'tau')}
    for alias in aliases[name]:
        if hasattr(samples, alias):
            return np.asarray(getattr(samples, alias), dtype=float)
        if isinstance(samples, Mapping) and alias in samples:
            return np.asarray(samples[alias], dtype=float)
    index = ('time_s', 'position_rad', 'velocity_rad_s', 'effort').index(name)
    return np.asarray(samples[index], dtype=float)


def is_bag(path: str | Path) -> bool:
    """Return True for a bag: a folder with ``metadata.yaml``, or a ``.mcap`` / ``.db3`` file."""
    file = Path(path)
    return (file.is_dir() and (file / 'metadata.yaml').exists()) or \
        file.suffix in ('.mcap', '.db3')


def load_audit_data(path: str | Path, *, model: str = 'speed', joint: str | None = None,
                    topic: str = '/joint_states', flip_sign: bool = True,
                    gear_ratio: float = 1.0, torque_scale: float = 1.0) -> AuditTable:
    """Read DATA of ``audit``: a level CSV, a raw run, a folder of raw runs, or a bag.

    * a CSV (or .csv.gz) with ``speed`` and ``friction`` columns: a table of levels;
    * a CSV with ``t_s, q_rad, dq_rad_s, tau_measured_Nm``: one raw run, segmented;
    * a folder holding ``*.csv.gz`` raw runs (or a ``raw_runs`` subfolder): all runs;
    * a bag (folder with ``metadata.yaml``, or a ``.mcap`` / ``.db3`` file): ``joint`` needed.
    """
    file = Path(path)
    if not file.exists():
        raise InputError(f'{file}: no such file or folder')
    if is_bag(file):
        if not joint:
            raise InputError(f'{file}: a bag needs --joint NAME (the joint to segment)')
        from robot_wear_monitor.experiment.segmentation import SegmenterConfig
        config = SegmenterConfig(joint=joint, gear_ratio=gear_ratio, torque_scale=torque_scale)
        return table_from_bag(file, joint=joint, topic=topic, model=model, config=config)
    if file.is_dir():
        from robot_wear_monitor.recordings.tables import list_kuka_runs
        runs = list_kuka_runs(file)
        if not runs:
            raise InputError(f'{file}: no raw runs (*.csv.gz) and no bag metadata.yaml here')
        return table_from_raw_runs(runs, flip_sign=flip_sign, model=model)
    if _is_raw_run(file):
        return table_from_raw_runs([file], flip_sign=flip_sign, model=model)
    return read_level_table(file, model=model)


def _is_raw_run(file: Path) -> bool:
    opener = gzip.open if file.suffix == '.gz' else open
    try:
        with opener(file, 'rt', encoding='utf-8') as stream:
            header = {h.strip() for h in stream.readline().split(',')}
    except (OSError, UnicodeDecodeError):
        return False
    return {'t_s', 'q_rad', 'dq_rad_s', 'tau_measured_Nm'} <= header
