"""Identify a friction-model parameter set from measured friction levels (``identify``).

Sec. II-B and II-C of Bittencourt and Axelsson, made a tool:

1. the nominal model (5), all twelve parameters, from the friction levels of a healthy joint
   (speed, friction, temperature, load): variable projection with several starts (the shared
   identification core of :mod:`robot_wear_monitor.audit.fitting`, the same as ``audit``), the
   Stribeck speeds kept positive over the data's temperature range, the standard error of every
   parameter, and the held-out prediction error [mu_eps, sigma_eps], cross-validated by
   experiment;
2. optionally, from the levels of an accelerated wear test, the wear profile (6) (data minus the
   identified nominal model at each level's temperature and load), the wear model (7) at the
   critical experiment K with w = 35 by convention (alpha shared with (5)), the wear level of
   every experiment (the validation of the paper's Fig. 4) and the wear-model error
   [mu, sigma]; sigma of (9b) is the root sum of squares of both errors;
3. a complete parameter set (the packaged YAML format), whose remaining fields (load estimate,
   design and alarm settings) come from a reference set.

The speed-only model (4) (per group, e.g. per joint) is identified the same way by
:func:`identify_speed_model`.

Units: speeds motor side [rad/s]; friction normalised (or the table's own unit for model (4));
temperature [degC]; wear w dimensionless.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
import json
import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.audit.cross_validation import cv_rms, fold_indices
from robot_wear_monitor.audit.fitting import (as_text, AuditTable, Base, fit_model, multistart_fit,
                                              nominal_base, parameter_errors, speed_base,
                                              wear_base)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.json_values import finite_or_none, json_clean
from robot_wear_monitor.model.friction import nominal_friction, wear_friction
from robot_wear_monitor.model.params import (FrictionModel, load_parameter_set,
                                             parameter_set_from_mapping, ParameterSet)

FloatArray = NDArray[np.float64]

#: The twelve parameters of the nominal model (5), in the order of the parameter-set YAML.
NOMINAL_PARAMETERS = ('f_c0', 'f_c_load', 'f_s0', 'f_s_load', 'f_s_temp', 'f_v0', 'f_v_temp',
                      'phi_s0', 'phi_s_load', 'phi_s_temp', 't_v0', 'alpha')
#: The parameters of the wear model (7) (alpha is shared with (5)).
WEAR_PARAMETERS = ('f_s_wear', 'f_v_wear', 'phi_s_wear')
#: Fewest distinct speeds for model (5) (error below), and the number that spans it well.
MIN_SPEEDS, GOOD_SPEEDS = 6, 8
#: Fewest distinct speeds of the critical experiment for model (7) (three parameters).
MIN_WEAR_SPEEDS = 4
#: Default wear level of the critical experiment (the paper's convention).
CRITICAL_WEAR = 35.0

_UNITS = {'f_c0': '-', 'f_c_load': '-/-', 'f_s0': '-', 'f_s_load': '-/-', 'f_s_temp': '1/degC',
          'f_v0': '1/(rad/s)', 'f_v_temp': '1/(rad/s)', 'phi_s0': 'rad/s',
          'phi_s_load': 'rad/s', 'phi_s_temp': 'rad/s/degC', 't_v0': 'degC', 'alpha': '-',
          'f_s_wear': '-/w', 'f_v_wear': '1/(rad/s)/w', 'phi_s_wear': 'rad/s/w'}
_MEANING = {'f_c0': 'Coulomb offset', 'f_c_load': 'Coulomb load slope',
            'f_s0': 'Stribeck amplitude offset', 'f_s_load': 'Stribeck load amplitude',
            'f_s_temp': 'Stribeck amplitude temperature slope',
            'f_v0': 'viscous slope offset', 'f_v_temp': 'viscous slope temperature amplitude',
            'phi_s0': 'Stribeck speed offset', 'phi_s_load': 'Stribeck speed of the load term',
            'phi_s_temp': 'Stribeck speed temperature slope',
            't_v0': 'viscous temperature constant', 'alpha': 'Stribeck exponent',
            'f_s_wear': 'Stribeck wear amplitude', 'f_v_wear': 'viscous wear slope',
            'phi_s_wear': 'Stribeck wear speed'}
#: What to measure more of when a parameter is poorly determined.
_MEASURE_MORE = {
    'f_c0': 'more load levels (including light loads)',
    'f_c_load': 'more load levels spread over the load range',
    'f_s_load': 'more load levels and more low speeds (below the load Stribeck speed)',
    'phi_s_load': 'more low speeds around the load Stribeck speed, at several loads',
    'f_s0': 'more temperatures and more low speeds',
    'f_s_temp': 'more temperatures (a wider range) and more low speeds',
    'phi_s0': 'more temperatures and more speeds around the Stribeck speed',
    'phi_s_temp': 'more temperatures (a wider range) and more speeds around the Stribeck speed',
    'f_v0': 'more high speeds at several temperatures',
    'f_v_temp': 'more high speeds over a wider temperature range',
    't_v0': 'more high speeds over a wider temperature range (three or more temperatures)',
    'alpha': 'more speeds across the Stribeck region',
    'f_s_wear': 'more low and intermediate speeds in the critical experiment',
    'f_v_wear': 'more high speeds in the critical experiment',
    'phi_s_wear': 'more speeds around the wear Stribeck speed in the critical experiment',
}


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class Parameter:
    """One identified parameter.

    Attributes:
        name: field name of the parameter set (``f_c0``, ...).
        value: the estimate, in the parameter's unit (``unit``).
        std_error: its standard error (inf when the data do not determine it).
        unit: unit of value and standard error.
        at_bound: the estimate lies on a bound of its physical domain.

    """

    name: str
    value: float
    std_error: float
    unit: str
    at_bound: bool = False

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (an infinite standard error is null)."""
        return {'value': self.value, 'std_error': finite_or_none(self.std_error),
                'unit': self.unit, 'at_bound': self.at_bound}


