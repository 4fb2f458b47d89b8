"""
The results of ``identify``: identified parameters with standard errors and their report.

:class:`Parameter` (value, standard error, unit, bound), the nominal (5), wear-profile (7) and
complete results (:class:`NominalIdentification`, :class:`WearIdentification`,
:class:`Identification`), with their text report and JSON; the parameter names, units and
meanings of the parameter-set YAML.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.json_values import finite_or_none, json_clean
from robot_wear_monitor.model.params import (ParameterSet)


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

#: Unit of each parameter of the parameter set.
PARAMETER_UNITS = {'f_c0': '-', 'f_c_load': '-/-', 'f_s0': '-', 'f_s_load': '-/-',
                   'f_s_temp': '1/degC',
                   'f_v0': '1/(rad/s)', 'f_v_temp': '1/(rad/s)', 'phi_s0': 'rad/s',
                   'phi_s_load': 'rad/s', 'phi_s_temp': 'rad/s/degC', 't_v0': 'degC', 'alpha': '-',
                   'f_s_wear': '-/w', 'f_v_wear': '1/(rad/s)/w', 'phi_s_wear': 'rad/s/w'}
#: The parameters whose unit is the friction's (normalised: dimensionless), and the rest of
#: their unit.
_FRICTION_UNITS = {'f_c0': '', 'f_c_load': '/load', 'f_s0': '', 'f_s_load': '/load',
                   'f_s_temp': '/degC', 'f_v0': '/(rad/s)', 'f_v_temp': '/(rad/s)',
                   'f_s_wear': '/w', 'f_v_wear': '/(rad/s)/w'}


def parameter_unit(name: str, friction_unit: str = 'normalised') -> str:
    """Return the unit of a parameter when friction is in ``friction_unit`` (e.g. 'A/degC')."""
    if friction_unit == 'normalised' or name not in _FRICTION_UNITS:
        return PARAMETER_UNITS[name]
    return friction_unit + _FRICTION_UNITS[name]


#: What each parameter of the parameter set stands for.
PARAMETER_MEANINGS = {'f_c0': 'Coulomb offset', 'f_c_load': 'Coulomb load slope',
                      'f_s0': 'Stribeck amplitude offset', 'f_s_load': 'Stribeck load amplitude',
                      'f_s_temp': 'Stribeck amplitude temperature slope',
                      'f_v0': 'viscous slope offset',
                      'f_v_temp': 'viscous slope temperature amplitude',
                      'phi_s0': 'Stribeck speed offset',
                      'phi_s_load': 'Stribeck speed of the load term',
                      'phi_s_temp': 'Stribeck speed temperature slope',
                      't_v0': 'viscous temperature constant', 'alpha': 'Stribeck exponent',
                      'f_s_wear': 'Stribeck wear amplitude', 'f_v_wear': 'viscous wear slope',
                      'phi_s_wear': 'Stribeck wear speed'}
#: What to measure more of when a parameter is poorly determined.


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class Parameter:
    """
    One identified parameter.

    :ivar name: field name of the parameter set (``f_c0``, ...).
    :ivar value: the estimate, in the parameter's unit (``unit``).
    :ivar std_error: its standard error (inf when the data do not determine it).
    :ivar unit: unit of value and standard error.
    :ivar at_bound: the estimate lies on a bound of its physical domain.

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
    """
    The nominal model (5) identified on baseline levels.

    :ivar parameters: the twelve parameters, in the order of :data:`NOMINAL_PARAMETERS`.
    :ivar held_out_mean: mean of the held-out prediction error mu_eps [friction units].
    :ivar held_out_std: its standard deviation sigma_eps [friction units].
    :ivar folds: how the levels were split for the held-out error.
    :ivar fit_rms: in-sample RMS error [friction units].
    :ivar residual: in-sample residual (data minus model), shape (n,).
    :ivar held_out_residual: held-out residual of every level, shape (n,).
    :ivar n_levels: number of friction levels.
    :ivar n_experiments: number of experiments (0 without an ``experiment`` column).
    :ivar n_speeds: number of distinct speeds (equal within 2 %).
    :ivar temperatures: number of distinct temperatures (equal within 0.1 degC).
    :ivar loads: number of distinct loads (equal within 0.005).
    :ivar temperature_range_degc: (min, max) of the levels' temperatures.
    :ivar load_range: (min, max) of the levels' loads.
    :ivar starts: number of starting points ranked by the multi-start fit.
    :ivar dropped: Stribeck terms left out because the data do not support them (BIC).

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
    """
    The wear level identified for one experiment of the wear test (Fig. 4 validation).

    :ivar experiment: the experiment's label (its value in the ``experiment`` column).
    :ivar wear: the identified w [-].
    :ivar wear_std: its standard error (from the pooled wear-model error).
    :ivar n_levels: friction levels of the experiment.

    """

    experiment: str
    wear: float
    wear_std: float
    n_levels: int


@dataclass(frozen=True)
class WearIdentification:
    """
    The wear model (7) identified on an accelerated wear test.

    :ivar parameters: F_s,w, F_v,w and phi_s,w with standard errors (alpha from (5); alpha
        too when it was identified in (7), see :func:`identify_wear`).
    :ivar critical_experiment: the experiment K the model was identified at.
    :ivar critical_wear: the wear level assigned to K by convention.
    :ivar levels: the identified wear level of every experiment, in the table's order of
        experiments (numeric order when the labels are numbers).
    :ivar error_mean: mean of the wear-model error over the whole test [friction units].
    :ivar error_std: its standard deviation [friction units].
    :ivar profile: the wear profile (6) of every level of the test, shape (n,).
    :ivar residual: the wear-model error of every level (profile minus (7) at the experiment's
        identified w), shape (n,).
    :ivar experiment: the experiment label of every level, shape (n,).

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
    """
    Outcome of :func:`identify`: the parameter set and how well the data determined it.

    :ivar params: the complete, validated parameter set.
    :ivar nominal: the nominal model (5) identification.
    :ivar wear: the wear model (7) identification (None without a wear test).
    :ivar sigma: sigma of (9b) written to the set.
    :ivar sigma_rule: how sigma was formed.
    :ivar from_params: the reference set the undetermined fields came from.
    :ivar warnings: what the data do not determine well, each naming what to measure more of.
    :ivar baseline_source: where the baseline levels came from.
    :ivar wear_source: where the wear-test levels came from (None without a wear test).
    :ivar extra: further report fields (friction unit, load configurations, wear scaling).
    :ivar provenance: where each value of the set comes from, in words: the model's fields
        (identified with its standard error, from the reference set by name, scaled, held at
        a bound), ``load`` and the design ``temperature_degc``.

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
    provenance: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Return the JSON report (valid JSON: no NaN or inf)."""
        return json_clean({
            'name': self.params.name, 'nominal': self.nominal.to_dict(),
            'wear': self.wear.to_dict() if self.wear is not None else None,
            'sigma': self.sigma, 'sigma_rule': self.sigma_rule,
            'temperature_bounds_degc': [self.params.temperature_min_degc,
                                        self.params.temperature_max_degc],
            'from_params': self.from_params.source, 'from_params_name': self.from_params.name,
            'baseline': self.baseline_source,
            'set_values': {name: getattr(self.params.model, name)
                           for name in NOMINAL_PARAMETERS + WEAR_PARAMETERS},
            'provenance': dict(self.provenance),
            'load_estimate': {'mean': self.params.load_mean, 'std': self.params.load_std},
            'operating_range': {'speed_min_rad_s': self.params.speed_min_rad_s,
                                'speed_max_rad_s': self.params.speed_max_rad_s,
                                'speed_separation_rad_s': self.params.speed_separation_rad_s},
            'wear_test': self.wear_source, 'estimates_wear': self.params.estimates_wear,
            'warnings': list(self.warnings), **self.extra})

    def summary(self) -> str:
        """Return a plain-text report: the values the set holds, each with where it comes from."""
        nominal = self.nominal
        params = self.params
        unit = params.friction_unit
        lines = [f'identified nominal model (5) on {nominal.n_levels} friction levels '
                 f'({nominal.n_experiments} experiments, {nominal.n_speeds} speeds, '
                 f'T {nominal.temperature_range_degc[0]:.1f}-'
                 f'{nominal.temperature_range_degc[1]:.1f} degC, load '
                 f'{nominal.load_range[0]:.3g}-{nominal.load_range[1]:.3g}); friction in '
                 f'{unit}; the values the set holds:']
        lines += [self._value_line(p.name) for p in nominal.parameters]
        lines += [f'  {term}: not supported by the data (BIC), left out: amplitudes 0'
                  for term in nominal.dropped]
        lines.append(f'  held-out error [mu, sigma] = [{nominal.held_out_mean:.3e}, '
                     f'{nominal.held_out_std:.3e}] {unit} ({nominal.folds})')
        if self.wear is not None:
            wear = self.wear
            lines.append(f'wear model (7) at experiment {wear.critical_experiment} with '
                         f'w = {wear.critical_wear:g} (alpha from (5)):')
            lines += [self._value_line(p.name) for p in wear.parameters if p.name != 'alpha']
            lines.append(f'  wear-model error [mu, sigma] = [{wear.error_mean:.3e}, '
                         f'{wear.error_std:.3e}] over {len(wear.levels)} experiments')
            shown = ', '.join(f'{lv.experiment}: {lv.wear:.1f}' for lv in wear.levels[-8:])
            lines.append(f'  identified w (last {min(8, len(wear.levels))}): {shown}')
        elif not self.params.estimates_wear:
            lines.append('wear model (7): none (--no-wear-model): the set estimates the '
                         'temperature only; w-hat is not determined and raises no alarm')
        else:
            scaling = self.extra.get('wear_model_scaling')
            borrowed = (scaling['assumption'] if scaling else
                        f'from {self.from_params.name} as it stands (no --wear-test)')
            lines.append(f'wear model (7): {borrowed}')
            lines += [self._value_line(name) for name in WEAR_PARAMETERS]
        lines.append(f'sigma of (9b) = {self.sigma:.3e} {unit} ({self.sigma_rule})')
        lines.append(f'load estimate of (14): mean {params.load_mean:.4g}, std '
                     f'{params.load_std:.4g} ({self.provenance.get("load", "")})')
        configurations = self.extra.get('load_configurations') or []
        if len(configurations) > 1:
            named = configurations[0].get('column')
            lines.append((f'  column {named!r} names ' if named else '  the load column has ')
                         + str(len(configurations)) + ' configurations: ' + '; '.join(
                             f"{c['low']:.3g}-{c['high']:.3g} (mean {c['mean']:.3g}, std "
                             f"{c['std']:.3g}, {c['n_levels']} levels)" for c in configurations))
        lines.append(f'operating range: speeds {params.speed_min_rad_s:.4g}-'
                     f'{params.speed_max_rad_s:.4g} rad/s (motor side), separation '
                     f'{params.speed_separation_rad_s:.4g} rad/s; temperature '
                     f'{params.temperature_min_degc:.4g}-{params.temperature_max_degc:.4g} degC')
        lines += [f'warning: {text}' for text in self.warnings]
        return '\n'.join(lines)

    def _value_line(self, name: str) -> str:
        """Return one parameter's line: the set's value, its unit and its provenance."""
        value = getattr(self.params.model, name)
        unit = parameter_unit(name, self.params.friction_unit)
        return f'  {name:<12}{value:>13.5g} [{unit}]  {self.provenance.get(name, "")}'
