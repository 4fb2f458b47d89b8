"""
A set per configuration: the levels' configurations (payloads) named by a column of the levels.

``identify --configuration-column COLUMN`` writes one set per value of the column: the model is
identified on all levels (its load terms need every configuration), and each configuration's
set has that configuration's load estimate of eq. (14) and operating range.  The pooled set
(``--out``) is for a monitor that does not know its configuration; what that costs is measured
by the held-out check (:func:`temperature_cost`): every experiment of the baseline is estimated
with the pooled set and with its configuration's set, on its levels as a model fitted without
it sees them, and the temperature errors are compared.

Without the column, the configurations are those of a gap in the load column
(:func:`~robot_wear_monitor.audit.operating_range.load_clusters`).

Units: speeds motor side [rad/s]; load in the levels' unit; temperature [degC].
"""

from __future__ import annotations

from dataclasses import replace
import math
import re
from typing import Any, Sequence

import numpy as np
from robot_wear_monitor.audit.export import parameter_set_yaml
from robot_wear_monitor.audit.fitting import as_text, AuditTable
from robot_wear_monitor.audit.identification_result import Identification
from robot_wear_monitor.audit.operating_range import operating_range, pooled_load_prior
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import parameter_set_from_mapping
from robot_wear_monitor.yaml_files import shorten
import yaml

#: Longest configuration label in a file or set name.
MAX_LABEL_CHARS = 40


def configuration_label(value: str) -> str:
    """
    Return a configuration's value cut to letters, digits, ``-`` and ``_`` (for file names).

    ``'5 kg'`` -> ``'5kg'``; a value with none of them is an InputError naming it.
    """
    label = re.sub(r'[^A-Za-z0-9_-]', '', value)[:MAX_LABEL_CHARS]
    if not label:
        raise InputError(f'configuration value {shorten(repr(value))} has no letter, digit, '
                         "'-' or '_' to name its set by")
    return label


def column_configurations(table: AuditTable, column: str) -> list[dict[str, Any]]:
    """
    Return the configurations named by ``column``: one dict per value, in sorted order.

    Each holds ``value``, ``label`` (:func:`configuration_label`), the load estimate of
    eq. (14) (``mean``, ``std``, ``low``, ``high``, ``n_levels`` of its ``load`` column) and
    its operating range (``speed_min_rad_s``, ``speed_max_rad_s``,
    ``speed_separation_rad_s``).  Errors: the column missing, one value only, labels that
    collide.
    """
    if column not in table.columns:
        raise InputError(f'{table.source}: --configuration-column {shorten(column)}: no such '
                         f'column (columns: {shorten(", ".join(table.columns))})')
    values = as_text(table, column)
    keys = sorted(set(values.tolist()))
    if len(keys) < 2:
        raise InputError(f'{table.source}: --configuration-column {shorten(column)} has one '
                         f'value ({shorten(keys[0] if keys else "")}): one configuration, '
                         'nothing to split')
    out: list[dict[str, Any]] = []
    labels: dict[str, str] = {}
    for key in keys:
        label = configuration_label(key)
        if label in labels:
            raise InputError(f'{table.source}: configurations {shorten(repr(labels[label]))} and '
                             f'{shorten(repr(key))} give one file name {label!r}')
        labels[label] = key
        rows = values == key
        load = pooled_load_prior(table.numeric['load'][rows])
        speed_min, speed_max, separation = operating_range(table.numeric['speed'][rows])
        out.append({'value': key, 'label': label, **load.to_dict(),
                    'speed_min_rad_s': speed_min, 'speed_max_rad_s': speed_max,
                    'speed_separation_rad_s': separation, 'column': column})
    return out