@dataclass(frozen=True)
class NominalIdentification:
    """The nominal model (5) identified on baseline levels.

    Attributes:
        parameters: the twelve parameters, in the order of :data:`NOMINAL_PARAMETERS`.
        held_out_mean: mean of the held-out prediction error mu_eps [friction units].
        held_out_std: its standard deviation sigma_eps [friction units].
        folds: how the levels were split for the held-out error.
        fit_rms: in-sample RMS error [friction units].
        residual: in-sample residual (data minus model), shape (n,).
        held_out_residual: held-out residual of every level, shape (n,).
        n_levels: number of friction levels.
        n_experiments: number of experiments (0 without an ``experiment`` column).
        n_speeds: number of distinct speeds (equal within 2 %).
        temperatures: number of distinct temperatures (equal within 0.1 degC).
        loads: number of distinct loads (equal within 0.005).
        temperature_range_degc: (min, max) of the levels' temperatures.
        load_range: (min, max) of the levels' loads.
        starts: number of starting points ranked by the multi-start fit.
        dropped: Stribeck terms left out because the data do not support them (BIC).

    """

    parameters: tuple[Parameter, ...]
    held_out_mean: float
    held_out_std: float
    folds: str
    fit_rms: float
    residual: FloatArray
    held_out_residual: FloatArray
    n_levels: int
    n_experiments: int
    n_speeds: int
    temperatures: int
    loads: int
    temperature_range_degc: tuple[float, float]
    load_range: tuple[float, float]
    starts: int
    dropped: tuple[str, ...] = ()

    def values(self) -> dict[str, float]:
        """Return {name: value} of the twelve parameters."""
        return {p.name: p.value for p in self.parameters}

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (without the residual arrays)."""
        return {'parameters': {p.name: p.to_dict() for p in self.parameters},
                'held_out_error': {'mean': self.held_out_mean, 'std': self.held_out_std,
                                   'folds': self.folds},
                'fit_rms': self.fit_rms, 'n_levels': self.n_levels,
                'n_experiments': self.n_experiments, 'distinct_speeds': self.n_speeds,
                'distinct_temperatures': self.temperatures, 'distinct_loads': self.loads,
                'temperature_range_degc': list(self.temperature_range_degc),
                'load_range': list(self.load_range), 'starts': self.starts,
                'dropped_terms': list(self.dropped)}


@dataclass(frozen=True)
class WearLevel:
    """The wear level identified for one experiment of the wear test (Fig. 4 validation).

    Attributes:
        experiment: the experiment's label (its value in the ``experiment`` column).
        wear: the identified w [-].
        wear_std: its standard error (from the pooled wear-model error).
        n_levels: friction levels of the experiment.

    """

    experiment: str
    wear: float
    wear_std: float
    n_levels: int


@dataclass(frozen=True)
class WearIdentification:
    """The wear model (7) identified on an accelerated wear test.

    Attributes:
        parameters: F_s,w, F_v,w and phi_s,w with standard errors (alpha from (5); alpha
            too when it was identified in (7), see :func:`identify_wear`).
        critical_experiment: the experiment K the model was identified at.
        critical_wear: the wear level assigned to K by convention.
        levels: the identified wear level of every experiment, in the table's order of
            experiments (numeric order when the labels are numbers).
        error_mean: mean of the wear-model error over the whole test [friction units].
        error_std: its standard deviation [friction units].
        profile: the wear profile (6) of every level of the test, shape (n,).
        residual: the wear-model error of every level (profile minus (7) at the experiment's
            identified w), shape (n,).
        experiment: the experiment label of every level, shape (n,).

    """

    parameters: tuple[Parameter, ...]
    critical_experiment: str
    critical_wear: float
    levels: tuple[WearLevel, ...]
    error_mean: float
    error_std: float
    profile: FloatArray
    residual: FloatArray
    experiment: NDArray[np.str_]

    def values(self) -> dict[str, float]:
        """Return {name: value} of the three wear parameters."""
        return {p.name: p.value for p in self.parameters}

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (without the per-level arrays)."""
        return {'parameters': {p.name: p.to_dict() for p in self.parameters},
                'critical_experiment': self.critical_experiment,
                'critical_wear': self.critical_wear,
                'error': {'mean': self.error_mean, 'std': self.error_std},
                'wear_levels': [{'experiment': lv.experiment, 'wear': lv.wear,
                                 'wear_std': finite_or_none(lv.wear_std),
                                 'n_levels': lv.n_levels} for lv in self.levels]}


