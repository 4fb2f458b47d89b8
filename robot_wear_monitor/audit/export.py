"""Parameter export: the input parameter set plus the terms the audit added.

The nominal (5) (and, for the complete model, wear (7)) coefficients are the audit's joint
re-identification with the added terms (the amplitudes of the terms are only meaningful with
it); noise, load, bounds, design and alarm settings are the input set's.  The added terms go
into the ``added_terms`` section (see :mod:`robot_wear_monitor.model.extensions`), with the
defaults of the variables the service does not measure online:

* experiment order and time-like columns: the last value of the table (the joint's latest
  state: drift is evaluated where the data end);
* other numeric columns: the median of the table;
* categories: the most frequent one;
* ``load`` and ``temperature`` (only where m(v) of eq. (14) is linearised): the input set's
  load mean and design temperature.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.audit.candidates import ORDER_COLUMN
from robot_wear_monitor.audit.fitting import AuditTable, Base, Fit
from robot_wear_monitor.audit.shapes import Term
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.extensions import AddedTerm, ModelExtension, ONLINE_VARIABLES
from robot_wear_monitor.model.params import (FrictionModel, parameter_set_from_mapping,
                                             parameter_set_to_mapping,
                                             parameter_set_yaml_text, ParameterSet)

#: Columns whose default is their last value (the state where the data end).
LATEST_COLUMNS = ('experiment', ORDER_COLUMN, 'time', 'time_s', 'stamp', 'stamp_s', 'date')


def added_terms(base: Base, fit: Fit, table: AuditTable,
                terms: Sequence[Term]) -> tuple[AddedTerm, ...]:
    """Return the terms with their identified amplitudes (after the base model's columns)."""
    start = base.columns(fit.theta, table.subset(np.arange(1))).shape[1]
    out = []
    for term in terms:
        size = term.columns(table.subset(np.arange(1))).shape[1]
        out.append(term.added(fit.coef[start:start + size]))
        start += size
    return tuple(out)


def offline_defaults(table: AuditTable, terms: Sequence[AddedTerm]) -> dict[str, object]:
    """Return the default of every offline variable of the terms, and how it was chosen."""
    out: dict[str, object] = {}
    for name in dict.fromkeys(v for t in terms for v in t.variables):
        if name in ONLINE_VARIABLES:
            continue
        if name in table.text:
            values, counts = np.unique(table.text[name], return_counts=True)
            out[name] = (str(values[int(np.argmax(counts))]), 'most frequent category')
        elif name in LATEST_COLUMNS or name.startswith('time'):
            out[name] = (float(np.max(table.numeric[name])), 'last value (latest state)')
        else:
            out[name] = (float(np.median(table.numeric[name])), 'median of the table')
    return out


def base_model(params: ParameterSet, description: dict) -> FrictionModel:
    """Return the input set's model with the base coefficients of an audit fit."""
    values = {f: getattr(params.model, f) for f in FrictionModel.__dataclass_fields__}
    values.update({k: float(v) for k, v in description['all'].items() if k in values})
    values['extension'] = None
    return FrictionModel(**values)


def extended_parameter_set(params: ParameterSet, base: Base, fit: Fit, table: AuditTable,
                           terms: Sequence[Term], *, name: str | None = None) -> ParameterSet:
    """Return the parameter set of the audit's fit: re-identified base plus added terms."""
    model = base_model(params, base.describe(fit.theta, fit.coef))
    added = added_terms(base, fit, table, terms)
    defaults = {k: v for k, (v, _) in offline_defaults(table, added).items()}
    if any('load' in t.variables for t in added):
        defaults.setdefault('load', float(params.load_mean))
        defaults.setdefault('temperature', float(params.design_temperature_degc))
    extension = ModelExtension(added, tuple(defaults.items())) if added else None
    candidate = replace(params, name=name or f'{params.name}_audited',
                        model=replace(model, extension=extension), source='<audit>')
    # validate exactly as a loaded file would be
    return parameter_set_from_mapping(parameter_set_to_mapping(candidate),
                                      source=f'audited set {candidate.name!r}')


def write_parameter_set(path: str | Path, params: ParameterSet, *, header: str) -> None:
    """Write a parameter set as YAML (atomically), with ``header`` as comment lines."""
    try:
        write_text_atomic(path, parameter_set_yaml_text(params, header=header))
    except OSError as error:
        raise InputError(f'{path}: cannot write: {error.strerror or error}') from None
