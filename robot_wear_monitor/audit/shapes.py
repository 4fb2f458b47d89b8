"""
Naming the shape: the simplest term that explains the structure a candidate family found.

For the variables of the chosen family the audit offers named physical shapes: a linear
(Coulomb-like) offset, an offset per category, a sinusoid (ripple), a Stribeck amplitude or a
viscous slope that varies with the variable, a bilinear term, a slope per category, and the
smooth (spline, tensor) terms; the one with the lowest BIC on the current residual (the model's
own columns projected out) is named.  Each term is a tensor product of the factors of
:mod:`robot_wear_monitor.model.extensions`, so it is written into a parameter set as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Mapping, Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.candidates import factor_columns, speed_factor, Variable
from robot_wear_monitor.audit.fitting import AuditTable, Base, orthonormal
from robot_wear_monitor.model.extensions import AddedTerm, Factor


@dataclass(frozen=True)
class Term:
    """
    A term the audit adds: named shape, variables and its factors (fixed basis columns).

    The amplitudes are re-identified with the base model; ``info`` holds shape constants
    (period, Stribeck speed) for the report.
    """

    name: str
    shape: str
    variables: tuple[str, ...]
    factors: tuple[Factor, ...]
    drop_first: bool = False
    info: Mapping[str, float] = field(default_factory=dict)

    def columns(self, table: AuditTable) -> FloatArray:
        """Return the term's basis on a table, shape (n, df)."""
        return factor_columns(table, self.factors, self.drop_first)

    @property
    def df(self) -> int:
        """Return the number of amplitudes (plus 1 for a scanned period or Stribeck speed)."""
        size = int(np.prod([f.size for f in self.factors])) - (1 if self.drop_first else 0)
        return size + (1 if self.shape in ('periodic', 'Stribeck interaction') else 0)

    def added(self, coefficients: Sequence[float] | np.ndarray) -> AddedTerm:
        """Return the term with its identified amplitudes, as the model evaluates it."""
        return AddedTerm(self.name, self.factors, tuple(float(c) for c in coefficients),
                         self.drop_first)


def base_alpha(base: Base, theta: FloatArray) -> float:
    """Return the Stribeck exponent of the fitted base model (median over groups)."""
    if base.name == 'speed':
        return float(np.median(theta[1::2]))
    return float(theta[4])


class ShapeBuilder:
    """Builds the named shapes of an effect in given variables."""

    def __init__(self, table: AuditTable, variables: Sequence[Variable],
                 group_variable: Variable | None, base: Base, theta: FloatArray):
        """Prepare the shapes of ``variables`` for the model ``base`` fitted at ``theta``."""
        self.table = table
        self.variables = {v.name: v for v in variables}
        self.group_variable = group_variable
        self.alpha = base_alpha(base, theta)
        log_v = np.log(table.numeric['speed'])
        self.speed_varies = float(log_v.max() - log_v.min()) > 1e-6

    def shapes(self, variables: tuple[str, ...], periods: Mapping[str, float]) -> list[Term]:
        """Return the shapes to choose from for an effect in ``variables`` (and subsets)."""
        terms: list[Term] = []
        singles = [n for n in variables if n in self.variables]
        for name in singles:
            terms += self._single_shapes(name, periods.get(name))
        if 'speed' in variables and self.speed_varies:
            for name in singles:
                if name != 'speed':
                    terms += self._speed_shapes(name)
        pair = [n for n in variables if n != 'speed']
        if len(pair) == 2:
            a = self.variables.get(pair[0]) or self.group_variable
            b = self.variables.get(pair[1]) or self.group_variable
            if a is not None and b is not None:
                terms += self._pair_shapes(a, b)
        return terms

    def _single_shapes(self, name: str, period: float | None) -> list[Term]:
        var = self.variables[name]
        factors, drop = var.linear()
        if var.kind == 'categorical':
            return [Term(f'offset per {name} (Coulomb-like)', 'offset per category', (name,),
                         factors, drop)]
        out = [Term(f'linear in {name} (Coulomb-like offset)', 'linear', (name,), factors)]
        smooth, drop = var.smooth()
        if int(np.prod([f.size for f in smooth])) > 1:
            out.append(Term(f'smooth in {name}', 'smooth', (name,), smooth, drop))
        if period is not None and 0 < period <= 0.5 * (var.hi - var.lo):  # 2 periods seen
            out.append(Term(f'periodic in {name} (period {period:.4g}, ripple)', 'periodic',
                            (name,), (Factor(name, 'periodic', period=period),),
                            info={'period': period}))
        return out

    def _speed_shapes(self, name: str) -> list[Term]:
        var = self.variables[name]
        x = var.indicators()
        v = self.table.numeric['speed']
        out = []
        for phi in np.exp(np.linspace(math.log(v.min() / 5), math.log(v.max()), 24)):
            out.append(Term(f'Stribeck amplitude varies with {name} (phi_s {phi:.3g} rad/s)',
                            'Stribeck interaction', ('speed', name),
                            (x, Factor('speed', 'stribeck', stribeck_speed=float(phi),
                                       alpha=self.alpha)),
                            info={'stribeck_speed_rad_s': float(phi), 'alpha': self.alpha}))
        out.append(Term(f'viscous slope varies with {name}', 'viscous interaction',
                        ('speed', name), (x, Factor('speed', 'identity'))))
        out.append(Term(f'smooth speed x {name} interaction', 'smooth interaction',
                        ('speed', name), (x, speed_factor(self.table))))
        return out

    @staticmethod
    def _pair_shapes(a: Variable, b: Variable) -> list[Term]:
        out = []
        if a.kind == 'continuous' and b.kind == 'continuous':
            linear = [Factor(v.name, 'polynomial', lower=v.lo, upper=v.hi, degree=1,
                             constant=True) for v in (a, b)]
            out.append(Term(f'bilinear {a.name} x {b.name}', 'bilinear', (a.name, b.name),
                            tuple(linear), True))
        else:
            cat, cont = (a, b) if a.kind == 'categorical' else (b, a)
            if cont.kind == 'continuous':
                out.append(Term(f'linear in {cont.name}, slope per {cat.name}',
                                'slope per category', (cont.name, cat.name),
                                (cat.small(), Factor(cont.name, 'polynomial', lower=cont.lo,
                                                     upper=cont.hi, degree=1, constant=True)),
                                True))
        out.append(Term(f'smooth {a.name} x {b.name} interaction', 'smooth tensor',
                        (a.name, b.name), (a.small(), b.small()), True))
        return out


def choose_shape(shapes: Sequence[Term], q0: FloatArray, residual: FloatArray,
                 table: AuditTable) -> Term | None:
    """
    Return the shape with the lowest BIC on the current residual (ties: fewer df).

    None when no shape adds a column outside the span of ``q0``.
    """
    n = len(residual)
    best, best_bic = None, math.inf
    for term in shapes:
        basis = term.columns(table)
        perp = basis - q0 @ (q0.T @ basis)
        q1 = orthonormal(perp, tol=1e-5)
        if q1.shape[1] == 0:
            continue
        rss = float(residual @ residual) - float(np.sum((q1.T @ residual) ** 2))
        bic = n * math.log(max(rss, 1e-300) / n) + term.df * math.log(n)
        if bic < best_bic - 1e-9:
            best, best_bic = term, bic
    return best
