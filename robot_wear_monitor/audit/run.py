"""
The audit loop: identify, test every candidate, name the best effect, add it, repeat.

1. identify the chosen model on the table (variable projection, :mod:`.fitting`, the core
   shared with ``identify``);
2. test the residual against every candidate family (:mod:`.candidates`, :mod:`.significance`)
   with Benjamini-Hochberg control over the step's candidates;
3. name the most significant effect with the simplest shape (:mod:`.shapes`); the other
   significant candidates that have no evidence given it are listed as confounded with it;
4. re-identify everything jointly and keep the effect when the held-out error
   (:mod:`.cross_validation`) comes down; repeat while the evidence holds.

Then the noise floor (:mod:`.noise`), the extended parameter set (:mod:`.export`) and the T
and w estimates before and after (:mod:`.estimates`).
"""

from __future__ import annotations

from dataclasses import replace
import math
from typing import Any, Sequence

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.candidates import (candidate_columns, families, make_variable,
                                                 make_variables, periodic_frequencies, Variable,
                                                 with_experiment_order, with_position_window)
from robot_wear_monitor.audit.cross_validation import cv_rms, fold_indices
from robot_wear_monitor.audit.data import MODELS, REQUIRED_COLUMNS
from robot_wear_monitor.audit.directions import (compare_directions, DIRECTION_GROUP, f_test,
                                                 PER_DIRECTION, with_direction_groups)
from robot_wear_monitor.audit.estimates import estimate_changes
from robot_wear_monitor.audit.export import (added_terms, base_model, extended_parameter_set,
                                             offline_defaults)
from robot_wear_monitor.audit.fitting import (as_text, AuditTable, Base, design_matrix, Fit,
                                              fit_model, group_codes, nominal_base, orthonormal)
from robot_wear_monitor.audit.noise import lack_of_fit, noise_floor
from robot_wear_monitor.audit.physical import flag_text, impossible_values
from robot_wear_monitor.audit.result import AuditResult, Effect
from robot_wear_monitor.audit.shapes import choose_shape, ShapeBuilder, Term
from robot_wear_monitor.audit.significance import (benjamini_hochberg, confounded, periodic_scan,
                                                   sinusoid, Tester)
from robot_wear_monitor.audit.speed_fit import fit_speed_model
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.json_values import json_clean
from robot_wear_monitor.model.extensions import Factor
from robot_wear_monitor.model.params import load_parameter_set, ParameterSet


#: Fewest distinct speeds per group for the five-parameter speed model (4).
MIN_SPEEDS = 6
#: Candidates tried per step (in order of significance) before the held-out error stops it.
MAX_TRIES = 3


