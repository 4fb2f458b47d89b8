"""
Candidate variables and the bases the audit tests them with.

Every column is a suspect (issue 10): the undeclared columns, the model's own variables
(speed, temperature, load, wear: tested in the shapes the model lacks, the model's fitted terms
being projected out by the tests) and the order of the experiments (drift, ageing).  The
``experiment`` column stays the key of the cross-validation folds and is a candidate as well:
numeric experiment labels are used as they are, numbered text labels (``exp07``) by their
number (``experiment_order``).

Each variable is tested alone (a smooth spline, a sinusoid), with speed (its linear effect times
a cubic in log speed) and in pairs (a tensor product of quadratics).  All bases are tensor
products of the one-dimensional factors of :mod:`robot_wear_monitor.model.extensions`, so that
what the audit adds is what the model evaluates.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import re
from typing import Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.model.extensions import Factor, tensor_basis


#: Columns that are never candidates (the response and its standard error).
NOT_CANDIDATES = ('friction', 'friction_std_error')
#: The derived candidate of experiment order when the experiment labels are text.
ORDER_COLUMN = 'experiment_order'
#: Integer columns with at most this many values (and 4 rows per value) are categories.
CATEGORICAL_MAX_LEVELS = 8
#: The model's own online variables: tested in shapes the model lacks.
MODEL_VARIABLES = ('speed', 'temperature', 'load', 'wear')
#: The window columns of a level table (``segment``'s) and the candidates derived from them.
WINDOW_COLUMNS = ('position_min_rad', 'position_max_rad')
POSITION_COLUMNS = ('position_centre', 'position_span')
#: Derived group columns that are no candidates (the per-direction model's groups).
DERIVED_GROUPS = ('group_direction',)


def table_values(table: AuditTable) -> dict:
    """Return column -> values (numbers or text) for evaluating factors on a table."""
    return {**table.numeric, **table.text}


def factor_columns(table: AuditTable, factors: Sequence[Factor],
                   drop_first: bool = False) -> FloatArray:
    """Evaluate a tensor product of factors on a table, shape (n, columns)."""
    return tensor_basis(tuple(factors), table_values(table), drop_first=drop_first)[0]


@dataclass(frozen=True)
class Variable:
    """A candidate explanatory variable: a numeric column (range, knots) or categories."""

    name: str
    kind: str  # 'continuous' | 'categorical'
    lo: float = 0.0
    hi: float = 1.0
    knots: tuple = ()
    levels: tuple = ()
    n_unique: int = 0

    def linear(self) -> tuple[tuple[Factor, ...], bool]:
        """Return the variable itself (centred), or its categories minus the first."""
        if self.kind == 'categorical':
            return (Factor(self.name, 'categories', levels=self.levels),), True
        return (Factor(self.name, 'linear', centre=0.5 * (self.lo + self.hi)),), False

    def indicators(self) -> Factor:
        """Return the linear factor, or all indicators for categories (for interactions)."""
        if self.kind == 'categorical':
            return Factor(self.name, 'categories', levels=self.levels)
        return Factor(self.name, 'linear', centre=0.5 * (self.lo + self.hi))

    def smooth(self) -> tuple[tuple[Factor, ...], bool]:
        """
        Return a natural cubic spline in the variable (linear beyond the outer knots).

        Knots at quantiles of the audited table; with fewer than 3, a polynomial of degree up
        to 3.  Speed: the spline is in log speed (the levels are spread logarithmically).
        Categories: the indicators minus the first.
        """
        if self.kind == 'categorical':
            return self.linear()
        if self.name == 'speed' and len(self.knots) >= 3:
            return (Factor('speed', 'log_spline', log_lower=math.log(self.lo),
                           log_upper=math.log(self.hi), knots=self.knots),), False
        if len(self.knots) >= 3:
            return (Factor(self.name, 'spline', lower=self.lo, upper=self.hi,
                           knots=self.knots),), False
        degree = min(3, self.n_unique - 1)
        return (Factor(self.name, 'polynomial', lower=self.lo, upper=self.hi, degree=degree,
                       constant=False),), False

    def small(self) -> Factor:
        """Return the basis for tensor products, constant included: [1, z, z^2] or indicators."""
        if self.kind == 'categorical':
            return Factor(self.name, 'categories', levels=self.levels)
        return Factor(self.name, 'polynomial', lower=self.lo, upper=self.hi,
                      degree=min(2, self.n_unique - 1), constant=True)


def make_variable(table: AuditTable, name: str, *, ordered: bool = False) -> Variable | None:
    """
    Describe a candidate column; None when it is constant.

    ``ordered`` keeps an integer column continuous (experiment order) whatever its number of
    values.
    """
    if name in table.text:
        levels = tuple(sorted(set(table.text[name].tolist())))
        return Variable(name, 'categorical', levels=levels) if len(levels) > 1 else None
    x = table.numeric[name]
    unique = np.unique(x)
    if len(unique) < 2 or (ordered and len(unique) < 3):
        return None
    integer = np.all(unique == np.round(unique))
    if (not ordered and integer and len(unique) > 2
            and len(unique) <= min(CATEGORICAL_MAX_LEVELS, len(x) // 4)):
        return Variable(name, 'categorical', levels=tuple(f'{u:g}' for u in unique))
    lo, hi = float(unique[0]), float(unique[-1])
    if name == 'speed' and lo > 0:
        z = np.log(x / lo) / math.log(hi / lo)
        n_knots = int(min(6, len(unique) // 2))
    else:
        z = (x - lo) / (hi - lo)
        n_knots = int(min(6, len(unique) // 3))
    quantiles = np.quantile(z, np.linspace(0.05, 0.95, max(n_knots, 1)))
    knots = tuple(float(k) for k in np.unique(quantiles)) if n_knots >= 3 else ()
    return Variable(name, 'continuous', lo, hi, knots, n_unique=len(unique))


def with_experiment_order(table: AuditTable) -> AuditTable:
    """
    Add ``experiment_order`` for text labels that number a series (``exp01``, ``exp02``).

    Labels that are one common prefix followed by a number are ordered by that number; other
    text labels (run names such as ``joint6_vel_p5``) carry no order and get no column.  Numeric
    labels are an order already; the table is returned unchanged then, and when there is no
    experiment column.
    """
    if 'experiment' not in table.text:
        return table
    labels = table.text['experiment']
    matches = {k: re.fullmatch(r'(.*?)(\d+)', k) for k in set(labels.tolist())}
    prefixes = {m.group(1) if m else None for m in matches.values()}
    if len(prefixes) != 1 or None in prefixes:
        return table
    numeric = dict(table.numeric)
    numeric[ORDER_COLUMN] = np.array([float(matches[v].group(2))  # type: ignore[union-attr]
                                      for v in labels])  # (None excluded above)
    return AuditTable(numeric, dict(table.text), table.source, table.levels)


def with_position_window(table: AuditTable) -> AuditTable:
    """
    Add ``position_centre`` and ``position_span`` [rad] of a level table's window columns.

    A level table with ``position_min_rad`` and ``position_max_rad`` (as ``segment`` writes it)
    carries the positions its levels were averaged over: their centre and width are the
    position candidates, as for raw runs (the two ends are then no candidates of their own).
    Unchanged without both columns or when the table has a ``position_centre`` already.
    """
    if not all(c in table.numeric for c in WINDOW_COLUMNS) or 'position_centre' in table.columns:
        return table
    low, high = (table.numeric[c] for c in WINDOW_COLUMNS)
    numeric = {**table.numeric, 'position_centre': 0.5 * (low + high),
               'position_span': high - low}
    return AuditTable(numeric, dict(table.text), table.source)


def candidate_columns(table: AuditTable, *, model: str, group: str | None = None) -> list[str]:
    """
    Return the candidate columns: every column but friction, its error and the group.

    The model's own variables come first (``speed`` only when it varies); the experiment
    column is a candidate when its labels are numbers, else its order ``experiment_order``.
    A window's ends are no candidates beside its centre and span (:func:`with_position_window`).
    """
    del model  # every variable is a suspect, the model's own included
    skip = set(NOT_CANDIDATES) | set(DERIVED_GROUPS) | ({group} if group else set())
    if all(c in table.numeric for c in POSITION_COLUMNS):
        skip.update(WINDOW_COLUMNS)  # their centre and span are the candidates
    if 'experiment' in table.text:
        skip.add('experiment')
    names = [c for c in table.columns if c not in skip]
    return sorted(names, key=lambda c: (c not in MODEL_VARIABLES, names.index(c)))


def make_variables(table: AuditTable, names: Sequence[str]) -> list[Variable]:
    """Describe the candidate columns (constant ones are dropped)."""
    out = []
    for name in names:
        ordered = name in ('experiment', ORDER_COLUMN)
        if ordered and name in table.text:
            continue
        variable = make_variable(table, name, ordered=ordered)
        if variable is not None:
            out.append(variable)
    return out


@dataclass(frozen=True)
class Family:
    """A candidate family: a key, its variables and its basis (factors), or a periodic scan."""

    key: str
    variables: tuple[str, ...]
    factors: tuple[Factor, ...] = ()
    drop_first: bool = False
    periodic: bool = False

    def columns(self, table: AuditTable) -> FloatArray:
        """Return the family's basis on a table, shape (n, columns)."""
        return factor_columns(table, self.factors, self.drop_first)


