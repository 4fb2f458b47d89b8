"""
Parameter export: the input parameter set plus the terms the audit added.

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
import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.audit.candidates import ORDER_COLUMN
from robot_wear_monitor.audit.fitting import AuditTable, Base, Fit
from robot_wear_monitor.audit.identification_result import (Identification, NOMINAL_PARAMETERS,
                                                            Parameter, PARAMETER_MEANINGS,
                                                            PARAMETER_UNITS, WEAR_PARAMETERS)
from robot_wear_monitor.audit.shapes import Term
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.extensions import AddedTerm, ModelExtension, ONLINE_VARIABLES
from robot_wear_monitor.model.params import (FrictionModel, load_parameter_set,
                                             parameter_set_from_mapping,
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


def offline_defaults(table: AuditTable, terms: Sequence[AddedTerm]) -> dict[str, Any]:
    """Return the default of every offline variable of the terms, and how it was chosen."""
    out: dict[str, Any] = {}
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
        text = f'{PARAMETER_MEANINGS[key]} [{PARAMETER_UNITS[key]}]'
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


def write_identified_parameter_set(path: str | Path, result: Identification) -> ParameterSet:
    """
    Write the identified set atomically to ``path`` and load it back (the proof).

    :return: The set as :func:`~robot_wear_monitor.model.params.load_parameter_set` reads it.

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
