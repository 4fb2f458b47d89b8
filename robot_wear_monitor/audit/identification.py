"""
Identify a friction-model parameter set from measured friction levels (``identify``).

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
:func:`robot_wear_monitor.audit.speed_model.identify_speed_model`.  The results and their report
are :mod:`.identification_result`; the input checks and preparation :mod:`.identify_inputs`; the
parameter-set YAML :mod:`.export`; the figures :mod:`.report`.

Units: speeds motor side [rad/s]; friction normalised (or the table's own unit for model (4));
temperature [degC]; wear w dimensionless.
"""

from __future__ import annotations

from dataclasses import fields, replace
import math
from typing import Any, Mapping, Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.configurations import column_configurations
from robot_wear_monitor.audit.cross_validation import cv_rms, fold_indices
from robot_wear_monitor.audit.export import parameter_set_yaml
from robot_wear_monitor.audit.fitting import (as_text, AuditTable, Base, fit_model, multistart_fit,
                                              nominal_base, wear_base)
from robot_wear_monitor.audit.identification_result import (CRITICAL_WEAR, Identification,
                                                            NOMINAL_PARAMETERS,
                                                            NominalIdentification, Parameter,
                                                            PARAMETER_UNITS, WEAR_PARAMETERS,
                                                            WearIdentification, WearLevel)
from robot_wear_monitor.audit.identify_inputs import (check_baseline, check_wear_test,
                                                      distinct_count, experiment_order)
from robot_wear_monitor.audit.operating_range import (load_clusters, operating_range,
                                                      pooled_load_prior, scaled_wear_model)
from robot_wear_monitor.audit.parameter_errors import parameter_errors
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.friction import nominal_friction, wear_friction
from robot_wear_monitor.model.params import (FrictionModel, parameter_set_from_mapping,
                                             ParameterSet)