def speed_factor(table: AuditTable) -> Factor:
    """Cubic polynomial in log speed over the table's speed range (constant included)."""
    log_v = np.log(table.numeric['speed'])
    lo, hi = float(log_v.min()), float(log_v.max())
    return Factor('speed', 'log_polynomial', log_lower=lo, log_upper=max(hi, lo + 1e-12),
                  degree=3)


def families(table: AuditTable, variables: Sequence[Variable],
             group_variable: Variable | None) -> list[Family]:
    """Return the candidate families: alone, periodic, with speed, and in pairs."""
    log_v = np.log(table.numeric['speed'])
    speed_varies = float(log_v.max() - log_v.min()) > 1e-6
    out = []
    singles = [v for v in variables if v.name != 'speed']
    for var in variables:
        factors, drop = var.smooth()
        out.append(Family(var.name, (var.name,), factors, drop))
        if var.kind == 'continuous' and var.n_unique >= 8 and var.name != 'speed':
            out.append(Family(f'periodic {var.name}', (var.name,), periodic=True))
    if speed_varies:
        for var in singles:
            out.append(Family(f'speed x {var.name}', ('speed', var.name),
                              (var.indicators(), speed_factor(table))))
    pair_vars = list(singles) + ([group_variable] if group_variable is not None else [])
    for i, a in enumerate(pair_vars):
        for b in pair_vars[i + 1:]:
            if a.kind == 'categorical' and b.kind == 'categorical' and (
                    len(a.levels) * len(b.levels) > 4 * CATEGORICAL_MAX_LEVELS):
                continue
            out.append(Family(f'{a.name} x {b.name}', (a.name, b.name),
                              (a.small(), b.small()), True))
    return out


def periodic_frequencies(variable: Variable) -> FloatArray:
    """Frequencies [1/unit] scanned for a sinusoid: 1 to k_max periods over the range."""
    k_max = int(max(2, min(40, variable.n_unique // 3)))
    return np.arange(1.0, k_max + 0.01, 0.25) / (variable.hi - variable.lo)
