"""
Terms added to the friction model (8): effects the audit found, with their gradients.

An added term is a tensor product of one-dimensional bases ("factors"), each in one variable,
times fixed coefficients::

    term(x) = sum_j c_j prod_i B_i(x_{v_i})[j_i]

The bases are the ones the audit names its shapes with: a linear (centred) variable, a
polynomial or natural cubic spline of the variable scaled to its audited range, a sinusoid of a
period, a Stribeck decay exp(-|x/phi|^alpha), a polynomial or natural spline in log speed, the
variable itself or the indicators of categories.  A term may drop the first column of its tensor
product (the constant that the model already has).

Variables: ``speed`` [rad/s, motor side], ``temperature`` [degC], ``load`` (normalised) and
``wear`` [-] are what the estimator evaluates; every other variable (position, experiment order,
a pose name) is not measured online and is evaluated at the default stored with the terms
(:attr:`ModelExtension.defaults`).  The model functions of :mod:`robot_wear_monitor.model.friction`
split the terms as the estimator needs them: terms without wear add to the nominal friction
(5), terms in wear (and speed or offline variables) add to the wear profile (7); a term in wear
together with temperature or load is rejected (the estimator's likelihood adds the two parts).
The load sensitivity m(v) of eq. (14) gains the load derivative of the added terms evaluated at
the defaults of ``load`` and ``temperature`` (exact for terms linear in load).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray


#: The variables the wear monitor measures or estimates online.
ONLINE_VARIABLES = ('speed', 'temperature', 'load', 'wear')
#: Basis kinds of a factor and the keys each needs in the YAML section.
BASES = {
    'linear': ('centre',),
    'identity': (),
    'polynomial': ('lower', 'upper', 'degree', 'constant'),
    'spline': ('lower', 'upper', 'knots'),
    'periodic': ('period',),
    'stribeck': ('stribeck_speed', 'alpha'),
    'log_polynomial': ('log_lower', 'log_upper', 'degree'),
    'log_spline': ('log_lower', 'log_upper', 'knots'),
    'categories': ('levels',),
}


class ExtensionError(ValueError):
    """An added-term description is invalid; the message names the field."""


def _relu(x: FloatArray) -> FloatArray:
    return np.maximum(x, 0.0)


@dataclass(frozen=True)
class Factor:
    """
    A one-dimensional basis in one variable (see :data:`BASES` for the kinds).

    :ivar variable: the variable (table column) it is evaluated on.
    :ivar basis: 'linear', 'identity', 'polynomial', 'spline', 'periodic', 'stribeck',
        'log_polynomial', 'log_spline' or 'categories'.
    :ivar centre: linear: the value subtracted from the variable (its unit).
    :ivar lower: polynomial/spline: the variable's value mapped to 0 (its unit).
    :ivar upper: polynomial/spline: the variable's value mapped to 1 (its unit).
    :ivar degree: polynomial/log_polynomial: the highest power.
    :ivar constant: polynomial: include the power 0.
    :ivar knots: spline: knots on the scaled variable (at least 3 for a spline).
    :ivar period: periodic: the period (the variable's unit).
    :ivar stribeck_speed: stribeck: phi [the variable's unit, rad/s for speed].
    :ivar alpha: stribeck: the exponent.
    :ivar log_lower: log_polynomial/log_spline: log of the value mapped to -0.5 (polynomial) or
        0 (spline, whose knots are on that scale).
    :ivar log_upper: log_polynomial/log_spline: log of the value mapped to +0.5 or 1.
    :ivar levels: categories: the category names (one indicator column each).

    """

    variable: str
    basis: str
    centre: float = 0.0
    lower: float = 0.0
    upper: float = 1.0
    degree: int = 1
    constant: bool = False
    knots: tuple[float, ...] = ()
    period: float = 1.0
    stribeck_speed: float = 1.0
    alpha: float = 1.0
    log_lower: float = 0.0
    log_upper: float = 1.0
    levels: tuple[str, ...] = ()

    @property
    def size(self) -> int:
        """Return the number of columns of the basis."""
        if self.basis in ('linear', 'identity', 'stribeck'):
            return 1
        if self.basis == 'polynomial':
            return self.degree + (1 if self.constant else 0)
        if self.basis in ('spline', 'log_spline'):
            return len(self.knots) - 1
        if self.basis == 'periodic':
            return 2
        if self.basis == 'log_polynomial':
            return self.degree + 1
        return len(self.levels)

    def evaluate(self, x: Any) -> tuple[FloatArray, FloatArray]:
        """
        Return the basis and its derivative in the variable, both of shape x.shape + (size,).

        Categories take text (or numbers, written as ``f'{x:g}'``); their derivative is 0.
        """
        if self.basis == 'categories':
            text = _as_text(x)
            values = np.stack([(text == level).astype(float) for level in self.levels], -1)
            return values, np.zeros_like(values)
        x = np.asarray(x, dtype=float)
        if self.basis == 'linear':
            return (x - self.centre)[..., None], np.ones(x.shape + (1,))
        if self.basis == 'identity':
            return x[..., None], np.ones(x.shape + (1,))
        if self.basis in ('polynomial', 'spline'):
            span = self.upper - self.lower
            raw = (x - self.lower) / span
            z = np.clip(raw, -0.5, 1.5)
            dz = np.where((raw > -0.5) & (raw < 1.5), 1.0 / span, 0.0)
            if self.basis == 'polynomial':
                return _powers(z - 0.5, dz, 0 if self.constant else 1, self.degree)
            return _natural_spline(z, dz, self.knots)
        if self.basis == 'periodic':
            phase = 2.0 * math.pi * x / self.period
            rate = 2.0 * math.pi / self.period
            return (np.stack([np.sin(phase), np.cos(phase)], -1),
                    np.stack([rate * np.cos(phase), -rate * np.sin(phase)], -1))
        if self.basis == 'stribeck':
            with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
                power = np.abs(x / self.stribeck_speed) ** self.alpha
                decay = np.exp(-power)
                slope = np.where(x != 0, -self.alpha * power / x * decay, 0.0)
            return np.nan_to_num(decay)[..., None], np.nan_to_num(slope)[..., None]
        # log_polynomial, log_spline: in log x scaled by the range [log_lower, log_upper]
        span = self.log_upper - self.log_lower
        with np.errstate(divide='ignore', invalid='ignore'):
            s = (np.log(x) - self.log_lower) / span
            ds = 1.0 / (x * span)
        if self.basis == 'log_spline':
            return _natural_spline(s, ds, self.knots)
        return _powers(s - 0.5, ds, 0, self.degree)


def _powers(s: FloatArray, ds: FloatArray, first: int, degree: int) -> tuple:
    values = np.stack([s ** d for d in range(first, degree + 1)], -1)
    slopes = np.stack([d * s ** max(d - 1, 0) * ds if d else np.zeros_like(s)
                       for d in range(first, degree + 1)], -1)
    return values, slopes


def _natural_spline(z: FloatArray, dz: FloatArray, knots: tuple[float, ...]) -> tuple:
    """Restricted cubic spline in z (linear beyond the outer knots) and its derivative."""
    t = knots
    last, before = t[-1], t[-2]
    values = [z - 0.5]
    slopes = [dz]
    for tj in t[:-2]:
        a, b = (last - tj) / (last - before), (before - tj) / (last - before)
        values.append(_relu(z - tj) ** 3 - a * _relu(z - before) ** 3 + b * _relu(z - last) ** 3)
        slopes.append(3.0 * dz * (_relu(z - tj) ** 2 - a * _relu(z - before) ** 2
                                  + b * _relu(z - last) ** 2))
    return np.stack(values, -1), np.stack(slopes, -1)


def _as_text(x: Any) -> NDArray[np.str_]:
    array = np.asarray(x)
    if array.dtype.kind in 'fiub':
        return np.vectorize(lambda v: f'{v:g}', otypes=[str])(array.astype(float))
    return array.astype(str)


def tensor_basis(factors: tuple[Factor, ...], values: Mapping[str, Any], *,
                 drop_first: bool = False,
                 wrt: tuple[str, ...] = ()) -> tuple[FloatArray, dict[str, FloatArray]]:
    """
    Return the tensor product of the factors' bases and its derivatives in ``wrt``.

    :param factors: the factors; their columns are combined in row-major order (the last
        factor's index runs fastest).
    :param values: variable -> values (arrays broadcast together).
    :param drop_first: drop the first column of the product (the constant when every factor
        has one).
    :param wrt: the variables to differentiate in.

    :return: (basis of shape (..., k), {variable: derivative of the basis, same shape}).

    """
    evaluated = [f.evaluate(values[f.variable]) for f in factors]
    shape = np.broadcast_shapes(*(b.shape[:-1] for b, _ in evaluated))

    def product(blocks: list[FloatArray]) -> FloatArray:
        out = np.broadcast_to(blocks[0], shape + blocks[0].shape[-1:])
        for block in blocks[1:]:
            out = (out[..., :, None] * block[..., None, :]).reshape(
                shape + (out.shape[-1] * block.shape[-1],))
        return out[..., 1:] if drop_first else out

    basis = product([b for b, _ in evaluated])
    derivatives = {}
    for name in wrt:
        total = np.zeros_like(basis)
        for i, factor in enumerate(factors):
            if factor.variable == name:
                total = total + product([d if j == i else b
                                         for j, (b, d) in enumerate(evaluated)])
        derivatives[name] = total
    return basis, derivatives


@dataclass(frozen=True)
class AddedTerm:
    """
    A term added to the friction model: a tensor product of factors times coefficients.

    :ivar name: what the audit named it (shape and variables).
    :ivar factors: the one-dimensional bases.
    :ivar coefficients: one per column of the product, in friction units.
    :ivar drop_first: the first column of the product is dropped.

    """

    name: str
    factors: tuple[Factor, ...]
    coefficients: tuple[float, ...]
    drop_first: bool = False

    @property
    def variables(self) -> tuple[str, ...]:
        """Return the variables of the term, in the order of first appearance."""
        return tuple(dict.fromkeys(f.variable for f in self.factors))

    @property
    def size(self) -> int:
        """Return the number of columns (= coefficients) of the term."""
        return int(np.prod([f.size for f in self.factors])) - (1 if self.drop_first else 0)

    def evaluate(self, values: Mapping[str, Any], wrt: tuple[str, ...] = ()) -> tuple:
        """Return the term's value and {variable: derivative} for the variables ``wrt``."""
        basis, derivatives = tensor_basis(self.factors, values, drop_first=self.drop_first,
                                          wrt=wrt)
        c = np.asarray(self.coefficients, dtype=float)
        return basis @ c, {k: d @ c for k, d in derivatives.items()}


@dataclass(frozen=True)
class ModelExtension:
    """
    The added terms of a parameter set and the defaults of the offline variables.

    :ivar terms: the added terms.
    :ivar defaults: (variable, value) pairs: the value at which a variable the service does not
        measure online is evaluated (a number, or a category name); ``load`` and
        ``temperature`` defaults set where m(v) of eq. (14) is linearised.

    """

    terms: tuple[AddedTerm, ...]
    defaults: tuple[tuple[str, Any], ...] = ()

    @property
    def offline_variables(self) -> tuple[str, ...]:
        """Variables of the terms that are not measured online (evaluated at their default)."""
        names = dict.fromkeys(v for t in self.terms for v in t.variables)
        return tuple(v for v in names if v not in ONLINE_VARIABLES)

    def default(self, name: str) -> Any:
        """Return the stored default of a variable (KeyError when there is none)."""
        return dict(self.defaults)[name]

    def _values(self, online: Mapping[str, Any]) -> dict[str, Any]:
        values = dict(self.defaults)
        values.update(online)
        return values

    def _sum(self, terms, online: Mapping[str, Any], wrt: tuple[str, ...]) -> tuple:
        values = self._values(online)
        shape = np.broadcast_shapes(*(np.shape(v) for v in online.values()))
        total = np.zeros(shape)
        derivatives = {k: np.zeros(shape) for k in wrt}
        for term in terms:
            value, d = term.evaluate(values, wrt)
            total = total + value
            for k in wrt:
                derivatives[k] = derivatives[k] + d[k]
        return total, derivatives

    def nominal_terms(self) -> tuple[AddedTerm, ...]:
        """Return the terms without wear (they add to the nominal friction (5))."""
        return tuple(t for t in self.terms if 'wear' not in t.variables)

    def wear_terms(self) -> tuple[AddedTerm, ...]:
        """Return the terms in wear (they add to the wear profile (7))."""
        return tuple(t for t in self.terms if 'wear' in t.variables)

    def nominal(self, speed: ArrayLike, load: ArrayLike, temperature: ArrayLike) -> FloatArray:
        """Return the sum of the terms without wear at (v, load, T)."""
        online = {'speed': speed, 'load': load, 'temperature': temperature}
        return self._sum(self.nominal_terms(), online, ())[0]

    def wear(self, speed: ArrayLike, wear: ArrayLike) -> FloatArray:
        """Return the sum of the terms in wear at (v, w)."""
        return self._sum(self.wear_terms(), {'speed': speed, 'wear': wear}, ())[0]

    def with_gradients(self, speed: ArrayLike, load: ArrayLike, temperature: ArrayLike,
                       wear: ArrayLike) -> tuple[FloatArray, dict[str, FloatArray]]:
        """Return the sum of all terms and its derivatives in temperature, wear and load."""
        online = {'speed': speed, 'load': load, 'temperature': temperature, 'wear': wear}
        return self._sum(self.terms, online, ('temperature', 'wear', 'load'))

    def load_sensitivity(self, speed: ArrayLike) -> FloatArray:
        """Return d(terms)/d load at the defaults of load and temperature (0 without load)."""
        terms = tuple(t for t in self.nominal_terms() if 'load' in t.variables)
        v = np.asarray(speed, dtype=float)
        if not terms:
            return np.zeros(v.shape)
        values = dict(self.defaults)
        online = {'speed': v, 'load': values.get('load', 0.0),
                  'temperature': values.get('temperature', 0.0)}
        return self._sum(terms, online, ('load',))[1]['load']


# --------------------------------------------------------------------------- YAML section

def _where(path: str, key: str) -> str:
    return f'{path}.{key}'


def _real(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ExtensionError(f'{where}: expected a number, got {type(value).__name__} '
                             f'{value!r}')
    number = float(value)
    if not math.isfinite(number):
        raise ExtensionError(f'{where}: must be finite, got {number}')
    return number


def _factor_from_mapping(item: Any, where: str) -> Factor:
    if not isinstance(item, Mapping):
        raise ExtensionError(f'{where}: expected a mapping, got {type(item).__name__}')
    variable = item.get('variable')
    if not isinstance(variable, str) or not variable.strip():
        raise ExtensionError(f'{_where(where, "variable")}: expected a column name, got '
                             f'{variable!r}')
    basis = item.get('basis')
    if basis not in BASES:
        raise ExtensionError(f'{_where(where, "basis")}: expected one of '
                             f'{", ".join(sorted(BASES))}, got {basis!r}')
    allowed = {'variable', 'basis', *BASES[basis]}
    extra = sorted(set(item) - allowed)
    if extra:
        raise ExtensionError(f'{_where(where, extra[0])}: unknown key for basis {basis!r} '
                             f'(expected {", ".join(BASES[basis]) or "no other key"})')
    missing = [k for k in BASES[basis] if k not in item]
    if missing:
        raise ExtensionError(f'{_where(where, missing[0])}: missing (basis {basis!r})')
    kwargs: dict[str, Any] = {}
    for key in BASES[basis]:
        value, at = item[key], _where(where, key)
        if key == 'degree':
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 5:
                raise ExtensionError(f'{at}: expected an integer 1 to 5, got {value!r}')
            kwargs[key] = value
        elif key == 'constant':
            if not isinstance(value, bool):
                raise ExtensionError(f'{at}: expected true or false, got {value!r}')
            kwargs[key] = value
        elif key == 'knots':
            if not isinstance(value, (list, tuple)) or len(value) < 3:
                raise ExtensionError(f'{at}: expected a list of at least 3 numbers')
            knots = tuple(_real(k, f'{at}[{i}]') for i, k in enumerate(value))
            if any(b <= a for a, b in zip(knots, knots[1:])):
                raise ExtensionError(f'{at}: must increase strictly, got {list(knots)}')
            kwargs[key] = knots
        elif key == 'levels':
            if not isinstance(value, (list, tuple)) or len(value) < 1:
                raise ExtensionError(f'{at}: expected a list of category names')
            kwargs[key] = tuple(str(v) for v in value)
        else:
            kwargs[key] = _real(value, at)
    factor = Factor(variable=variable.strip(), basis=basis, **kwargs)
    checks = (
        (basis not in ('polynomial', 'spline') or factor.upper > factor.lower, 'upper',
         'must be > lower'),
        (basis != 'periodic' or factor.period > 0, 'period', 'must be > 0'),
        (basis != 'stribeck' or factor.stribeck_speed > 0, 'stribeck_speed', 'must be > 0'),
        (basis != 'stribeck' or factor.alpha > 0, 'alpha', 'must be > 0'),
        (basis not in ('log_polynomial', 'log_spline') or factor.log_upper > factor.log_lower,
         'log_upper', 'must be > log_lower'),
        (basis not in ('log_polynomial', 'log_spline', 'stribeck') or factor.variable == 'speed',
         'variable',
         f'basis {basis!r} applies to speed only'),
    )
    for ok, key, rule in checks:
        if not ok:
            raise ExtensionError(f'{_where(where, key)}: {rule}')
    return factor


def _term_from_mapping(item: Any, where: str) -> AddedTerm:
    if not isinstance(item, Mapping):
        raise ExtensionError(f'{where}: expected a mapping, got {type(item).__name__}')
    extra = sorted(set(item) - {'name', 'factors', 'coefficients', 'drop_first'})
    if extra:
        raise ExtensionError(f'{_where(where, extra[0])}: unknown key (expected name, '
                             'factors, coefficients, drop_first)')
    name = item.get('name')
    if not isinstance(name, str) or not name.strip():
        raise ExtensionError(f'{_where(where, "name")}: expected a non-empty string')
    factors = item.get('factors')
    if not isinstance(factors, (list, tuple)) or not factors:
        raise ExtensionError(f'{_where(where, "factors")}: expected a non-empty list')
    parsed = tuple(_factor_from_mapping(f, f'{where}.factors[{i}]')
                   for i, f in enumerate(factors))
    drop_first = item.get('drop_first', False)
    if not isinstance(drop_first, bool):
        raise ExtensionError(f'{_where(where, "drop_first")}: expected true or false')
    coefficients = item.get('coefficients')
    if not isinstance(coefficients, (list, tuple)):
        raise ExtensionError(f'{_where(where, "coefficients")}: expected a list of numbers')
    coefs = tuple(_real(c, f'{where}.coefficients[{i}]') for i, c in enumerate(coefficients))
    term = AddedTerm(name.strip(), parsed, coefs, drop_first)
    if len(coefs) != term.size:
        raise ExtensionError(f'{_where(where, "coefficients")}: expected {term.size} numbers '
                             f'(one per column of the factors), got {len(coefs)}')
    names = term.variables
    if 'wear' in names and ({'temperature', 'load'} & set(names)):
        raise ExtensionError(f'{_where(where, "factors")}: a term in wear and temperature or '
                             'load is not supported (the estimator adds the nominal (5) and '
                             'wear (7) parts)')
    return term


def extension_from_mapping(section: Any, where: str = 'added_terms') -> ModelExtension:
    """Validate the ``added_terms`` section of a parameter set; raise ExtensionError."""
    if not isinstance(section, Mapping):
        raise ExtensionError(f'{where}: expected a mapping, got {type(section).__name__}')
    extra = sorted(set(section) - {'defaults', 'terms'})
    if extra:
        raise ExtensionError(f'{where}.{extra[0]}: unknown key (expected defaults, terms)')
    defaults = section.get('defaults', {}) or {}
    if not isinstance(defaults, Mapping):
        raise ExtensionError(f'{where}.defaults: expected a mapping variable: value')
    parsed_defaults: list[tuple[str, str | float]] = []
    for key, value in defaults.items():
        if isinstance(value, str):
            parsed_defaults.append((str(key), value))
        else:
            parsed_defaults.append((str(key), _real(value, f'{where}.defaults.{key}')))
    terms = section.get('terms')
    if not isinstance(terms, (list, tuple)):
        raise ExtensionError(f'{where}.terms: expected a list of terms')
    extension = ModelExtension(tuple(_term_from_mapping(t, f'{where}.terms[{i}]')
                                     for i, t in enumerate(terms)), tuple(parsed_defaults))
    known = dict(extension.defaults)
    for i, term in enumerate(extension.terms):
        for variable in term.variables:
            if variable not in ONLINE_VARIABLES and variable not in known:
                raise ExtensionError(
                    f'{where}.defaults.{variable}: missing: terms[{i}] uses {variable!r}, which '
                    'the service does not measure online; state the value to evaluate it at')
        for j, factor in enumerate(term.factors):
            if factor.basis != 'categories' and isinstance(known.get(factor.variable), str):
                raise ExtensionError(f'{where}.defaults.{factor.variable}: expected a number '
                                     f'(terms[{i}].factors[{j}] is numeric)')
    return extension


def extension_to_mapping(extension: ModelExtension) -> dict:
    """Return the YAML-ready ``added_terms`` section of an extension."""
    terms = []
    for term in extension.terms:
        factors = []
        for f in term.factors:
            item: dict[str, Any] = {'variable': f.variable, 'basis': f.basis}
            for key in BASES[f.basis]:
                value = getattr(f, key)
                if isinstance(value, tuple):
                    value = [float(v) if key == 'knots' else str(v) for v in value]
                elif isinstance(value, float):
                    value = float(value)
                item[key] = value
            factors.append(item)
        entry: dict[str, Any] = {'name': term.name, 'factors': factors,
                                 'coefficients': [float(c) for c in term.coefficients]}
        if term.drop_first:
            entry['drop_first'] = True
        terms.append(entry)
    defaults = {k: (v if isinstance(v, str) else float(v)) for k, v in extension.defaults}
    return {'defaults': defaults, 'terms': terms}
