"""
The T and w estimates of the table's experiments before and after the added terms.

The wear estimator of :mod:`robot_wear_monitor.estimation` runs on every experiment (levels of one
experiment share T and w) twice: with the audit's model alone, and with the extended parameter
set, whose model functions evaluate the added terms (see
:mod:`robot_wear_monitor.model.extensions`).  On the table's own experiments the offline
variables of the terms are known, so the extended set is evaluated at each experiment's values
(the file's defaults are for the service): terms in offline variables only are subtracted
level by level, the other terms are evaluated at each experiment's mean value.  Units:
temperature [degC], wear w [-].
"""

from __future__ import annotations

from dataclasses import replace
import math

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.fitting import as_text, AuditTable
from robot_wear_monitor.model.params import ParameterSet


def _rms(x: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _split(params: ParameterSet, table: AuditTable) -> tuple[ParameterSet, FloatArray]:
    """
    Return the set without its offline-only terms, and their value at every level.

    A term in offline variables only (a ripple in position, a drift) is known level by level
    on the table: it is subtracted from the levels instead of evaluated at one value per
    experiment.
    """
    extension = params.model.extension
    if extension is None:
        return params, np.zeros(table.n_rows)
    offline = set(extension.offline_variables)
    values = {**table.numeric, **table.text}
    known = np.zeros(table.n_rows)
    kept = []
    for term in extension.terms:
        if set(term.variables) <= offline:
            known = known + term.evaluate(values)[0]
        else:
            kept.append(term)
    model = replace(params.model, extension=replace(extension, terms=tuple(kept))
                    if kept else None)
    return replace(params, model=model), known


def _at_experiment(params: ParameterSet, table: AuditTable, rows: NDArray) -> ParameterSet:
    """Return ``params`` with the load mean and the offline defaults of one experiment."""
    load = float(np.mean(table.numeric['load'][rows]))
    extension = params.model.extension
    if extension is not None:
        defaults = dict(extension.defaults)
        for name in extension.offline_variables:
            if name in table.text:
                values, counts = np.unique(table.text[name][rows], return_counts=True)
                defaults[name] = str(values[int(np.argmax(counts))])
            elif name in table.numeric:
                defaults[name] = float(np.mean(table.numeric[name][rows]))
        params = replace(params, model=replace(
            params.model, extension=replace(extension, defaults=tuple(defaults.items()))))
    return params.with_overrides(load_mean=load)


def estimate_changes(table: AuditTable, model: str, before: ParameterSet | None,
                     after: ParameterSet | None) -> dict:
    """
    Return how the (T, w) estimates per experiment change with the added terms.

    Errors are against the table's ``temperature`` and ``wear`` columns, the truth of the
    experiments; without a ``wear`` column no wear error is given (None: no basis), only how
    the estimates change.  Needs the nominal or complete model and an ``experiment`` column.
    """
    if model == 'speed' or before is None or after is None:
        return {'applies': False, 'reason': 'the speed model has no temperature or wear'}
    if 'experiment' not in table.columns:
        return {'applies': False, 'reason': 'no experiment column to group levels'}
    # deferred import: start-up time (the estimator: tables with an experiment column only)
    from robot_wear_monitor.estimation.estimator import estimate_wear

    y = table.numeric['friction']
    after, known = _split(after, table)
    experiments = as_text(table, 'experiment')
    results: dict[str, list] = {'before': [], 'after': []}
    truth_t, truth_w = [], []
    try:
        for key in sorted(set(experiments.tolist())):
            rows = experiments == key
            if rows.sum() < 2:
                continue
            speeds = table.numeric['speed'][rows]
            for label, params, levels in (('before', before, y[rows]),
                                          ('after', after, y[rows] - known[rows])):
                estimate = estimate_wear(speeds, levels,
                                         params=_at_experiment(params, table, rows))[0]
                results[label].append((estimate.temperature_degc, estimate.wear))
            truth_t.append(float(np.mean(table.numeric['temperature'][rows])))
            truth_w.append(float(np.mean(table.numeric['wear'][rows])) if 'wear' in
                           table.numeric else math.nan)
    except Exception as error:  # noqa: BLE001 - report, do not fail the audit
        return {'applies': False, 'reason': f'estimation failed: {error}'.splitlines()[0]}
    if not results['before']:
        return {'applies': False, 'reason': 'no experiment with two or more levels'}
    b, a = np.array(results['before']), np.array(results['after'])
    t_true, w_true = np.array(truth_t), np.array(truth_w)
    has_wear = 'wear' in table.numeric
    return {'applies': True, 'n_experiments': len(b),
            'temperature_rms_error_before_degc': _rms(b[:, 0] - t_true),
            'temperature_rms_error_after_degc': _rms(a[:, 0] - t_true),
            'wear_rms_error_before': _rms(b[:, 1] - w_true) if has_wear else None,
            'wear_rms_error_after': _rms(a[:, 1] - w_true) if has_wear else None,
            'temperature_mean_abs_change_degc': float(np.mean(np.abs(a[:, 0] - b[:, 0]))),
            'wear_mean_abs_change': float(np.mean(np.abs(a[:, 1] - b[:, 1]))),
            'per_experiment': [{'temperature_before_degc': float(x[0]), 'wear_before': float(x[1]),
                                'temperature_after_degc': float(z[0]), 'wear_after': float(z[1])}
                               for x, z in zip(b, a)],
            'reference': ("errors are against the table's temperature and wear columns"
                          if has_wear else "errors are against the table's temperature column; "
                          'no wear column: no wear error (no basis), only the change')}