@dataclass(frozen=True)
class Identification:
    """Outcome of :func:`identify`: the parameter set and how well the data determined it.

    Attributes:
        params: the complete, validated parameter set.
        nominal: the nominal model (5) identification.
        wear: the wear model (7) identification (None without a wear test).
        sigma: sigma of (9b) written to the set.
        sigma_rule: how sigma was formed.
        from_params: the reference set the undetermined fields came from.
        warnings: what the data do not determine well, each naming what to measure more of.
        baseline_source: where the baseline levels came from.
        wear_source: where the wear-test levels came from (None without a wear test).

    """

    params: ParameterSet
    nominal: NominalIdentification
    wear: WearIdentification | None
    sigma: float
    sigma_rule: str
    from_params: ParameterSet
    warnings: tuple[str, ...]
    baseline_source: str
    wear_source: str | None = None
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Return the JSON report (valid JSON: no NaN or inf)."""
        return json_clean({
            'name': self.params.name, 'nominal': self.nominal.to_dict(),
            'wear': self.wear.to_dict() if self.wear is not None else None,
            'sigma': self.sigma, 'sigma_rule': self.sigma_rule,
            'temperature_bounds_degc': [self.params.temperature_min_degc,
                                        self.params.temperature_max_degc],
            'from_params': self.from_params.source, 'baseline': self.baseline_source,
            'wear_test': self.wear_source, 'warnings': list(self.warnings), **self.extra})

    def summary(self) -> str:
        """Return a plain-text report."""
        nominal = self.nominal
        lines = [f'identified nominal model (5) on {nominal.n_levels} friction levels '
                 f'({nominal.n_experiments} experiments, {nominal.n_speeds} speeds, '
                 f'T {nominal.temperature_range_degc[0]:.1f}-'
                 f'{nominal.temperature_range_degc[1]:.1f} degC, load '
                 f'{nominal.load_range[0]:.3g}-{nominal.load_range[1]:.3g})']
        lines += [_parameter_line(p) for p in nominal.parameters]
        lines += [f'  {term}: not supported by the data (BIC), left out: amplitudes 0'
                  for term in nominal.dropped]
        lines.append(f'  held-out error [mu, sigma] = [{nominal.held_out_mean:.3e}, '
                     f'{nominal.held_out_std:.3e}] ({nominal.folds})')
        if self.wear is not None:
            wear = self.wear
            lines.append(f'wear model (7) at experiment {wear.critical_experiment} with '
                         f'w = {wear.critical_wear:g} (alpha from (5)):')
            lines += [_parameter_line(p) for p in wear.parameters]
            lines.append(f'  wear-model error [mu, sigma] = [{wear.error_mean:.3e}, '
                         f'{wear.error_std:.3e}] over {len(wear.levels)} experiments')
            shown = ', '.join(f'{lv.experiment}: {lv.wear:.1f}' for lv in wear.levels[-8:])
            lines.append(f'  identified w (last {min(8, len(wear.levels))}): {shown}')
        else:
            lines.append(f'wear model (7): from {self.from_params.source} (no --wear-test)')
        lines.append(f'sigma of (9b) = {self.sigma:.3e} ({self.sigma_rule})')
        lines += [f'warning: {text}' for text in self.warnings]
        return '\n'.join(lines)


def _parameter_line(p: Parameter) -> str:
    error = f'{p.std_error:.2e}' if math.isfinite(p.std_error) else 'undetermined'
    flag = '  (at its bound)' if p.at_bound else ''
    return f'  {p.name:<12}{p.value:>13.5g} +- {error:<12} [{p.unit}]{flag}'


# --------------------------------------------------------------------------- data checks

def _distinct(values: FloatArray, resolution: float, *, log: bool = False) -> int:
    x = np.log(values) if log else values
    return len(np.unique(np.round(x / resolution)))


def _require_columns(table: AuditTable, columns: Sequence[str], what: str) -> None:
    for name in columns:
        if name not in table.numeric:
            kind = 'non-numeric' if name in table.text else 'missing'
            raise InputError(f'{table.source}: column {name!r} is {kind} ({what} needs '
                             f'{", ".join(columns)})')


def check_baseline(table: AuditTable) -> list[str]:
    """Check that baseline levels can determine model (5); return the warnings.

    Raises:
        InputError: a missing column, fewer than :data:`MIN_SPEEDS` distinct speeds, a single
            temperature or a single load, or fewer levels than twice the parameters.

    """
    _require_columns(table, ('speed', 'friction', 'temperature', 'load'), 'model (5)')
    n_speeds = _distinct(table.numeric['speed'], 0.02, log=True)
    temperature = table.numeric['temperature']
    load = table.numeric['load']
    n_temperatures = _distinct(temperature, 0.1)
    n_loads = _distinct(load, 0.005)
    if n_speeds < MIN_SPEEDS:
        raise InputError(f'{table.source}: {n_speeds} distinct speed(s); model (5) needs at '
                         f'least {MIN_SPEEDS} (measure more speeds, low ones below the Stribeck '
                         f'speed and high ones for the viscous slope)')
    if n_temperatures < 2:
        raise InputError(f'{table.source}: a single temperature ({temperature[0]:g} degC); the '
                         'temperature terms of (5) need friction levels at several temperatures '
                         '(measure cold and warm, e.g. after start-up and after warm-up)')
    if n_loads < 2:
        raise InputError(f'{table.source}: a single load ({load[0]:g}); the load terms of (5) '
                         'need friction levels at several loads (measure with other payloads '
                         'or poses)')
    if table.n_rows < 2 * len(NOMINAL_PARAMETERS):
        raise InputError(f'{table.source}: {table.n_rows} friction levels are too few for the '
                         f'{len(NOMINAL_PARAMETERS)} parameters of (5) (need at least '
                         f'{2 * len(NOMINAL_PARAMETERS)})')
    warnings = []
    if n_speeds < GOOD_SPEEDS:
        warnings.append(f'only {n_speeds} distinct speeds: measure more speeds (at least '
                        f'{GOOD_SPEEDS}, spread from the lowest to the highest)')
    if n_temperatures < 3:
        warnings.append(f'only {n_temperatures} distinct temperatures: T_V0 needs three or '
                        'more; measure at more temperatures')
    if n_loads < 3:
        warnings.append(f'only {n_loads} distinct loads: measure at more loads')
    if 'experiment' not in table.columns:
        warnings.append('no experiment column: the held-out error is cross-validated by level, '
                        'not by experiment, and may be optimistic')
    return warnings


# --------------------------------------------------------------------------- model (5)

def _nominal_starts(table: AuditTable, start: FrictionModel, theta0: FloatArray,
                    lower: FloatArray, upper: FloatArray) -> list[FloatArray]:
    """Return the starts of theta = (phi_s,tl, phi_s(T_lo), phi_s(T_hi), T_V0, alpha)."""
    v = table.numeric['speed']
    vmin, vmax = float(v.min()), float(v.max())
    stribeck = np.exp(np.linspace(math.log(max(vmin, 0.1) * 1.5), math.log(vmax / 3.0), 3))
    starts = [theta0]
    for phi_load in stribeck:
        for phi_lo in stribeck:
            for ratio in (0.5, 1.0, 2.0):
                for t_v0 in (10.0, 40.0, 200.0):
                    for alpha in (0.8, 1.4, 2.5):
                        starts.append(np.array([phi_load, phi_lo, phi_lo * ratio, t_v0,
                                                alpha]))
    return [np.clip(s, lower + 1e-9, upper - 1e-9) for s in starts]


#: Stribeck terms of (5) that model selection may drop: (name, linear columns, theta indices)
#: in the columns (1, tl, tl e_tl, e_T, T e_T, v, v exp(-T/T_V0)) and theta (phi_s,tl,
#: phi_s(T_lo), phi_s(T_hi), T_V0, alpha) of the shared nominal base.
_STRIBECK_TERMS = (('load Stribeck term', (2,), (0,)),
                   ('temperature Stribeck term', (3, 4), (1, 2)))
_T_V0 = 3
_ALPHA = 4


def _restricted(base: Base, *, n_columns: int, drop_columns: Sequence[int],
                fixed_theta: Mapping[int, float]) -> Base:
    """Return ``base`` (``n_columns`` linear columns) with some columns removed, theta fixed.

    ``describe`` still reports every parameter: the removed amplitudes as 0, the fixed theta at
    their values.
    """
    n_theta = len(base.theta0)
    free = np.array([i for i in range(n_theta) if i not in fixed_theta], dtype=int)
    keep = np.array([j for j in range(n_columns) if j not in drop_columns], dtype=int)

    def full_theta(theta: FloatArray) -> FloatArray:
        out = np.empty(n_theta)
        out[free] = theta
        for i, value in fixed_theta.items():
            out[i] = value
        return out

    def columns(theta: FloatArray, data: AuditTable) -> FloatArray:
        return base.columns(full_theta(theta), data)[:, keep]

    def describe(theta: FloatArray, coef: FloatArray) -> dict:
        full = np.zeros(n_columns)
        full[keep] = coef
        return base.describe(full_theta(theta), full)

    def decays(theta: FloatArray, data: AuditTable) -> dict:
        return base.decays(full_theta(theta), data)

    return replace(base, theta0=base.theta0[free], lower=base.lower[free],
                   upper=base.upper[free], columns=columns, describe=describe, decays=decays,
                   bounds_for=None)


def _bic(fit, n_parameters: int) -> float:
    n = len(fit.residual)
    return n * math.log(max(float(fit.residual @ fit.residual), 1e-300) / n) + \
        n_parameters * math.log(n)


def identify_nominal(*, table: AuditTable, start: FrictionModel, n_folds: int = 5,
                     seed: int = 0) -> NominalIdentification:
    """Identify the nominal model (5) on baseline friction levels.

    The full model is fitted from many starts (variable projection, the Stribeck speeds between
    0.05 rad/s and twice the highest speed, positive over the table's temperature range).  A
    Stribeck term the data do not support (lower BIC without it: e.g. a direct drive with no
    Stribeck dip) is dropped: its amplitudes are then 0 (standard errors of the full model) and
    its Stribeck speeds (and alpha, when both terms go) are undetermined (infinite standard
    errors).  Standard errors of f_v0 and f_v_temp take the larger of the linearised value and
    the change along the profile of T_V0 at +-1 standard error (their coupling through
    exp(-T/T_V0) is strongly nonlinear over a 20 degC range).

    Args:
        table: levels with ``speed`` [rad/s], ``friction``, ``temperature`` [degC], ``load``
            (optionally ``experiment``: the held-out error is then cross-validated by
            experiment), checked by :func:`check_baseline`.
        start: a model whose nominal part is one of the starting points.
        n_folds: cross-validation folds.
        seed: seed of the fold assignment.

    Returns:
        The :class:`NominalIdentification`.

    """
    base = nominal_base(table, start, False)
    vmax = float(table.numeric['speed'].max())
    upper = base.upper.copy()
    upper[[0, 1, 2]] = 2.0 * vmax
    base = replace(base, upper=upper, theta0=np.minimum(base.theta0, upper - 1e-6))
    lower, upper = base.bounds(table)
    starts = _nominal_starts(table, start, base.theta0, lower, upper)
    full_fit, ranked = multistart_fit(base, table, starts, n_best=3)
    full_errors = parameter_errors(base, table, full_fit)
    n_linear = 7
    chosen, fit, dropped = base, full_fit, ()
    free_theta = list(range(len(base.theta0)))
    best = _bic(full_fit, n_linear + len(base.theta0))
    for subset in ((0,), (1,), (0, 1)):
        drop_columns = [c for i in subset for c in _STRIBECK_TERMS[i][1]]
        fixed = {t: float(full_fit.theta[t]) for i in subset for t in _STRIBECK_TERMS[i][2]}
        if len(subset) == 2:
            fixed[_ALPHA] = float(full_fit.theta[_ALPHA])
        candidate = _restricted(base, n_columns=n_linear, drop_columns=drop_columns,
                                fixed_theta=fixed)
        free = [i for i in range(len(base.theta0)) if i not in fixed]
        trial = fit_model(candidate, table, [], full_fit.theta[free], max_nfev=200)
        bic = _bic(trial, n_linear - len(drop_columns) + len(free))
        if bic < best:
            chosen, fit, best, dropped, free_theta = candidate, trial, bic, subset, free
    errors = dict(parameter_errors(chosen, table, fit))
    undetermined = {'phi_s_load'} if 0 in dropped else set()
    if 1 in dropped:
        undetermined |= {'phi_s0', 'phi_s_temp'}
    if len(dropped) == 2:
        undetermined.add('alpha')
    for name in ('f_s_load',) * (0 in dropped) + ('f_s0', 'f_s_temp') * (1 in dropped):
        errors[name] = (0.0, full_errors[name][1], False)
    for name in undetermined:
        errors[name] = (errors[name][0], math.inf, False)
    errors.update(_viscous_profile_errors(chosen, table, fit, errors,
                                          index=free_theta.index(_T_V0)))
    parameters = tuple(Parameter(name, errors[name][0], errors[name][1], _UNITS[name],
                                 errors[name][2]) for name in NOMINAL_PARAMETERS)
    folds, fold_text = fold_indices(table, n_folds, seed)
    _, held_out = cv_rms(chosen, table, [], fit.theta, folds)
    temperature = table.numeric['temperature']
    load = table.numeric['load']
    n_experiments = (len(set(as_text(table, 'experiment').tolist()))
                     if 'experiment' in table.columns else 0)
    return NominalIdentification(
        parameters=parameters, held_out_mean=float(np.mean(held_out)),
        held_out_std=float(np.std(held_out, ddof=1)), folds=fold_text,
        fit_rms=float(np.sqrt(np.mean(fit.residual ** 2))), residual=fit.residual,
        held_out_residual=held_out, n_levels=table.n_rows, n_experiments=n_experiments,
        n_speeds=_distinct(table.numeric['speed'], 0.02, log=True),
        temperatures=_distinct(temperature, 0.1), loads=_distinct(load, 0.005),
        temperature_range_degc=(float(temperature.min()), float(temperature.max())),
        load_range=(float(load.min()), float(load.max())), starts=ranked,
        dropped=tuple(_STRIBECK_TERMS[i][0] for i in dropped))


def _viscous_profile_errors(base: Base, table: AuditTable, fit, errors: Mapping, *,
                            index: int) -> dict:
    """Return f_v0, f_v_temp errors widened to their mean change along the T_V0 profile (+-1 SE).

    ``index`` is the position of T_V0 in the theta of ``base``.
    """
    t_v0, t_error, at_bound = errors['t_v0']
    if not math.isfinite(t_error) or at_bound:
        return {}
    lower, upper = base.bounds(table)
    out = {}
    for shift in (-t_error, t_error):
        value = float(np.clip(t_v0 + shift, lower[index] + 1e-6, upper[index] - 1e-6))
        fixed = _restricted(base, n_columns=len(fit.coef), drop_columns=(),
                            fixed_theta={index: value})
        free = [i for i in range(len(fit.theta)) if i != index]
        trial = fit_model(fixed, table, [], fit.theta[free], max_nfev=60)
        values = _flatten_all(fixed.describe(trial.theta, trial.coef))
        for name in ('f_v0', 'f_v_temp'):
            change = abs(values[name] - errors[name][0])
            out[name] = out.get(name, 0.0) + 0.5 * change  # mean of both sides
    return {name: (errors[name][0], max(errors[name][1], change), errors[name][2])
            for name, change in out.items()}


def _flatten_all(description: Mapping) -> dict[str, float]:
    return {k: float(v) for k, v in description['all'].items()}


def _model_with(model: FrictionModel, values: Mapping[str, float]) -> FrictionModel:
    current = {f.name: getattr(model, f.name) for f in fields(FrictionModel)}
    current.update({k: float(v) for k, v in values.items() if k in current})
    return FrictionModel(**current)


# --------------------------------------------------------------------------- model (7)

def _experiment_key(text: str) -> str:
    """Normalise an experiment label the way :func:`as_text` writes numbers."""
    try:
        return f'{float(text):g}'
    except ValueError:
        return str(text).strip()


def _experiment_order(labels: Sequence[str]) -> list[str]:
    unique = list(dict.fromkeys(labels))
    try:
        return sorted(unique, key=float)
    except ValueError:
        return sorted(unique)


def check_wear_test(table: AuditTable, critical_experiment: str) -> str:
    """Check the wear-test levels; return the critical experiment's label as in the table.

    Raises:
        InputError: a missing column, an unknown critical experiment, or too few distinct
            speeds in it for the three parameters of (7).

    """
    _require_columns(table, ('speed', 'friction', 'temperature', 'load'),
                     'the wear profile (6)')
    if 'experiment' not in table.columns:
        raise InputError(f"{table.source}: column 'experiment' is missing (the wear test "
                         'needs its time index k)')
    labels = as_text(table, 'experiment')
    key = _experiment_key(critical_experiment)
    if key not in set(labels.tolist()):
        order = _experiment_order(labels.tolist())
        raise InputError(f'{table.source}: --critical-experiment {critical_experiment}: no such '
                         f'experiment (the test has {len(order)}: {order[0]} ... {order[-1]})')
    n_speeds = _distinct(table.numeric['speed'][labels == key], 0.02, log=True)
    if n_speeds < MIN_WEAR_SPEEDS:
        raise InputError(f'{table.source}: critical experiment {key} has {n_speeds} distinct '
                         f'speed(s); the wear model (7) needs at least {MIN_WEAR_SPEEDS}')
    return key


def _fit_wear_level(speed: FloatArray, profile: FloatArray, model: FrictionModel,
                    wear_max: float) -> tuple[float, float]:
    """Return (w, sum of squared d(7)/dw) minimising the squared wear-model error, w >= 0."""
    grid = np.linspace(0.0, wear_max, 301)
    predicted = wear_friction(speed[None, :], grid[:, None], model)
    cost = np.sum((profile[None, :] - predicted) ** 2, axis=1)
    i = int(np.argmin(cost))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]

    def objective(w: float) -> float:
        return float(np.sum((profile - wear_friction(speed, w, model)) ** 2))
    if hi > lo:
        result = optimize.minimize_scalar(objective, bounds=(lo, hi), method='bounded',
                                          options={'xatol': 1e-6 * max(wear_max, 1.0)})
        w = float(result.x) if result.fun <= cost[i] else float(grid[i])
    else:
        w = float(grid[i])
    step = 1e-4 * max(w, 1.0)
    low = max(w - step, 0.0)
    slope = (wear_friction(speed, w + step, model) - wear_friction(speed, low, model)) / (
        w + step - low)
    return w, float(np.sum(slope ** 2))


def identify_wear(*, table: AuditTable, nominal: FrictionModel, critical_experiment: str,
                  critical_wear: float = CRITICAL_WEAR, start: FrictionModel,
                  wear_max: float = 150.0, free_alpha: bool = False) -> WearIdentification:
    """Identify the wear model (7) on an accelerated wear test and w of every experiment.

    Args:
        table: levels of the wear test: ``speed`` [rad/s], ``friction``, ``temperature``
            [degC], ``load``, ``experiment`` (the test's time index k).
        nominal: the identified nominal model (5) (its alpha is shared with (7)).
        critical_experiment: label of the experiment K where w = ``critical_wear``.
        critical_wear: the conventional wear level of K (the paper: 35).
        start: a model whose phi_s,w is one of the starting points.
        wear_max: w of every experiment is searched in [0, wear_max] (a grid, then refined).
        free_alpha: identify alpha in (7) as well (when the nominal data do not determine it,
            e.g. a joint without a Stribeck dip); it is then reported among the parameters.

    Returns:
        The :class:`WearIdentification`.

    """
    key = check_wear_test(table, critical_experiment)
    if not critical_wear > 0:
        raise InputError(f'--critical-wear must be > 0, got {critical_wear}')
    speed = table.numeric['speed']
    profile = table.numeric['friction'] - nominal_friction(
        speed, table.numeric['load'], table.numeric['temperature'], nominal)
    labels = as_text(table, 'experiment')
    rows = labels == key
    critical = AuditTable({'speed': speed[rows], 'friction': profile[rows],
                           'wear': np.full(int(rows.sum()), float(critical_wear))},
                          {}, f'{table.source} (experiment {key})')
    base = wear_base(critical, alpha=nominal.alpha, phi_s_wear=start.phi_s_wear,
                     free_alpha=free_alpha)
    lower, upper = base.bounds(critical)
    grid = np.exp(np.linspace(math.log(lower[0] * 1.01), math.log(upper[0] * 0.99), 25))
    alphas = (0.7, 1.0, 1.4, 2.0, 3.0) if free_alpha else (None,)
    starts = [base.theta0] + [np.array([x] if a is None else [x, a])
                              for x in grid for a in alphas]
    fit, _ = multistart_fit(base, critical, starts, n_best=3)
    errors = parameter_errors(base, critical, fit)
    names = WEAR_PARAMETERS + (('alpha',) if free_alpha else ())
    parameters = tuple(Parameter(name, errors[name][0], errors[name][1], _UNITS[name],
                                 errors[name][2]) for name in names)
    model = _model_with(nominal, {p.name: p.value for p in parameters})
    order = _experiment_order(labels.tolist())
    fitted, slopes, counts = {}, {}, {}
    residual = np.empty_like(profile)
    for label in order:
        mask = labels == label
        w, slope = _fit_wear_level(speed[mask], profile[mask], model,
                                   max(wear_max, 2.0 * critical_wear))
        if label == key:
            w = float(critical_wear)  # the convention that defines the scale of w
        fitted[label], slopes[label], counts[label] = w, slope, int(mask.sum())
        residual[mask] = profile[mask] - wear_friction(speed[mask], w, model)
    dof = max(len(profile) - len(order), 1)
    pooled = math.sqrt(float(residual @ residual) / dof)
    levels = tuple(WearLevel(label, fitted[label],
                             pooled / math.sqrt(slopes[label]) if slopes[label] > 0
                             else math.inf, counts[label]) for label in order)
    return WearIdentification(parameters=parameters, critical_experiment=key,
                              critical_wear=float(critical_wear), levels=levels,
                              error_mean=float(np.mean(residual)),
                              error_std=float(np.std(residual, ddof=1)) if len(residual) > 1
                              else 0.0, profile=profile, residual=residual, experiment=labels)


# --------------------------------------------------------------------------- model (4)

@dataclass(frozen=True)
class SpeedIdentification:
    """The speed-only model (4) identified per group.

    Attributes:
        groups: group -> {F_c, F_s, phi_s, alpha, F_v: :class:`Parameter`}.
        held_out_mean: mean of the held-out error [friction units].
        held_out_std: its std [friction units].
        folds: how the levels were split.
        fit_rms: in-sample RMS error.
        n_levels: levels used.
        excluded: groups left out (fewer than six distinct speeds), with the reason.

    """

    groups: Mapping[str, Mapping[str, Parameter]]
    held_out_mean: float
    held_out_std: float
    folds: str
    fit_rms: float
    n_levels: int
    excluded: tuple[str, ...] = ()

    @property
    def warnings(self) -> tuple[str, ...]:
        """Return the parameters the data do not determine well, naming what to measure."""
        out = []
        for group, values in self.groups.items():
            for p in values.values():
                where = ('at the high end' if p.name == 'F_v'
                         else 'below and around the Stribeck speed')
                if not p.std_error <= abs(p.value) and not (p.at_bound and p.value == 0):
                    out.append(f'{group} {p.name} = {p.value:.3g} has a standard error '
                               f'{p.std_error:.2g} larger than its value: measure more speeds '
                               f'{where}')
                elif p.at_bound:
                    out.append(f'{group} {p.name} = {p.value:.3g} is on a bound of its domain')
        return tuple(out)

    def to_dict(self) -> dict:
        """Return a JSON-ready dict."""
        return json_clean({'groups': {g: {k: p.to_dict() for k, p in values.items()}
                                      for g, values in self.groups.items()},
                           'warnings': list(self.warnings),
                           'held_out_error': {'mean': self.held_out_mean, 'std': self.held_out_std,
                                              'folds': self.folds},
                           'fit_rms': self.fit_rms, 'n_levels': self.n_levels,
                           'excluded': list(self.excluded)})


def identify_speed_model(*, table: AuditTable, group: str | None = None, n_folds: int = 5,
                         seed: int = 0) -> SpeedIdentification:
    """Identify the speed model (4) per value of ``group`` with standard errors.

    As in the paper, F_c, F_s, F_v, phi_s, alpha >= 0 (amplitudes by non-negative least squares
    inside the variable projection; an amplitude at 0 is flagged ``at_bound``).  Groups with
    fewer than six distinct speeds are left out (reported in ``excluded``).  The friction unit
    is the table's (N.m for the KUKA iiwa levels); speeds in the table's unit.
    """
    from robot_wear_monitor.audit.run import enough_speeds

    table, excluded = enough_speeds(table, group, 'speed')
    keys = (sorted(set(as_text(table, group).tolist())) if group is not None else ['all'])
    units = {'F_c': 'friction', 'F_s': 'friction', 'phi_s': 'speed', 'alpha': '-',
             'F_v': 'friction/speed'}
    groups: dict[str, dict[str, Parameter]] = {}
    held_out = np.zeros(table.n_rows)
    residual = np.zeros(table.n_rows)
    fold_text = ''
    for key in keys:
        rows = (as_text(table, group) == key) if group is not None else np.ones(
            table.n_rows, dtype=bool)
        sub = table.subset(rows)
        base = speed_base(sub, None)
        lower, upper = base.bounds(sub)
        starts = [base.theta0] + [np.array([log_phi, alpha])
                                  for log_phi in np.linspace(lower[0], upper[0], 9)
                                  for alpha in (0.7, 1.0, 1.4, 2.0, 2.8)]
        fit, _ = multistart_fit(base, sub, starts, n_best=3, nonnegative=True)
        errors = parameter_errors(base, sub, fit, nonnegative=True)
        for name, (value, error, at_bound) in errors.items():
            parameter = name.rpartition('.')[2]
            groups.setdefault(key, {})[parameter] = Parameter(parameter, value, error,
                                                              units[parameter], at_bound)
        folds, fold_text = fold_indices(sub, n_folds, seed)
        _, held_out[rows] = cv_rms(base, sub, [], fit.theta, folds, nonnegative=True)
        residual[rows] = fit.residual
    return SpeedIdentification(groups=groups, held_out_mean=float(np.mean(held_out)),
                               held_out_std=float(np.std(held_out, ddof=1)),
                               folds=fold_text + (f' within each {group}' if group else ''),
                               fit_rms=float(np.sqrt(np.mean(residual ** 2))),
                               n_levels=table.n_rows, excluded=excluded)


# --------------------------------------------------------------------------- the parameter set

def _precision_warnings(parameters: Sequence[Parameter]) -> list[str]:
    out = []
    for p in parameters:
        if not math.isfinite(p.std_error):
            out.append(f'{p.name} is not determined by the data: measure '
                       f'{_MEASURE_MORE[p.name]}')
        elif p.std_error > abs(p.value):
            out.append(f'{p.name} = {p.value:.3g} has a standard error {p.std_error:.2g} larger '
                       f'than its value: measure {_MEASURE_MORE[p.name]}')
        if p.at_bound:
            out.append(f'{p.name} = {p.value:.3g} is on a bound of its physical domain')
    return out


def identify(*, baseline: AuditTable, from_params: ParameterSet, name: str,
             wear_test: AuditTable | None = None, critical_experiment: str | None = None,
             critical_wear: float = CRITICAL_WEAR,
             temperature_bounds_degc: tuple[float, float] | None = None,
             n_folds: int = 5, seed: int = 0) -> Identification:
    """Identify a complete parameter set: model (5), optionally (7), sigma of (9b).

    Args:
        baseline: healthy-joint levels (``speed``, ``friction``, ``temperature``, ``load``,
            optionally ``experiment``).
        from_params: the reference set: the start of the fits and the source of every field the
            data cannot determine (load estimate, design, alarm, wear_max; and the wear model
            without a wear test).
        name: the ``name`` of the new set.
        wear_test: levels of an accelerated wear test (same columns plus ``experiment``).
        critical_experiment: the experiment K of the wear test identified with w =
            ``critical_wear`` (required with ``wear_test``).
        critical_wear: w of experiment K (the paper's convention: 35).
        temperature_bounds_degc: (min, max) of the estimator's temperature [degC]; default the
            baseline's temperature range.
        n_folds: folds of the held-out error.
        seed: seed of the folds.

    Returns:
        The :class:`Identification`; ``params`` is validated like a loaded file.

    """
    if not name or not name.strip():
        raise InputError('--name must not be empty')
    if wear_test is not None and critical_experiment is None:
        raise InputError('--wear-test needs --critical-experiment K (the experiment with '
                         'w = --critical-wear)')
    warnings = check_baseline(baseline)
    nominal = identify_nominal(table=baseline, start=from_params.model, n_folds=n_folds,
                               seed=seed)
    dropped_names = set()
    for term in nominal.dropped:
        names = ('f_s_load', 'phi_s_load') if term.startswith('load') else (
            'f_s0', 'f_s_temp', 'phi_s0', 'phi_s_temp')
        dropped_names.update(names)
        warnings.append(f'the {term} of (5) is not supported by the data (no Stribeck dip): left '
                        f'out, {", ".join(names)} undetermined; if a dip is expected, measure '
                        'more low speeds')
    if len(nominal.dropped) == 2:
        dropped_names.add('alpha')
    warnings += _precision_warnings([p for p in nominal.parameters
                                     if p.name not in dropped_names])
    values = nominal.values()
    alpha_undetermined = 'alpha' in dropped_names or not (
        {p.name: p for p in nominal.parameters}['alpha'].std_error
        <= 0.5 * abs(values['alpha']))
    if alpha_undetermined and wear_test is None:
        values['alpha'] = from_params.model.alpha
        warnings.append(f'alpha is not determined by the baseline: kept at {values["alpha"]:g} '
                        f'from {from_params.source} (shared with its wear model (7))')
    model = _model_with(from_params.model, values)
    wear = None
    if wear_test is not None:
        free_alpha = alpha_undetermined
        if free_alpha:
            warnings.append('alpha is not determined by the baseline (no Stribeck effect in '
                            '(5)): identified in the wear model (7) instead and shared with (5)')
        wear = identify_wear(table=wear_test, nominal=model,
                             critical_experiment=str(critical_experiment),
                             critical_wear=critical_wear, start=from_params.model,
                             wear_max=from_params.wear_max, free_alpha=free_alpha)
        warnings += _precision_warnings(wear.parameters)
        model = _model_with(model, wear.values())
        sigma = math.hypot(nominal.held_out_std, wear.error_std)
        rule = ('root sum of squares of the held-out error of (5) and the wear-model error '
                'of (7)')
    else:
        sigma = max(nominal.held_out_std, from_params.sigma)
        rule = (f'no wear test: the larger of the held-out error of (5) and the sigma of '
                f'{from_params.source}')
    t_lo, t_hi = (nominal.temperature_range_degc if temperature_bounds_degc is None
                  else temperature_bounds_degc)
    if not t_lo < t_hi:
        raise InputError(f'temperature bounds must satisfy low < high, got {t_lo}, {t_hi}')
    for bound in (t_lo, t_hi):
        if model.phi_s0 + model.phi_s_temp * bound <= 0:
            raise InputError(f'the identified Stribeck speed phi_s0 + phi_s_temp T is <= 0 at '
                             f'the temperature bound {bound:g} degC: keep the bounds within '
                             f'the baseline range')
    design_t = from_params.design_temperature_degc
    if not t_lo <= design_t <= t_hi:
        warnings.append(f'design temperature {design_t:g} degC of {from_params.source} is '
                        f'outside the temperature bounds: set to their middle '
                        f'{0.5 * (t_lo + t_hi):g} degC')
        design_t = 0.5 * (t_lo + t_hi)
    values = {f.name: getattr(from_params, f.name) for f in fields(ParameterSet)}
    values.update(name=name.strip(), model=model, sigma=float(sigma),
                  temperature_min_degc=float(t_lo), temperature_max_degc=float(t_hi),
                  design_temperature_degc=float(design_t), source='<identified>')
    params = ParameterSet(**values)
    result = Identification(params=params, nominal=nominal, wear=wear, sigma=float(sigma),
                            sigma_rule=rule, from_params=from_params,
                            warnings=tuple(warnings), baseline_source=baseline.source,
                            wear_source=wear_test.source if wear_test is not None else None,
                            extra={'temperature_bounds_given': temperature_bounds_degc
                                   is not None})
    # validate exactly as a loaded file (raises ParameterError, an InputError, naming the field)
    import yaml
    checked = parameter_set_from_mapping(yaml.safe_load(parameter_set_yaml(result)),
                                         source=f'identified set {name!r}')
    return Identification(**{**{f.name: getattr(result, f.name) for f in fields(result)},
                             'params': checked})


def _yaml_number(value: float) -> str:
    """Format a float so that YAML 1.1 reads it as a number (1.0e-3, never 1e-3)."""
    text = f'{value:.6g}'
    if 'e' in text:
        mantissa, exponent = text.split('e')
        if '.' not in mantissa:
            mantissa += '.0'
        return f'{mantissa}e{exponent}'
    return text if ('.' in text or 'n' in text) else text + '.0'


def parameter_set_yaml(result: Identification) -> str:
    """Return the parameter-set YAML of an identification, commented with its provenance."""
    params = result.params
    model = params.model
    nominal = {p.name: p for p in result.nominal.parameters}
    wear = {p.name: p for p in result.wear.parameters} if result.wear is not None else {}
    source = result.from_params.source

    def line(key: str, value: float, comment: str) -> str:
        return f'  {key + ":":<24} {_yaml_number(value):<15} # {comment}'

    def model_line(key: str, estimates: Mapping[str, Parameter]) -> str:
        value = getattr(model, key)
        text = f'{_MEANING[key]} [{_UNITS[key]}]'
        if key in estimates and not math.isclose(value, estimates[key].value, rel_tol=1e-9):
            text += f', from {source} (not determined by the data)'
        elif key in estimates:
            error = estimates[key].std_error
            text += (f', +- {error:.2e}' if math.isfinite(error) else ', undetermined')
        return line(key, value, text)

    n = result.nominal
    out = ['# Parameter set identified by robot-wear-monitor identify (Bittencourt & Axelsson, '
           'Sec. II-B, II-C).',
           f'# Nominal model (5): {n.n_levels} friction levels of {result.baseline_source} '
           f'({n.n_experiments} experiments, {n.n_speeds} speeds,',
           f'#   T {n.temperature_range_degc[0]:.4g}-{n.temperature_range_degc[1]:.4g} degC, '
           f'load {n.load_range[0]:.4g}-{n.load_range[1]:.4g}); +- are standard errors.',
           f'# Held-out error of (5) [mu, sigma] = [{n.held_out_mean:.3e}, '
           f'{n.held_out_std:.3e}] ({n.folds}).',
           '# Torques are normalised (dimensionless); speeds are motor side in rad/s; '
           'temperatures in degC.',
           f'name: {json.dumps(params.name)}', '', '# Nominal friction, eq. (5), identified.',
           'nominal_model:']
    if 'alpha' in wear:  # identified in (7): the baseline did not determine it
        nominal = {**nominal, 'alpha': wear['alpha']}
    out += [model_line(k, nominal) for k in NOMINAL_PARAMETERS]
    out.append('')
    if result.wear is not None:
        w = result.wear
        out.append(f'# Wear profile, eq. (7), identified from {result.wear_source} at '
                   f'experiment {w.critical_experiment} with w = {w.critical_wear:g};')
        out.append(f'# wear-model error [mu, sigma] = [{w.error_mean:.3e}, {w.error_std:.3e}] '
                   f'over {len(w.levels)} experiments; alpha is shared with (5).')
    else:
        out.append(f'# Wear profile, eq. (7): from {source} (not identified: no wear test).')
    out.append('wear_model:')
    out += [model_line(k, wear) for k in WEAR_PARAMETERS]
    out += ['', f'# Measurement model, eqs. (9)-(14). sigma: {result.sigma_rule}.', 'noise:',
            line('sigma', params.sigma, 'std of the friction-level error, eq. (9b) [-]'),
            f'# The friction data cannot determine the load estimate: from {source}.',
            'load:', line('mean', params.load_mean, 'mean of the load-torque estimate [-]'),
            line('std', params.load_std, 'std of the load-torque estimate [-]'), '',
            '# Estimation: temperature bounds = '
            + ('given by --temperature-bounds' if result.extra.get('temperature_bounds_given')
               else "the baseline's temperature range") + f'; wear_max from {source}.',
            'estimation:',
            line('temperature_min_degc', params.temperature_min_degc, 'degC'),
            line('temperature_max_degc', params.temperature_max_degc, 'degC'),
            line('wear_max', params.wear_max, 'upper end of the starting grid for w'), '',
            f'# Experiment design and alarm: from {source} (not determined by friction data).',
            'design:',
            line('speed_min_rad_s', params.speed_min_rad_s, 'rad/s'),
            line('speed_max_rad_s', params.speed_max_rad_s, 'rad/s'),
            line('speed_separation_rad_s', params.speed_separation_rad_s, 'rad/s'),
            line('temperature_degc', params.design_temperature_degc, 'degC'),
            line('wear', params.design_wear, 'design wear level'), '',
            'alarm:',
            line('wear_threshold', params.wear_threshold, 'alarm at w >= threshold'),
            line('wear_warning', params.wear_warning, 'diagnostics WARN at w >= warning')]
    return '\n'.join(out) + '\n'


def write_parameter_set(path: str | Path, result: Identification) -> ParameterSet:
    """Write the identified set atomically to ``path`` and load it back (the proof).

    Returns:
        The set as :func:`~robot_wear_monitor.model.params.load_parameter_set` reads it.

    """
    target = Path(path)
    if target.parent and not target.parent.exists():
        raise InputError(f'{target}: the folder {target.parent} does not exist')
    try:
        write_text_atomic(target, parameter_set_yaml(result))
    except OSError as error:
        raise InputError(f'{target}: cannot write: {error.strerror or error}') from None
    return load_parameter_set(target)


def default_from_params() -> ParameterSet:
    """Return the packaged parameter set (the default reference of ``identify``)."""
    return load_parameter_set()


# --------------------------------------------------------------------------- inputs and figures

def attach_series(table: AuditTable, *, column: str, time_s: ArrayLike, values: ArrayLike,
                  source: str) -> AuditTable:
    """Return ``table`` with ``column`` = the series interpolated at each level's time.

    For levels segmented from a bag (column ``time``, the level's centre time [s]) whose
    temperature or load was recorded on a topic: linear interpolation in time, the end values
    held outside the series.  Raises InputError when the table has no ``time`` column or the
    levels lie more than 60 s outside the series (a topic from another recording).
    """
    if 'time' not in table.numeric:
        raise InputError(f'{table.source}: {source}: the levels have no time to match it to')
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values, dtype=float)
    level_t = table.numeric['time']
    if level_t.min() < t[0] - 60.0 or level_t.max() > t[-1] + 60.0:
        raise InputError(f'{table.source}: {source} covers {t[0]:.1f}..{t[-1]:.1f} s, the '
                         f'levels {level_t.min():.1f}..{level_t.max():.1f} s')
    numeric = dict(table.numeric)
    numeric[column] = np.interp(level_t, t, v)
    return AuditTable(numeric, dict(table.text), table.source)


def number_experiments(table: AuditTable, *, gap_s: float) -> AuditTable:
    """Return ``table`` with ``experiment`` = 0, 1, ... split where levels are > gap_s apart.

    For levels segmented from a recording without an experiment column: consecutive levels
    (in time) less than ``gap_s`` [s] apart belong to one experiment.
    """
    if 'time' not in table.numeric or 'experiment' in table.columns:
        return table
    if not (math.isfinite(gap_s) and gap_s > 0):
        raise InputError(f'experiment gap must be > 0 s, got {gap_s}')
    t = table.numeric['time']
    order = np.argsort(t, kind='stable')
    index = np.empty(t.size)
    index[order] = np.concatenate([[0], np.cumsum(np.diff(t[order]) > gap_s)])
    numeric = dict(table.numeric)
    numeric['experiment'] = index
    return AuditTable(numeric, dict(table.text), table.source)


def prepare_levels(table: AuditTable, *, role: str, temperature_column: str | None = None,
                   load_column: str | None = None) -> AuditTable:
    """Return the levels with ``temperature`` and ``load`` columns, named or checked.

    Args:
        table: levels read by :func:`~robot_wear_monitor.audit.data.load_audit_data`.
        role: 'BASELINE' or 'WEAR' (for messages).
        temperature_column: column holding the joint temperature [degC] (default
            ``temperature``).
        load_column: column holding the load torque tau_l (default ``load``).

    Raises:
        InputError: a named column is missing, or the table has no temperature or load; the
            message says where they can come from.

    """
    numeric = dict(table.numeric)
    for target, name, option in (('temperature', temperature_column, '--temperature-column'),
                                 ('load', load_column, '--load-column')):
        if name is not None and name != target:
            if name not in numeric:
                raise InputError(f'{role} {table.source}: {option} {name!r}: no such numeric '
                                 f'column (columns: {", ".join(table.columns)})')
            numeric[target] = numeric[name]
        if target not in numeric:
            hint = (" (the raw runs' gravity load is in column load_torque: "
                    '--load-column load_torque)' if 'load_torque' in numeric and
                    target == 'load' else '')
            raise InputError(
                f'{role} {table.source}: no {target!r} column: model (5) needs the {target} of '
                f'every friction level; segmented raw runs and bags carry none: add it as a '
                f'column of a level CSV, name the column with {option}, or for a bag name '
                f'its topic with --{target}-topic{hint}')
    return AuditTable(numeric, dict(table.text), table.source)


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_identification(*, result: Identification, baseline: AuditTable,
                        wear_test: AuditTable | None = None, out_dir: str | Path,
                        dpi: int = 80) -> list[Path]:
    """Write the identification figures into ``out_dir``; return their paths.

    ``identify_residuals.png``: held-out residuals of (5) against speed, temperature and load
    (and the wear-model error against experiment with a wear test), with +- sigma_eps;
    ``identify_wear.png`` (wear test only): the identified w of every experiment and the wear
    profile (6) of the critical experiment with model (7).
    """
    plt = _pyplot()
    folder = Path(out_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f'{folder}: cannot create the figure folder: {error.strerror}') from None
    nominal = result.nominal
    panels = [('speed [rad/s]', baseline.numeric['speed'], nominal.held_out_residual),
              ('temperature [degC]', baseline.numeric['temperature'],
               nominal.held_out_residual),
              ('load [-]', baseline.numeric['load'], nominal.held_out_residual)]
    wear = result.wear
    if wear is not None and wear_test is not None:
        order = {lv.experiment: i for i, lv in enumerate(wear.levels)}
        index = np.array([order[e] for e in wear.experiment], dtype=float)
        panels.append(('experiment (index in time order)', index, wear.residual))
    figure, axes = plt.subplots(1, len(panels), figsize=(2.9 * len(panels), 2.5),
                                squeeze=False)
    for i, (axis, (label, x, residual)) in enumerate(zip(axes[0], panels)):
        axis.plot(x, residual, '.', markersize=2.5,
                  color='tab:orange' if label.startswith('experiment') else 'tab:blue')
        std = wear.error_std if label.startswith('experiment') else nominal.held_out_std
        for level in (-std, 0.0, std):
            axis.axhline(level, color='k' if level == 0 else '0.5', linewidth=0.6,
                         linestyle='-' if level == 0 else '--')
        if label.startswith('speed') and np.ptp(np.log(x)) > 2:
            axis.set_xscale('log')
        axis.set_xlabel(label, fontsize=8)
        axis.tick_params(labelsize=7)
    axes[0, 0].set_ylabel('held-out residual of (5)', fontsize=8)
    if len(panels) == 4:
        axes[0, 3].set_ylabel('error of (7)', fontsize=8)
    figure.suptitle(f'{result.params.name}: held-out error [mu, sigma] = '
                    f'[{nominal.held_out_mean:.2e}, {nominal.held_out_std:.2e}]', fontsize=9)
    figure.tight_layout()
    paths = [folder / 'identify_residuals.png']
    figure.savefig(paths[0], dpi=dpi)
    plt.close(figure)
    if wear is None or wear_test is None:
        return paths
    figure, (left, right) = plt.subplots(1, 2, figsize=(8.0, 2.8))
    w = np.array([lv.wear for lv in wear.levels])
    std = np.array([lv.wear_std for lv in wear.levels])
    x = np.arange(len(w))
    left.errorbar(x, w, yerr=np.where(np.isfinite(std), std, 0.0), fmt='.', markersize=3,
                  linewidth=0.7)
    critical = [i for i, lv in enumerate(wear.levels) if lv.experiment == wear.critical_experiment]
    left.plot(critical, [wear.critical_wear], 's', color='tab:red',
              label=f'K = {wear.critical_experiment} (w = {wear.critical_wear:g})')
    left.set_xlabel('experiment (index in time order)', fontsize=8)
    left.set_ylabel('identified w', fontsize=8)
    left.legend(fontsize=7)
    rows = wear.experiment == wear.critical_experiment
    speed = wear_test.numeric['speed'][rows]
    right.plot(speed, wear.profile[rows], 'o', markersize=3, label='wear profile (6)')
    grid = np.linspace(speed.min(), speed.max(), 200)
    right.plot(grid, wear_friction(grid, wear.critical_wear, result.params.model), '-',
               color='tab:red', label='model (7)')
    right.set_xlabel('speed [rad/s]', fontsize=8)
    right.set_ylabel('tau_f - tau_f0', fontsize=8)
    right.legend(fontsize=7)
    for axis in (left, right):
        axis.tick_params(labelsize=7)
    figure.tight_layout()
    paths.append(folder / 'identify_wear.png')
    figure.savefig(paths[1], dpi=dpi)
    plt.close(figure)
    return paths