def run_audit(*, table: AuditTable, model: str = 'speed', params: ParameterSet | None = None,
              group: str | None = None, fdr: float = 0.01, min_gain: float = 0.01,
              max_effects: int = 4, n_folds: int = 5, seed: int = 0,
              estimate: bool = True) -> AuditResult:
    """
    Identify ``model`` on ``table``, trace the structure of its residuals and add it.

    :param table: friction levels (see :func:`robot_wear_monitor.audit.data.read_level_table`).
    :param model: 'speed' (eq. 4, per ``group``), 'nominal' (eq. 5) or 'complete' (eq. 8).
    :param params: parameter set whose coefficients start the nominal/complete fit, that the
        (T, w) estimator uses and that the extended set extends; the packaged set when
        None.
    :param group: column whose every value gets its own speed model (e.g. ``joint``).
    :param fdr: false-discovery rate of the Benjamini-Hochberg control over each step's
        candidates.
    :param min_gain: minimum relative reduction of the held-out error for an effect to be kept.
    :param max_effects: at most this many effects are added.
    :param n_folds: cross-validation folds (by ``experiment`` when that column exists).
    :param seed: seed of the fold assignment.
    :param estimate: also report how the (T, w) estimates change (nominal/complete model with an
        ``experiment`` column; runs the wear estimator twice per experiment).

    :return: The :class:`~robot_wear_monitor.audit.result.AuditResult`.

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
        params = load_parameter_set()
    if params is not None and params.model.extension is not None and model != 'speed':
        params = _without_extension(params)
    table = with_position_window(with_experiment_order(table))
    table, excluded = enough_speeds(table, group, model)
    split = with_direction_groups(table, group) if model == 'speed' else None
    if split is not None:
        table = split
    nonnegative = model == 'speed'  # model (4) in its domain: F_c, F_s, F_v >= 0
    if model == 'speed':
        fitted = fit_speed_model(table, group)  # identify --speed-only's fitter
        base = fitted.base
    else:
        assert params is not None  # loaded above for the models (5) and (8)
        base = nominal_base(table, params.model, model == 'complete')
    n = table.n_rows
    if n < len(base.theta0) + 3 * _n_linear(base, table) // 2 + 5:
        raise InputError(f'{table.source}: {n} friction levels are too few to audit the '
                         f'{model} model')
    variables = make_variables(table, candidate_columns(table, model=model, group=group))
    group_variable = make_variable(table, group) if group is not None else None
    folds, fold_text = fold_indices(table, n_folds, seed)

    fit = fitted.fit if model == 'speed' else fit_model(base, table, [], base.theta0)
    fit_before, base_before = fit, base
    cv_before, held_before = cv_rms(base, table, [], fit.theta, folds,
                                    nonnegative=nonnegative)
    cv_now, held_now = cv_before, held_before
    terms: list[Term] = []
    effects: list[Effect] = []
    steps: list[dict] = []
    split_done = split is None
    speed_group = group  # model (4) per this group (per direction once the split is taken)
    stop = 'maximum number of effects reached'
    # a replicate repeats the model's conditions (speed, its variables, the groups and the
    # categories); measurements made along the way (a time, a window centre) are no condition
    conditions = ['speed'] + [c for c in REQUIRED_COLUMNS[model] if c not in
                              ('speed', 'friction')] + list(table.text)
    if group is not None:
        conditions.append(group)
    conditions = list(dict.fromkeys(conditions))
    for _ in range(max_effects):
        adequate = lack_of_fit(table=table, residual=fit.residual, n_parameters=(
            orthonormal(design_matrix(base, fit.theta, table, terms)).shape[1]
            + len(base.theta0)), variables=conditions)
        if adequate is not None and math.isfinite(adequate.p_value) and \
                adequate.p_value >= fdr:
            stop = (f'the model explains the data to the replicate error (lack of fit '
                    f'p = {adequate.p_value:.2g} >= {fdr:g})')
            break
        rejected: list[str] = []
        accepted = None
        while len(rejected) < MAX_TRIES:
            step = _step(table, base, fit, terms, variables, group_variable, fdr,
                         frozenset(rejected))
            steps.append(step['report'])
            if step['term'] is None:
                stop = step['report']['decision']
                break
            trial_terms = terms + [step['term']]
            trial_base, trial_fit = _refit(base, table, trial_terms, fit.theta, speed_group,
                                           model == 'speed')
            cv_trial, held_trial = cv_rms(
                trial_base, table,
                _fold_terms(trial_base, terms, step['term'], trial_fit.theta, nonnegative),
                trial_fit.theta, folds, nonnegative=nonnegative)
            step['report']['rms_cv_with_term'] = cv_trial
            if cv_trial <= cv_now * (1.0 - min_gain):
                accepted = step
                break
            step['report']['decision'] = (f'rejected: held-out error {cv_now:.4g} -> '
                                          f'{cv_trial:.4g} (needs {min_gain:.0%} gain)')
            rejected.append(step['report']['tried'])
            stop = (f'the {len(rejected)} most significant effect(s) do not lower the held-out '
                    'error')
        if not split_done:  # model (4) per direction: a candidate until it is taken
            rival = ({} if accepted is None else
                     {accepted['report']['chosen']['term']: cv_trial})
            taken = _per_direction_step(table, fit, terms, cv_now, folds, group, fdr,
                                        min_gain, effects, steps, rival)
            if taken is not None:
                if accepted is not None:
                    accepted['report']['decision'] = (
                        f'not added: {taken[0]} predicts held-out levels better')
                name, base, fit, cv_now, held_now, added = taken
                terms = terms + list(added)
                # after one offset per direction the per-direction model is no longer tried:
                # the offset earned its place against it held out
                split_done = True
                if name == PER_DIRECTION:
                    speed_group = DIRECTION_GROUP
                continue
            if accepted is not None:
                steps[-1]['decision'] += (f'; {accepted["report"]["chosen"]["term"]} '
                                          'added instead')
        if accepted is None:
            break
        step['report']['decision'] = 'added'
        change = trial_fit.prediction - fit.prediction
        term = step['term']
        effects.append(Effect(term.name, term.shape, term.variables, term.df, step['log10_p'],
                              cv_now, cv_trial, float(np.sqrt(np.mean(change ** 2))),
                              float(np.ptp(change)), dict(term.info),
                              step['report']['chosen']['candidate'],
                              tuple(step['report']['chosen']['confounded_with'])))
        terms, fit, cv_now, held_now = trial_terms, trial_fit, cv_trial, held_trial
        base = trial_base
    n_params = (orthonormal(design_matrix(base, fit.theta, table, terms)).shape[1]
                + len(base.theta0))
    floor_vars = ['speed'] + [c for c in REQUIRED_COLUMNS[model] if c not in
                              ('speed', 'friction')] + [v.name for v in variables]
    if group is not None:
        floor_vars.append(group)
    floor, floor_method = noise_floor(table=table, residual=fit.residual, n_parameters=n_params,
                                      variables=list(dict.fromkeys(floor_vars)))
    replicates = lack_of_fit(table=table, residual=fit.residual, n_parameters=n_params,
                             variables=conditions)
    if replicates is not None:
        # repeated runs at one condition: the pure error is the floor (model-free); the
        # nearest-neighbour estimate is kept beside it in the method text
        floor_method = (f'replicates: pure error of {replicates.groups} repeated conditions '
                        f'({replicates.pure_dof} degrees of freedom); nearest neighbour '
                        f'{floor:.4g}') if floor_method == 'nearest neighbour' else floor_method
        floor = replicates.pure_error if floor_method.startswith('replicates: pure') \
            else floor
        if math.isfinite(replicates.p_value) and replicates.p_value < fdr:
            where = ('' if replicates.speed_range is None else
                     f' (speeds {replicates.speed_range[0]:.4g} to '
                     f'{replicates.speed_range[1]:.4g})')
            stop += ('; lack of fit remains against the replicate error'
                     + ('' if stop.startswith('maximum') else ' and no candidate explains it')
                     + where)
    extended: ParameterSet | None = None
    offline: dict[str, Any] = {}
    changes = None
    if model != 'speed':
        assert params is not None  # loaded above for the models (5) and (8)
        extended = extended_parameter_set(params, base, fit, table, terms)
        offline = offline_defaults(table, added_terms(base, fit, table, terms))
        if estimate:
            before = params.with_overrides(model=base_model(
                params, base.describe(fit_before.theta, fit_before.coef)))
            changes = estimate_changes(table, model, before, extended)
    elif estimate:
        changes = estimate_changes(table, model, None, None)
    impossible = impossible_values(model, base.describe(fit.theta, fit.coef), table)
    return AuditResult(
        model=model, n_levels=n, group=group, candidates=tuple(v.name for v in variables),
        rms_before=cv_before, rms_after=cv_now,
        fit_rms_before=float(np.sqrt(np.mean(fit_before.residual ** 2))),
        fit_rms_after=float(np.sqrt(np.mean(fit.residual ** 2))),
        noise_floor=floor, noise_floor_method=floor_method, folds=fold_text,
        effects=tuple(effects), steps=tuple(steps), residual_before=fit_before.residual,
        residual_after=fit.residual,
        parameters_before=json_clean(base_before.describe(fit_before.theta, fit_before.coef)),
        parameters_after=json_clean(base.describe(fit.theta, fit.coef)),
        estimate_changes=changes, stop_reason=stop, excluded=excluded,
        extended_params=extended, offline=offline,
        parameter_flags=speed_parameter_flags(base, fit.theta, fit.coef, table)
        if model == 'speed' else tuple(flag_text(v, False) for v in impossible),
        impossible_values=tuple(impossible), lack_of_fit=replicates,
        rms_by_group=_rms_by_group(table, group, held_before, held_now),
        stribeck_dropped=base_before.dropped)


def _per_direction_step(table: AuditTable, fit: Fit, terms: Sequence[Term], cv_now: float,
                        folds: np.ndarray, group: str | None, fdr: float, min_gain: float,
                        effects: list[Effect], steps: list[dict], rivals: dict
                        ) -> tuple[str, Base, Fit, float, FloatArray, tuple] | None:
    """
    Try model (4) per direction (``identify --speed-only``'s) against the simpler candidates.

    Taken when its F-test against the common model (with the effects added so far) is
    significant at ``fdr`` and its held-out error beats, by ``min_gain``, that of the common
    model, of one offset per direction and of the step's own effect (``rivals``: name ->
    held-out error), as :func:`~robot_wear_monitor.audit.directions.compare_directions` decides
    for ``identify`` too.  When the offset per direction is preferred to both, it is added.
    The step and the effect taken are appended.  Returns (what was taken, base, fit, held-out
    error, held-out residual, the terms added), or None when neither is taken.
    """
    key = PER_DIRECTION
    labels = table.text[DIRECTION_GROUP]
    few = [f'{k}: {_distinct_speeds(table.numeric["speed"][labels == k])} distinct speeds'
           for k in sorted(set(labels.tolist()))
           if _distinct_speeds(table.numeric['speed'][labels == k]) < MIN_SPEEDS]
    report: dict[str, Any] = {'n_candidates': 1, 'tried': key}
    steps.append(report)
    if few:
        report['decision'] = (f'not tried: model (4) per direction needs {MIN_SPEEDS} distinct '
                              f'speeds per direction ({"; ".join(few)})')
        return None
    n_common = len(set(as_text(table, group).tolist())) if group is not None else 1
    verdict = compare_directions(table, group=group, fit=fit, terms=terms, cv_now=cv_now,
                                 folds=folds, n_common_groups=n_common, level=fdr,
                                 min_gain=min_gain, rivals=rivals)
    trial = verdict.trial
    report.update(best=[{'candidate': key, 'log10_p': trial.log10_p, 'q_value':
                         10.0 ** trial.log10_p if math.isfinite(trial.log10_p) else None,
                         'df': 5 * n_common}],
                  rms_cv_with_term=trial.cv, f_statistic=trial.f_statistic,
                  held_out_of_simpler=dict(verdict.rivals), preferred=verdict.preferred,
                  direction_verdict=verdict.direction_verdict)
    offset = verdict.offset
    if offset is not None and verdict.offset_fit is not None and \
            verdict.offset_held_out is not None and verdict.preferred == offset.name:
        report['decision'] = f'rejected: {verdict.reason}; {offset.name} added'
        cv = verdict.rivals[offset.name]
        change = verdict.offset_fit.fit.prediction - fit.prediction
        offset_residual = verdict.offset_fit.fit.residual
        _, p_value = f_test(float(fit.residual @ fit.residual),
                            float(offset_residual @ offset_residual), table.n_rows, n_common,
                            verdict.offset_fit.n_parameters + n_common)
        effects.append(Effect(
            name=offset.name, shape=offset.shape, variables=offset.variables, df=n_common,
            log10_p=(math.log10(max(p_value, 1e-300)) if math.isfinite(p_value) else
                     math.nan), rms_cv_before=cv_now, rms_cv_after=cv,
            size_rms=float(np.sqrt(np.mean(change ** 2))),
            size_range=float(change.max() - change.min()), info={}, candidate=offset.name))
        return (offset.name, verdict.offset_fit.base, verdict.offset_fit.fit, cv,
                verdict.offset_held_out, (offset,))
    if not verdict.per_direction:
        report['decision'] = f'rejected: {verdict.reason}'
        return None
    report['decision'] = f'accepted: {verdict.reason}'
    report['chosen'] = {'candidate': key, 'term': key, 'variables': ['speed', 'direction'],
                        'confounded_with': []}
    change = trial.fit.prediction - fit.prediction
    effects.append(Effect(
        name='model (4) per direction (F_c, F_s, phi_s, alpha, F_v of each direction)',
        shape='per direction', variables=('speed', 'direction'), df=5 * n_common,
        log10_p=trial.log10_p, rms_cv_before=cv_now, rms_cv_after=trial.cv,
        size_rms=float(np.sqrt(np.mean(change ** 2))),
        size_range=float(change.max() - change.min()),
        info={'f_statistic': trial.f_statistic}, candidate=key))
    return key, trial.base, trial.fit, trial.cv, trial.held_out, ()


def _refit(base: Base, table: AuditTable, terms: Sequence[Term], theta: FloatArray,
           group: str | None, speed: bool) -> tuple[Base, Fit]:
    """
    Re-identify the model with ``terms``: (base, fit).

    The speed model (4) per ``group`` by the shared fitter (its Stribeck terms decided again
    by BIC with the terms, amplitudes >= 0); the models (5) and (8) from ``theta``.
    """
    if speed:
        fitted = fit_speed_model(table, group, terms, theta)
        return fitted.base, fitted.fit
    return base, fit_model(base, table, terms, theta)


def _rms_by_group(table: AuditTable, group: str | None, before: np.ndarray,
                  after: np.ndarray) -> dict[str, tuple[float, float]]:
    """
    Return group -> (held-out RMS before, after) [friction units]; {} without a group.

    Joints whose friction differs sevenfold are not pooled into one number: each has its own.
    """
    if group is None:
        return {}
    labels = as_text(table, group)
    return {str(key): (float(np.sqrt(np.mean(before[labels == key] ** 2))),
                       float(np.sqrt(np.mean(after[labels == key] ** 2))))
            for key in sorted(set(labels.tolist()))}


def speed_parameter_flags(base: Base, theta: np.ndarray, coef: np.ndarray,
                          table: AuditTable) -> tuple[str, ...]:
    """
    Return the speed model's (4) fitted parameters at a bound or with an impossible sign.

    The Stribeck speed phi_s and the exponent alpha are fitted within bounds (phi_s from the
    lowest to 5 x the highest speed, 0.5 <= alpha <= 3): a value on a bound is where the data
    pushed the fit out of what it can identify.  A friction model's Coulomb level F_c, Stribeck
    rise F_s and viscous slope F_v are >= 0; a negative one fits the data's shape with a model
    that is no friction (a torque offset, a missing direction, a bad sign convention).
    """
    lower, upper = base.bounds(table)
    flags = []
    described = base.describe(theta, coef)
    impossible = impossible_values('speed', described, table)
    for i, (key, values) in enumerate(described.items()):
        where = '' if len(described) == 1 else f' ({key})'
        for k, name in ((2 * i, 'phi_s'), (2 * i + 1, 'alpha')) * (key not in base.dropped):
            for bound, side in ((lower[k], 'lower'), (upper[k], 'upper')):
                if abs(theta[k] - bound) <= 1e-6 * max(1.0, abs(bound)):
                    shown = math.exp(bound) if name == 'phi_s' else bound
                    flags.append(f'{name}{where} = {values[name]:.4g} sits on its {side} bound '
                                 f'{shown:.4g}: not identified by these speeds')
        amplitudes: tuple[str, ...] = ('F_c', 'F_s', 'F_v')
        if key in base.dropped:
            flags.append(f'Stribeck term{where} not supported by the data (BIC): left out, '
                         'F_s = 0, phi_s and alpha undetermined')
            amplitudes = ('F_c', 'F_v')
        flags += [flag_text(v, len(described) > 1) for v in impossible if v['group'] == key]
        flags += [f'{name}{where} = 0 sits on its bound ({name} >= 0): the data pull it '
                  'below zero' for name in amplitudes if values[name] == 0]
    return tuple(flags)


def _fold_terms(base: Base, terms: Sequence[Term], term: Term, theta: FloatArray,
                nonnegative: bool = False):
    """
    Return the terms of a trial for cross-validation.

    A sinusoid's period is scanned again on every fold's training levels (over the same range
    of periods), so that the held-out error does not profit from a period chosen on the
    held-out levels.  Other terms are fixed bases.
    """
    if term.shape != 'periodic':
        return list(terms) + [term]
    name = term.variables[0]

    def for_training(train: AuditTable) -> list[Term]:
        fit = fit_model(base, train, terms, theta, max_nfev=200, nonnegative=nonnegative)
        q0 = orthonormal(design_matrix(base, fit.theta, train, terms))
        x = train.numeric[name]
        variable = make_variable(train, name)
        if variable is None or variable.kind != 'continuous':
            return list(terms) + [term]
        tester = Tester(q0, fit.residual, None)
        _, period = periodic_scan(lambda f: sinusoid(x, f), periodic_frequencies(variable),
                                  tester.test)
        return list(terms) + [replace(term, factors=(
            Factor(name, 'periodic', period=period),), info={'period': period})]
    return for_training


def _without_extension(params: ParameterSet) -> ParameterSet:
    """Return the set without added terms (the audit re-identifies the paper's model)."""
    return replace(params, model=replace(params.model, extension=None))


def _distinct_speeds(speed: FloatArray) -> int:
    """Return the number of distinct speed levels (equal within 2 %)."""
    return len(np.unique(np.round(np.log(speed) / 0.02)))


def enough_speeds(table: AuditTable, group: str | None,
                  model: str) -> tuple[AuditTable, tuple[str, ...]]:
    """
    Drop the groups with fewer than MIN_SPEEDS distinct speeds (speed model only).

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
    keys, codes = group_codes(table, group)
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


def _n_linear(base: Base, table: AuditTable) -> int:
    return base.columns(base.theta0, table.subset(np.arange(1))).shape[1]


def _theta_jacobian(base: Base, table: AuditTable, terms: Sequence[Term],
                    fit: Fit) -> FloatArray:
    """Jacobian of the prediction in theta at the fit (finite differences), shape (n, p)."""
    cols = []
    for j in range(len(fit.theta)):
        step = 1e-6 * max(abs(fit.theta[j]), 1e-3)
        theta = fit.theta.copy()
        theta[j] += step
        x = design_matrix(base, theta, table, terms)
        cols.append((x @ fit.coef - fit.prediction) / step)
    return np.column_stack(cols) if cols else np.zeros((table.n_rows, 0))


def _step(table: AuditTable, base: Base, fit: Fit, terms: Sequence[Term],
          variables: Sequence[Variable], group_variable: Variable | None,
          fdr: float, exclude: frozenset = frozenset()) -> dict:
    """
    Test every candidate family against the current model; choose the effect to add.

    ``exclude``: candidates already tried in this step whose effect did not lower the held-out
    error; the most significant other candidate is chosen.
    """
    x0 = design_matrix(base, fit.theta, table, terms)
    # the model's own shapes: a Stribeck term left out (BIC) is still the model's, not an effect
    shapes = [] if base.span_columns is None else [base.span_columns(fit.theta, table)]
    # the linearised model: its columns and its Jacobian in the nonlinear parameters
    q0 = orthonormal(np.column_stack([x0, *shapes, _theta_jacobian(base, table, terms, fit)]))
    by_name = {v.name: v for v in variables}
    # from the second effect on, experiment-level structure left by the effects already added
    # counts with the experiments' scatter, not as independent levels (see Tester); so do
    # the rivals of the named effect (confounding)
    experiments = (np.unique(as_text(table, 'experiment'), return_inverse=True)[1].ravel()
                   if 'experiment' in table.columns else None)
    robust = Tester(q0, fit.residual, experiments)
    tester = robust if terms else Tester(q0, fit.residual, None)
    rows: list[dict[str, Any]] = []
    for family in families(table, variables, group_variable):
        period = None
        if family.periodic:
            x = table.numeric[family.variables[0]]
            log_p, period = periodic_scan(
                lambda f: sinusoid(x, f), periodic_frequencies(by_name[family.variables[0]]),
                tester.test)
            basis, df1 = sinusoid(x, 1.0 / period), 2
        else:
            basis = family.columns(table)
            log_p, df1 = tester.test(basis)
        if df1 == 0:
            continue
        rows.append({'candidate': family.key, 'variables': family.variables, 'log_p': log_p,
                     'df': df1, 'period': period, 'basis': basis})
    report: dict = {'n_candidates': len(rows)}
    if not rows:
        report['decision'] = 'no candidate variables to test'
        return {'term': None, 'report': report, 'log10_p': 0.0}
    log_ps = np.array([r['log_p'] for r in rows])
    adjusted = benjamini_hochberg(log_ps)
    order = np.argsort(log_ps)
    report['best'] = [{'candidate': rows[i]['candidate'],
                       'log10_p': float(log_ps[i] / math.log(10)),
                       'q_value': float(adjusted[i]), 'df': rows[i]['df']}
                      for i in order[:6]]
    significant = adjusted <= fdr
    if not significant.any():
        report['decision'] = (f'no significant structure (smallest BH q-value '
                              f'{adjusted.min():.3g} > {fdr})')
        return {'term': None, 'report': report, 'log10_p': 0.0}
    left = [int(i) for i in order if significant[i] and rows[i]['candidate'] not in exclude]
    if not left:
        report['decision'] = 'no other significant candidate'
        return {'term': None, 'report': report, 'log10_p': 0.0}
    top = rows[left[0]]
    report['tried'] = top['candidate']
    best = _marginal(top, rows, robust, fdr)
    periods = {r['variables'][0]: r['period'] for r, ok in zip(rows, significant)
               if ok and r['period'] is not None}
    builder = ShapeBuilder(table, variables, group_variable, base, fit.theta)
    term = choose_shape(builder.shapes(best['variables'], periods), q0, fit.residual, table)
    if term is None:
        report['decision'] = f'no shape of {best["candidate"]} adds to the model'
        return {'term': None, 'report': report, 'log10_p': 0.0}
    # the strongest single-variable rivals (alone or with speed, Bonferroni-significant with
    # the experiments as random effects) that share no variable with the chosen effect: are
    # they confounded with it?
    chosen = set(best['variables']) - {'speed'}
    rivals: dict = {}
    for r in sorted(rows, key=lambda r: r['log_p']):
        own = set(r['variables']) - {'speed'}
        if (len(own) == 1 and not own & chosen and r['period'] is None
                and not own & set(rivals) and r['log_p'] <= math.log(fdr / len(rows))
                and robust.test(r['basis'])[0] <= math.log(fdr / len(rows))):
            rivals[own.pop()] = r
    others = [(r['candidate'], r['basis']) for r in rivals.values()]
    report['chosen'] = {'candidate': best['candidate'], 'term': term.name,
                        'variables': list(term.variables),
                        'confounded_with': confounded(robust, best['basis'], others, fdr)}
    if best is not top:
        report['chosen']['instead_of'] = top['candidate']
    report['decision'] = 'candidate'
    return {'term': term, 'report': report, 'log10_p': float(best['log_p'] / math.log(10))}


def _marginal(best: dict, rows: Sequence[dict], tester: Tester, fdr: float) -> dict:
    """
    Return the single-variable family to name instead of an interaction, if one suffices.

    Marginality: an interaction (a pair, or a variable with speed) is named only when it has
    evidence beyond the smooth term of each of its variables alone (tested with the experiments
    as random effects, their scatter estimated with both terms in the model); otherwise the most
    significant of those single-variable families that explain it is named.
    """
    if len(best['variables']) < 2:
        return best
    singles = [r for r in rows if len(r['variables']) == 1 and r['period'] is None
               and r['variables'][0] in best['variables'] and r['log_p'] <= math.log(fdr)]
    enough = [r for r in singles
              if tester.with_columns(r['basis'], best['basis']).test(best['basis'])[0]
              > math.log(fdr)]
    return min(enough, key=lambda r: r['log_p']) if enough else best
