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
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.audit.candidates import ORDER_COLUMN
from robot_wear_monitor.audit.fitting import AuditTable, Base, Fit
from robot_wear_monitor.audit.identification_result import (Identification, NOMINAL_PARAMETERS,
                                                            PARAMETER_MEANINGS, parameter_unit,
                                                            WEAR_PARAMETERS)
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


def _file_name(source: str) -> str:
    """Return the file or folder name of a data source (no folders: a set holds no path)."""
    return Path(str(source).rstrip('/')).name or str(source)


def parameter_set_yaml(result: Identification) -> str:
    """
    Return the parameter-set YAML of an identification, commented with its provenance.

    Every value's comment says where it comes from (``result.provenance``): identified with
    its standard error, taken from the reference set (by name), scaled from it, held at a
    bound, or taken from the data.  No path is written: the data by file name, the reference
    set by its set name.
    """
    params = result.params
    model = params.model
    reference = result.from_params.name
    unit = params.friction_unit
    unit_text = '-' if unit == 'normalised' else unit
    provenance = result.provenance

    def line(key: str, value: float, comment: str) -> str:
        return f'  {key + ":":<24} {_yaml_number(value):<15} # {comment}'

    def model_line(key: str) -> str:
        text = f'{PARAMETER_MEANINGS[key]} [{parameter_unit(key, unit)}]'
        if provenance.get(key):
            text += f', {provenance[key]}'
        return line(key, getattr(model, key), text)

    n = result.nominal
    units = ('Torques are normalised (dimensionless)' if unit == 'normalised' else
             f'Friction (and its load) in {unit}')
    out = ['# Parameter set identified by robot-wear-monitor identify (Bittencourt & Axelsson, '
           'Sec. II-B, II-C).',
           f'# Nominal model (5): {n.n_levels} friction levels of '
           f'{_file_name(result.baseline_source)} ({n.n_experiments} experiments, '
           f'{n.n_speeds} speeds,',
           f'#   T {n.temperature_range_degc[0]:.4g}-{n.temperature_range_degc[1]:.4g} degC, '
           f'load {n.load_range[0]:.4g}-{n.load_range[1]:.4g}); +- are standard errors.',
           f'# Held-out error of (5) [mu, sigma] = [{n.held_out_mean:.3e}, '
           f'{n.held_out_std:.3e}] {unit_text} ({n.folds}).',
           f'# {units}; speeds are motor side in rad/s; temperatures in degC.']
    if result.extra.get('pooled_note') and not result.extra.get('configuration'):
        out += ['# ' + text for text in str(result.extra['pooled_note']).splitlines()]
    out += [f'name: {json.dumps(params.name)}', '', '# Nominal friction, eq. (5), identified.',
            'nominal_model:']
    out += [model_line(k) for k in NOMINAL_PARAMETERS]
    out.append('')
    scaling = result.extra.get('wear_model_scaling')
    if result.wear is not None:
        w = result.wear
        wear_file = _file_name(result.wear_source or '')
        out.append(f'# Wear profile, eq. (7), identified from {wear_file} at experiment '
                   f'{w.critical_experiment} with w = {w.critical_wear:g};')
        out.append(f'# wear-model error [mu, sigma] = [{w.error_mean:.3e}, {w.error_std:.3e}] '
                   f'over {len(w.levels)} experiments; alpha is shared with (5).')
    elif not params.estimates_wear:
        out.append('# Wear profile, eq. (7): none (identify --no-wear-model): this set estimates '
                   'the temperature only;')
        out.append('# w-hat is not determined and raises no alarm. A wear test of this joint '
                   '(identify --wear-test) gives a wear model.')
    elif scaling:
        out.append('# Wear profile, eq. (7): not identified: no wear test. Assumption: '
                   f'{scaling["assumption"]}.')
        out.append('# A wear test of this joint (identify --wear-test) replaces it.')
    else:
        out.append(f'# Wear profile, eq. (7): from {reference} as it stands (not identified: '
                   'no wear test).')
    out.append('wear_model:')
    out += [model_line(k) for k in WEAR_PARAMETERS]
    load_note = provenance.get('load', f'from {reference}')
    out += ['', f'# Measurement model, eqs. (9)-(14). sigma: {result.sigma_rule}.', 'noise:',
            line('sigma', params.sigma,
                 f'std of the friction-level error, eq. (9b) [{unit_text}]'),
            f'# Load estimate of eq. (14): {load_note}.',
            'load:', line('mean', params.load_mean, 'mean of the load-torque estimate'),
            line('std', params.load_std, 'std of the load-torque estimate'), '',
            '# Estimation: temperature bounds = '
            + ('given by --temperature-bounds' if result.extra.get('temperature_bounds_given')
               else "the baseline's temperature range") + f'; wear_max from {reference}.',
            'estimation:',
            line('temperature_min_degc', params.temperature_min_degc, 'degC'),
            line('temperature_max_degc', params.temperature_max_degc, 'degC'),
            line('wear_max', params.wear_max, 'upper end of the starting grid for w'), '',
            "# Experiment design: the speed range and separation of the baseline's levels "
            f'(motor side); design wear from {reference}.',
            'design:',
            line('speed_min_rad_s', params.speed_min_rad_s, "rad/s, the levels' lowest"),
            line('speed_max_rad_s', params.speed_max_rad_s, "rad/s, the levels' highest"),
            line('speed_separation_rad_s', params.speed_separation_rad_s,
                 "rad/s, the levels' smallest step between speeds"),
            line('temperature_degc', params.design_temperature_degc,
                 f'degC, {provenance.get("temperature_degc", f"from {reference}")}'),
            line('wear', params.design_wear, f'design wear level, from {reference}'), '',
            f'# Alarm: from {reference} (not determined by friction data)'
            + ('; unused without a wear model.' if not params.estimates_wear else '.'),
            'alarm:',
            line('wear_threshold', params.wear_threshold, 'alarm at w >= threshold'),
            line('wear_warning', params.wear_warning, 'diagnostics WARN at w >= warning')]
    if unit != 'normalised' or params.not_identified:
        out += ['', '# What the data identified, and the unit of the friction levels.',
                'identification:',
                f'  friction_unit: {json.dumps(unit)}']
        if params.not_identified:
            out.append('  not_identified: [' + ', '.join(params.not_identified) + ']')
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