def temperature_cost(*, table: AuditTable, residual: np.ndarray, held_out_residual: np.ndarray,
                     pooled: Any, sets: Sequence[Any], column: str) -> dict[str, Any]:
    """
    Return the held-out check of the pooled set against the configurations' own sets.

    Every experiment of ``table`` (one configuration each: its most frequent value of
    ``column``) is estimated from its levels as a model fitted without it sees them (the
    level minus the in-sample residual plus the held-out residual of the cross-validation by
    experiment), averaged per speed, with the ``pooled`` set and with its configuration's set
    (``sets`` in the order of :func:`column_configurations`); the error is T-hat minus the
    experiment's mean ``temperature`` [degC].

    :return: ``{'experiments': n, 'pooled': {'rms', 'max'}, 'configuration': {'rms', 'max'},
        'pooled_by_configuration': {value: {'rms', 'max', 'mean'}}}`` [degC]; empty
        without an ``experiment`` column.

    """
    # deferred import: start-up time (the estimator: tables with an experiment column only)
    from robot_wear_monitor.estimation.estimator import estimate_wear
    if 'experiment' not in table.columns:
        return {}
    experiments = as_text(table, 'experiment')
    values = as_text(table, column)
    keys = sorted(set(values.tolist()))
    seen = table.numeric['friction'] - residual + held_out_residual
    errors: dict[str, list[float]] = {'pooled': [], 'configuration': []}
    by_configuration: dict[str, list[float]] = {k: [] for k in keys}
    for experiment in sorted(set(experiments.tolist())):
        rows = experiments == experiment
        names, counts = np.unique(values[rows], return_counts=True)
        own = sets[keys.index(str(names[np.argmax(counts)]))]
        speed = table.numeric['speed'][rows]
        grid = np.unique(np.round(np.log(speed) / 0.02))
        keys_of = np.round(np.log(speed) / 0.02)
        speeds = np.array([speed[keys_of == k].mean() for k in grid])
        friction = np.array([seen[rows][keys_of == k].mean() for k in grid])
        measured = float(table.numeric['temperature'][rows].mean())
        for kind, params in (('pooled', pooled), ('configuration', own)):
            try:
                t_hat = float(estimate_wear(speeds, friction,
                                            params=params).temperature_degc[0])
            except InputError:
                continue
            errors[kind].append(t_hat - measured)
            if kind == 'pooled':
                by_configuration[str(names[np.argmax(counts)])].append(t_hat - measured)

    def figures(values: list[float]) -> dict[str, float]:
        if not values:
            return {'rms': math.nan, 'max': math.nan, 'mean': math.nan}
        array = np.asarray(values)
        return {'rms': float(np.sqrt(np.mean(array ** 2))), 'max': float(np.abs(array).max()),
                'mean': float(array.mean())}

    return {'experiments': len(errors['pooled']), 'pooled': figures(errors['pooled']),
            'configuration': figures(errors['configuration']),
            'pooled_by_configuration': {k: figures(v) for k, v in by_configuration.items()}}


def pooled_header(cost: dict[str, Any], column: str) -> str:
    """Return the pooled set's header lines: for which monitor, and what it costs."""
    lines = [f'Pooled over the configurations of column {column!r}: for a monitor that does '
             'not know its configuration (monitor each with its own set).']
    if cost:
        pooled, own = cost['pooled'], cost['configuration']
        lines.append(f"Held-out check on these levels ({cost['experiments']} experiments): "
                     f"T-hat error {pooled['rms']:.2g} degC rms (max {pooled['max']:.2g}) with "
                     f"this set, {own['rms']:.2g} degC rms (max {own['max']:.2g}) with each "
                     "configuration's own set.")
        lines += [f'  {column} {key}: mean T-hat error {f["mean"]:+.2g} degC with this set'
                  for key, f in cost['pooled_by_configuration'].items()
                  if math.isfinite(f['mean'])]
    return '\n'.join(lines)


def for_configuration(result: Identification, index: int) -> Identification:
    """
    Return the identification's set for one configuration (e.g. without the payload).

    The model, sigma, bounds and the wear model (scaled once, at the pooled load) are the
    same; the load estimate of eq. (14) is the configuration's mean and standard deviation.
    A configuration named by a column (``identify --configuration-column``) also has its own
    operating range and the name ``<name>_<label>``; one of a gap in the load column is named
    ``<name>_load<index + 1>``.  ``index`` counts ``result.extra['load_configurations']``
    (from the lightest load, or in the sorted order of the column's values).
    """
    configurations = result.extra.get('load_configurations') or []
    cluster = configurations[index]
    overrides: dict[str, Any] = {}
    if 'label' in cluster:
        name = f"{result.params.name}_{cluster['label']}"
        where = (f"the baseline's load column where {cluster['column']} = {cluster['value']} "
                 f"({cluster['n_levels']} levels, loads {cluster['low']:.4g}-"
                 f"{cluster['high']:.4g}): its mean and standard deviation")
        overrides = {k: float(cluster[k]) for k in ('speed_min_rad_s', 'speed_max_rad_s',
                                                    'speed_separation_rad_s')}
    else:
        name = f'{result.params.name}_load{index + 1}'
        where = (f"the baseline's load column, configuration {index + 1} of "
                 f"{len(configurations)} (loads {cluster['low']:.4g}-{cluster['high']:.4g}, "
                 f"{cluster['n_levels']} levels): its mean and standard deviation")
    provenance = {**result.provenance, 'load': where}
    params = replace(result.params, name=name, load_mean=float(cluster['mean']),
                     load_std=float(cluster['std']), **overrides)
    candidate = replace(result, params=params, provenance=provenance,
                        extra={**result.extra, 'configuration': index + 1})
    checked = parameter_set_from_mapping(yaml.safe_load(parameter_set_yaml(candidate)),
                                         source=f'identified set {name!r}')
    return replace(candidate, params=checked)