from scipy import optimize
import yaml


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
    """
    Return ``base`` (``n_columns`` linear columns) with some columns removed, theta fixed.

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
    """
    Identify the nominal model (5) on baseline friction levels.

    The full model is fitted from many starts (variable projection, the Stribeck speeds between
    0.05 rad/s and twice the highest speed, positive over the table's temperature range).  A
    Stribeck term the data do not support (lower BIC without it: e.g. a direct drive with no
    Stribeck dip) is dropped: its amplitudes are then 0 (standard errors of the full model) and
    its Stribeck speeds (and alpha, when both terms go) are undetermined (infinite standard
    errors).  Standard errors of f_v0 and f_v_temp take the larger of the linearised value and
    the change along the profile of T_V0 at +-1 standard error (their coupling through
    exp(-T/T_V0) is strongly nonlinear over a 20 degC range).

    :param table: levels with ``speed`` [rad/s], ``friction``, ``temperature`` [degC], ``load``
        (optionally ``experiment``: the held-out error is then cross-validated by
        experiment), checked by :func:`check_baseline`.
    :param start: a model whose nominal part is one of the starting points.
    :param n_folds: cross-validation folds.
    :param seed: seed of the fold assignment.

    :return: The :class:`NominalIdentification`.

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
    chosen, fit = base, full_fit
    dropped: tuple[int, ...] = ()
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
    parameters = tuple(Parameter(name, errors[name][0], errors[name][1], PARAMETER_UNITS[name],
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
        n_speeds=distinct_count(table.numeric['speed'], 0.02, log=True),
        temperatures=distinct_count(temperature, 0.1), loads=distinct_count(load, 0.005),
        temperature_range_degc=(float(temperature.min()), float(temperature.max())),
        load_range=(float(load.min()), float(load.max())), starts=ranked,
        dropped=tuple(_STRIBECK_TERMS[i][0] for i in dropped))


def _viscous_profile_errors(base: Base, table: AuditTable, fit, errors: Mapping, *,
                            index: int) -> dict:
    """
    Return f_v0, f_v_temp errors widened to their mean change along the T_V0 profile (+-1 SE).

    ``index`` is the position of T_V0 in the theta of ``base``.
    """
    t_v0, t_error, at_bound = errors['t_v0']
    if not math.isfinite(t_error) or at_bound:
        return {}
    lower, upper = base.bounds(table)
    out: dict[str, tuple[float, float, bool]] = {}
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
    """
    Identify the wear model (7) on an accelerated wear test and w of every experiment.

    :param table: levels of the wear test: ``speed`` [rad/s], ``friction``, ``temperature``
        [degC], ``load``, ``experiment`` (the test's time index k).
    :param nominal: the identified nominal model (5) (its alpha is shared with (7)).
    :param critical_experiment: label of the experiment K where w = ``critical_wear``.
    :param critical_wear: the conventional wear level of K (the paper: 35).
    :param start: a model whose phi_s,w is one of the starting points.
    :param wear_max: w of every experiment is searched in [0, wear_max] (a grid, then refined).
    :param free_alpha: identify alpha in (7) as well (when the nominal data do not determine it,
        e.g. a joint without a Stribeck dip); it is then reported among the parameters.

    :return: The :class:`WearIdentification`.

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
    parameters = tuple(Parameter(name, errors[name][0], errors[name][1], PARAMETER_UNITS[name],
                                 errors[name][2]) for name in names)
    model = _model_with(nominal, {p.name: p.value for p in parameters})
    order = experiment_order(labels.tolist())
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
             n_folds: int = 5, seed: int = 0, friction_unit: str = 'normalised',
             load_prior: tuple[float, float] | None = None,
             borrowed_wear: str = 'scaled',
             configuration_column: str | None = None) -> Identification:
    """
    Identify a complete parameter set: model (5), optionally (7), sigma of (9b).

    :param baseline: healthy-joint levels (``speed`` [rad/s, motor side], ``friction``,
        ``temperature``, ``load``, optionally ``experiment``).
    :param from_params: the reference set: the start of the fits and the source of every field the
        data cannot determine (wear_max, design wear, alarm; the load estimate when the data
        give none; the wear model without a wear test, scaled, see ``borrowed_wear``).
    :param name: the ``name`` of the new set.
    :param wear_test: levels of an accelerated wear test (same columns plus ``experiment``).
    :param critical_experiment: the experiment K of the wear test identified with w =
        ``critical_wear`` (required with ``wear_test``).
    :param critical_wear: w of experiment K (the paper's convention: 35).
    :param temperature_bounds_degc: (min, max) of the estimator's temperature [degC]; default the
        baseline's temperature range.
    :param n_folds: folds of the held-out error.
    :param seed: seed of the folds.
    :param friction_unit: the unit of the levels' friction (and of the load column), stated in
        the set.
    :param load_prior: (mean, std) of the load estimate of eq. (14), given; None: the mean and
        standard deviation of the baseline's load column.
    :param borrowed_wear: without a wear test: ``'scaled'`` (the reference's wear model (7)
        scaled to this joint, :func:`~robot_wear_monitor.audit.operating_range.scaled_wear_model`),
        ``'reference'`` (taken as it stands; for a joint like the reference's, in its unit),
        ``'none'`` (no wear model: the set estimates T-hat only, w-hat not determined;
        ``not_identified`` holds ``wear``).
    :param configuration_column: a column of the baseline naming its configurations (a
        payload): ``extra['load_configurations']`` holds one per value
        (:func:`~robot_wear_monitor.audit.configurations.column_configurations`) instead of
        those of a gap in the load column.

    :return: The :class:`Identification`; ``params`` is validated like a loaded file.

    """
    if not name or not name.strip():
        raise InputError('--name must not be empty')
    if wear_test is not None and critical_experiment is None:
        raise InputError('--wear-test needs --critical-experiment K (the experiment with '
                         'w = --critical-wear)')
    if borrowed_wear not in ('scaled', 'reference', 'none'):
        raise InputError(f'borrowed wear model: scaled, reference or none, got '
                         f'{borrowed_wear[:40]!r}')
    if borrowed_wear == 'none' and wear_test is not None:
        raise InputError('--no-wear-model writes a set without a wear model; a wear test '
                         '(--wear-test) identifies one: give one or the other')
    reference = from_params.name
    named = (column_configurations(baseline, configuration_column)
             if configuration_column is not None else None)
    warnings = check_baseline(baseline)
    nominal = identify_nominal(table=baseline, start=from_params.model, n_folds=n_folds,
                               seed=seed)
    dropped_names: set[str] = set()
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
    provenance = {p.name: _identified_text(p, dropped=p.name in dropped_names)
                  for p in nominal.parameters}
    alpha_undetermined = 'alpha' in dropped_names or not (
        {p.name: p for p in nominal.parameters}['alpha'].std_error
        <= 0.5 * abs(values['alpha']))
    if 'alpha' in dropped_names and wear_test is None and borrowed_wear != 'none':
        # no Stribeck term left in (5): alpha shapes only the borrowed wear model (7)
        values['alpha'] = from_params.model.alpha
        provenance['alpha'] = f'from {reference} (no Stribeck term in (5) to determine it)'
        warnings.append(f'alpha is not determined by the baseline: kept at {values["alpha"]:g} '
                        f'from {reference} (shared with its wear model (7))')
    elif alpha_undetermined and wear_test is None:
        warnings.append(f'alpha is poorly determined by the baseline: the fitted '
                        f'{values["alpha"]:.3g} is kept (the other parameters of (5) were '
                        'fitted with it)' + ('' if borrowed_wear == 'none' else
                                             ' and shared with the borrowed wear model (7)'))
    model = _model_with(from_params.model, values)
    speed_min, speed_max, separation = operating_range(baseline.numeric['speed'])
    t_lo, t_hi = (nominal.temperature_range_degc if temperature_bounds_degc is None
                  else temperature_bounds_degc)
    if not t_lo < t_hi:
        raise InputError(f'temperature bounds must satisfy low < high, got {t_lo}, {t_hi}')
    design_t = from_params.design_temperature_degc
    provenance['temperature_degc'] = f'from {reference}'
    if not t_lo <= design_t <= t_hi:
        warnings.append(f'design temperature {design_t:g} degC of {reference} is '
                        f'outside the temperature bounds: set to their middle '
                        f'{0.5 * (t_lo + t_hi):g} degC')
        design_t = 0.5 * (t_lo + t_hi)
        provenance['temperature_degc'] = 'the middle of the temperature bounds'
    clusters = load_clusters(baseline.numeric['load']) if named is None else ()
    if load_prior is not None:
        load_mean, load_std = load_prior
        provenance['load'] = 'given (--load-mean, --load-std)'
    else:
        pooled = pooled_load_prior(baseline.numeric['load'])
        load_mean, load_std = pooled.mean, pooled.std
        provenance['load'] = "the baseline's load column: its mean and standard deviation"
        if named is not None:
            provenance['load'] += (f' over the {len(named)} configurations of column '
                                   f'{configuration_column!r} (' + ', '.join(
                                       c['value'] for c in named) + ')')
        if len(clusters) > 1:
            provenance['load'] += (
                ' over both configurations of the load (' + ' and '.join(
                    f'{c.low:.3g}-{c.high:.3g}' for c in clusters) + ')')
    wear = None
    scaling = None
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
        provenance.update({p.name: _identified_text(p) for p in wear.parameters})
        sigma = math.hypot(nominal.held_out_std, wear.error_std)
        rule = ('root sum of squares of the held-out error of (5) and the wear-model error '
                'of (7)')
    else:
        if borrowed_wear == 'none':
            model = _model_with(model, {'f_s_wear': 0.0, 'f_v_wear': 0.0})
            provenance.update(dict.fromkeys(('f_s_wear', 'f_v_wear'),
                                            'no wear model (identify --no-wear-model)'))
            provenance['phi_s_wear'] = (f'from {reference}, unused: no wear model (the '
                                        'amplitudes are 0)')
        elif borrowed_wear == 'scaled':
            scaled, scaling = scaled_wear_model(
                reference=from_params, model=model, speed_min=speed_min, speed_max=speed_max,
                temperature_degc=design_t, load_mean=load_mean, friction_unit=friction_unit)
            model = _model_with(model, scaled)
            provenance.update({k: f'scaled from {reference} (see the assumption above)'
                               for k in WEAR_PARAMETERS})
        else:
            provenance.update({k: f'from {reference} as it stands (no wear test)'
                               for k in WEAR_PARAMETERS})
        sigma = max(nominal.held_out_std, from_params.sigma) if (
            friction_unit == from_params.friction_unit) else nominal.held_out_std
        rule = (f'no wear test: the larger of the held-out error of (5) and the sigma of '
                f'{reference}' if friction_unit == from_params.friction_unit else
                f'no wear test: the held-out error of (5) (the sigma of {reference} is in '
                f'{from_params.friction_unit}, not {friction_unit})')
    for bound in (t_lo, t_hi):
        if model.phi_s0 + model.phi_s_temp * bound <= 0:
            raise InputError(f'the identified Stribeck speed phi_s0 + phi_s_temp T is <= 0 at '
                             f'the temperature bound {bound:g} degC: keep the bounds within '
                             f'the baseline range')
    fields_of_set: dict[str, Any] = {f.name: getattr(from_params, f.name)
                                     for f in fields(ParameterSet)}
    fields_of_set.update(name=name.strip(), model=model, sigma=float(sigma),
                         temperature_min_degc=float(t_lo), temperature_max_degc=float(t_hi),
                         design_temperature_degc=float(design_t), source='<identified>',
                         load_mean=float(load_mean), load_std=float(load_std),
                         speed_min_rad_s=speed_min, speed_max_rad_s=speed_max,
                         speed_separation_rad_s=separation, friction_unit=friction_unit,
                         not_identified=('wear',) if borrowed_wear == 'none' else (),
                         direction_model=None)
    params = ParameterSet(**fields_of_set)
    extra: dict[str, Any] = {'temperature_bounds_given': temperature_bounds_degc is not None,
                             'friction_unit': friction_unit,
                             'load_configurations': (named if named is not None else
                                                     [c.to_dict() for c in clusters]),
                             'wear_model_scaling': scaling.to_dict() if scaling else None}
    result = Identification(params=params, nominal=nominal, wear=wear, sigma=float(sigma),
                            sigma_rule=rule, from_params=from_params,
                            warnings=tuple(warnings), baseline_source=baseline.source,
                            wear_source=wear_test.source if wear_test is not None else None,
                            extra=extra, provenance=provenance)
    # validate exactly as a loaded file (raises ParameterError, an InputError, naming the field)
    checked = parameter_set_from_mapping(yaml.safe_load(parameter_set_yaml(result)),
                                         source=f'identified set {name!r}')
    return replace(result, params=checked)


def _identified_text(p: Parameter, *, dropped: bool = False) -> str:
    """Return the provenance comment of an identified parameter (its standard error)."""
    if dropped:
        return ('left out: the data do not support its Stribeck term (BIC)' if
                p.value == 0 else 'undetermined: its Stribeck term is left out (BIC)')
    text = ('identified, +- ' + f'{p.std_error:.2e}' if math.isfinite(p.std_error)
            else 'identified, standard error undetermined (the data do not determine it)')
    if p.at_bound:
        text += ', held at a bound of its domain'
    return text
