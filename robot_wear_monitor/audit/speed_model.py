"""
The speed-only friction model (4) identified from levels without temperature or load.

:func:`identify_speed_model` fits (4) per group (e.g. per joint) with the shared variable
projection core, with standard errors and the held-out error by experiment;
:func:`speed_only_parameter_set` makes a parameter set of it for levels that vary in speed
only (the set says that temperature, load and wear were not identified).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
import math
from typing import Mapping, Optional

import numpy as np
from robot_wear_monitor.audit.cross_validation import cv_rms, fold_indices
from robot_wear_monitor.audit.fitting import as_text, AuditTable
from robot_wear_monitor.audit.identification_result import Parameter
from robot_wear_monitor.audit.parameter_errors import parameter_errors
from robot_wear_monitor.audit.speed_fit import fit_speed_model
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.json_values import json_clean
from robot_wear_monitor.model.params import DirectionTerms, ParameterSet, SIGMA_MIN


# --------------------------------------------------------------------------- model (4)

@dataclass(frozen=True)
class SpeedIdentification:
    """
    The speed-only model (4) identified per group.

    :ivar groups: group -> {F_c, F_s, phi_s, alpha, F_v: :class:`Parameter`}.
    :ivar held_out_mean: mean of the held-out error [friction units].
    :ivar held_out_std: its std [friction units].
    :ivar folds: how the levels were split.
    :ivar fit_rms: in-sample RMS error.
    :ivar n_levels: levels used.
    :ivar excluded: groups left out (fewer than six distinct speeds), with the reason.
    :ivar dropped: groups whose Stribeck term the data do not support (BIC): F_s = 0, phi_s
        and alpha undetermined.
    :ivar held_out_rms: RMS of the held-out error [friction units] (the audit's figure).

    """

    groups: Mapping[str, Mapping[str, Parameter]]
    held_out_mean: float
    held_out_std: float
    folds: str
    fit_rms: float
    n_levels: int
    excluded: tuple[str, ...] = ()
    dropped: tuple[str, ...] = ()
    held_out_rms: float = math.nan

    @property
    def warnings(self) -> tuple[str, ...]:
        """Return the parameters the data do not determine well, naming what to measure."""
        out = []
        for group, values in self.groups.items():
            if group in self.dropped:
                out.append(f'{group}: the data do not support a Stribeck term (BIC): left out, '
                           'F_s = 0, phi_s and alpha undetermined')
            for p in values.values():
                if group in self.dropped and p.name in ('F_s', 'phi_s', 'alpha'):
                    continue
                where = ('at the high end' if p.name == 'F_v'
                         else 'below and around the Stribeck speed')
                if not p.std_error <= abs(p.value) and not (p.at_bound and p.value == 0):
                    out.append(f'{group} {p.name} = {p.value:.3g} has a standard error '
                               f'{p.std_error:.2g} larger than its value: measure more speeds '
                               f'{where}')
                elif p.at_bound:
                    domain = f' ({p.name} >= 0)' if p.value == 0 else ''
                    out.append(f'{group} {p.name} = {p.value:.3g} is on its bound{domain}: '
                               'the data pull it beyond')
        return tuple(out)

    def to_dict(self) -> dict:
        """Return a JSON-ready dict."""
        return json_clean({'groups': {g: {k: p.to_dict() for k, p in values.items()}
                                      for g, values in self.groups.items()},
                           'warnings': list(self.warnings),
                           'held_out_error': {'mean': self.held_out_mean, 'std': self.held_out_std,
                                              'rms': self.held_out_rms, 'folds': self.folds},
                           'stribeck_dropped': list(self.dropped),
                           'fit_rms': self.fit_rms, 'n_levels': self.n_levels,
                           'excluded': list(self.excluded)})


def identify_speed_model(*, table: AuditTable, group: str | None = None, n_folds: int = 5,
                         seed: int = 0) -> SpeedIdentification:
    """
    Identify the speed model (4) per value of ``group`` with standard errors.

    As in the paper, F_c, F_s, F_v, phi_s, alpha >= 0 (amplitudes by non-negative least squares
    inside the variable projection; an amplitude at 0 is flagged ``at_bound``).  Groups with
    fewer than six distinct speeds are left out (reported in ``excluded``).  The friction unit
    is the table's (N.m for the KUKA iiwa levels); speeds in the table's unit.
    """
    # deferred import: start-up time (audit.run: scipy.stats, scipy.ndimage)
    from robot_wear_monitor.audit.run import enough_speeds

    table, excluded = enough_speeds(table, group, 'speed')
    keys = (sorted(set(as_text(table, group).tolist())) if group is not None else ['all'])
    units = {'F_c': 'friction', 'F_s': 'friction', 'phi_s': 'speed', 'alpha': '-',
             'F_v': 'friction/speed'}
    groups: dict[str, dict[str, Parameter]] = {}
    held_out = np.zeros(table.n_rows)
    residual = np.zeros(table.n_rows)
    fold_text = ''
    dropped = []
    for key in keys:
        rows = (as_text(table, group) == key) if group is not None else np.ones(
            table.n_rows, dtype=bool)
        sub = table.subset(rows)
        fitted = fit_speed_model(sub, None)  # the audit's fitter: one model (4)
        errors = parameter_errors(fitted.base, sub, fitted.fit, nonnegative=True)
        for name, (value, error, at_bound) in errors.items():
            parameter = name.rpartition('.')[2]
            if fitted.dropped and parameter in ('F_s', 'phi_s', 'alpha'):
                error, at_bound = (0.0 if parameter == 'F_s' else math.inf), False
            groups.setdefault(key, {})[parameter] = Parameter(parameter, value, error,
                                                              units[parameter], at_bound)
        if fitted.dropped:
            dropped.append(key)
        folds, fold_text = fold_indices(sub, n_folds, seed)
        _, held_out[rows] = cv_rms(fitted.base, sub, [], fitted.fit.theta, folds,
                                   nonnegative=True)
        residual[rows] = fitted.fit.residual
    return SpeedIdentification(groups=groups, held_out_mean=float(np.mean(held_out)),
                               held_out_std=float(np.std(held_out, ddof=1)),
                               folds=fold_text + (f' within each {group}' if group else ''),
                               fit_rms=float(np.sqrt(np.mean(residual ** 2))),
                               n_levels=table.n_rows, excluded=excluded,
                               dropped=tuple(dropped),
                               held_out_rms=float(np.sqrt(np.mean(held_out ** 2))))


#: Significance level at which the directions of motion are said to differ.
DIRECTION_ALPHA = 0.01
#: Relative gain of the held-out error a direction model needs over the simpler candidates
#: (the audit's default ``--min-gain``).
DIRECTION_MIN_GAIN = 0.01


@dataclass(frozen=True)
class DirectionTest:
    """
    Does model (4) differ per direction?  An F-test of 10 against 5 parameters, held out.

    :ivar f_statistic: ((RSS_symmetric - RSS_per_direction) / 5) / (RSS_per_direction / (n - 10)).
    :ivar p_value: its upper tail probability.
    :ivar differ: the per-direction model is taken: p_value < :data:`DIRECTION_ALPHA` and its
        held-out error beats the simpler candidates' (as the audit decides).
    :ivar preferred: the candidate preferred (the per-direction model, one offset per
        direction, or the common model).
    :ivar reason: why, in words.
    :ivar held_out: candidate -> held-out RMS error [friction units].
    :ivar offset: the offset of the negative direction's level when it is preferred (else 0).

    """

    f_statistic: float
    p_value: float
    differ: bool
    preferred: str = ''
    reason: str = ''
    held_out: Mapping[str, float] = field(default_factory=dict)
    offset: float = 0.0

    def text(self) -> str:
        """Return the test in words."""
        verdict = ('the directions differ: the set holds model (4) per direction '
                   '(direction_model) beside the symmetric fit of eq. (3)' if self.differ
                   else f'the directions differ by an offset of {self.offset:.4g}: the set '
                   'holds it in direction_model' if self.offset != 0 else
                   'no difference between the directions: one symmetric model')
        return (f'direction test: F = {self.f_statistic:.3g}, p = {self.p_value:.2g} '
                f'(level {DIRECTION_ALPHA:g}): {verdict} ({self.reason})')

    def to_dict(self) -> dict:
        """Return a JSON-ready dict."""
        return json_clean({'f_statistic': self.f_statistic, 'p_value': self.p_value,
                           'differ': self.differ, 'level': DIRECTION_ALPHA,
                           'preferred': self.preferred, 'reason': self.reason,
                           'held_out_rms': dict(self.held_out), 'offset': self.offset})


def direction_test(table: AuditTable, *, n_folds: int = 5, seed: int = 0) -> DirectionTest:
    """
    Return the verdict on the directions of a table with both (the audit's rule).

    Model (4) per direction is compared with the common model and with one offset per
    direction, held out over the audit's folds
    (:func:`~robot_wear_monitor.audit.directions.compare_directions`).
    """
    # deferred import: start-up time (audit.directions: the direction test only)
    from robot_wear_monitor.audit.directions import (compare_directions, PER_DIRECTION,
                                                     with_direction_groups)
    grouped = with_direction_groups(table, None)
    assert grouped is not None, 'direction_test needs both directions'
    common = fit_speed_model(grouped, None)
    folds, _ = fold_indices(grouped, n_folds, seed)
    cv_now, _ = cv_rms(common.base, grouped, [], common.fit.theta, folds, nonnegative=True)
    verdict = compare_directions(grouped, group=None, fit=common.fit, terms=(),
                                 cv_now=cv_now, folds=folds, n_common_groups=1,
                                 level=DIRECTION_ALPHA, min_gain=DIRECTION_MIN_GAIN)
    offset = 0.0
    if verdict.offset is not None and verdict.offset_fit is not None and \
            verdict.preferred == verdict.offset.name:
        offset = float(verdict.offset_fit.fit.coef[-1])
    p_value = 10.0 ** verdict.trial.log10_p if math.isfinite(verdict.trial.log10_p) \
        else math.nan
    held_out = dict(verdict.rivals)
    held_out[PER_DIRECTION] = verdict.trial.cv
    return DirectionTest(verdict.trial.f_statistic, p_value, verdict.per_direction,
                         verdict.preferred, verdict.reason, held_out, offset)


@dataclass(frozen=True)
class SpeedOnlySet:
    """
    A parameter set from levels without temperature or load variation (model (4) only).

    :ivar params: the set: model (4) as the nominal model at the data's conditions (the
        temperature and load terms zero), the wear model borrowed, sigma = the held-out
        std; ``not_identified`` temperature, load and wear.
    :ivar fit: the symmetric fit (all levels) with standard errors.
    :ivar per_direction: the fit per direction when the levels have a ``direction`` group with
        both directions (None otherwise).
    :ivar direction_test: the verdict on the directions (F-test and held-out error against
        the simpler candidates); when the per-direction model is taken the set holds model
        (4) per direction (``direction_model``) beside the symmetric fit (the eq. (3) levels'
        model).
    :ivar sigma_source: which held-out error the set's sigma is.

    """

    params: ParameterSet
    fit: SpeedIdentification
    per_direction: Optional[SpeedIdentification]
    direction_test: Optional[DirectionTest] = None
    sigma_source: str = ''

    def summary(self) -> str:
        """
        Return the report: the fitted terms with standard errors, what is not identified.

        Parameter lines as ``identify`` prints them (``NAME VALUE [unit]  identified, +- SE``),
        a value on its bound said so; the warnings and the set's sigma as the JSON holds them.
        """
        unit = self.params.friction_unit
        lines = [f'identified the speed model (4) on {self.fit.n_levels} friction levels '
                 f'(no temperature or load variation: {unit})']
        for label, fit in (('all levels', self.fit), ('per direction', self.per_direction)):
            if fit is None:
                continue
            for group, values in fit.groups.items():
                shown = group if label == 'per direction' else label
                lines.append(f'  {shown}:')
                lines += [_parameter_line(p, unit, group in fit.dropped)
                          for p in values.values()]
        if self.direction_test is not None:
            lines.append(f'  {self.direction_test.text()}')
        lines.append(f'  held-out error [mu, sigma] = [{self.fit.held_out_mean:.3e}, '
                     f'{self.fit.held_out_std:.3e}] {unit} of the symmetric fit '
                     f'({self.fit.folds})')
        lines.append(f'  sigma of (9b) = {self.params.sigma:.3e} {unit} ({self.sigma_source})')
        warnings = list(self.fit.warnings)
        if self.per_direction is not None and self.direction_test is not None and \
                self.direction_test.differ:
            warnings += list(self.per_direction.warnings)
        lines += [f'  warning: {w}' for w in warnings]
        lines.append(f'  not identified: {", ".join(self.params.not_identified)}: the set '
                     'refuses to estimate wear and temperature and to design an experiment; '
                     'give levels that vary them (and a wear test) for a complete set')
        return '\n'.join(lines)

    def to_dict(self) -> dict:
        """Return the JSON report."""
        return json_clean({'kind': 'speed_only', 'fit': self.fit.to_dict(),
                           'per_direction': None if self.per_direction is None
                           else self.per_direction.to_dict(),
                           'direction_test': None if self.direction_test is None
                           else self.direction_test.to_dict(),
                           'sigma': self.params.sigma, 'sigma_source': self.sigma_source,
                           'not_identified': list(self.params.not_identified),
                           'friction_unit': self.params.friction_unit,
                           'name': self.params.name})


#: The unit of each parameter of model (4) given the friction unit.
_SPEED_UNITS = {'F_c': '{f}', 'F_s': '{f}', 'phi_s': 'rad/s', 'alpha': '-',
                'F_v': '{f}/(rad/s)'}


def _parameter_line(p: Parameter, friction_unit: str, dropped: bool) -> str:
    """Return one parameter's line as ``identify`` prints them: name, value, unit, provenance."""
    unit = _SPEED_UNITS[p.name].format(f='-' if friction_unit == 'normalised'
                                       else friction_unit)
    if dropped and p.name == 'F_s':
        text = 'left out: the data do not support its Stribeck term (BIC)'
    elif dropped and p.name in ('phi_s', 'alpha'):
        text = 'undetermined: its Stribeck term is left out (BIC)'
    else:
        text = ('identified, +- ' + f'{p.std_error:.2e}' if math.isfinite(p.std_error)
                else 'identified, standard error undetermined (the data do not determine it)')
        if p.at_bound:
            text += (f', on its bound ({p.name} >= 0)' if p.value == 0 and p.name in
                     ('F_c', 'F_s', 'F_v') else ', on its bound')
    return f'    {p.name:<12}{p.value:>13.5g} [{unit}]  {text}'


def _terms(group: Mapping[str, Parameter]) -> DirectionTerms:
    """Return the fitted model (4) of one direction as the parameter set's terms."""
    return DirectionTerms(f_c=group['F_c'].value, f_s=group['F_s'].value,
                          phi_s=group['phi_s'].value, alpha=group['alpha'].value,
                          f_v=group['F_v'].value)


def speed_only_parameter_set(*, table: AuditTable, from_params: ParameterSet, name: str,
                             friction_unit: str, n_folds: int = 5) -> SpeedOnlySet:
    """
    Identify model (4) with standard errors and write it as a (speed-only) parameter set.

    The nominal model (5) at the data's conditions is model (4): f_c0 = F_c, f_s0 = F_s,
    phi_s0 = phi_s, f_v0 = F_v, alpha, with the load and temperature terms zero.  The speed
    range of the set is the data's; the wear model, the load estimate, the temperature bounds
    and the alarm come from ``from_params`` and are marked not identified where they matter.
    The fitter, the held-out error and the direction verdict are the audit's.
    """
    if not name or not name.strip():
        raise InputError('--name must not be empty')
    fit = identify_speed_model(table=table, group=None, n_folds=n_folds)
    if 'all' not in fit.groups:
        raise InputError(f'{table.source}: the speed model (4) needs 6 or more distinct speeds')
    per_direction: Optional[SpeedIdentification] = None
    tested: Optional[DirectionTest] = None
    directions: Optional[tuple[DirectionTerms, DirectionTerms]] = None
    if 'direction' in table.text and \
            set(table.text['direction'].tolist()) == {'positive', 'negative'}:
        per_direction = identify_speed_model(table=table, group='direction', n_folds=n_folds)
        if set(per_direction.groups) == {'positive', 'negative'}:
            tested = direction_test(table, n_folds=n_folds)
            if tested.differ:
                directions = (_terms(per_direction.groups['positive']),
                              _terms(per_direction.groups['negative']))
            elif tested.offset != 0.0:
                common = _terms(fit.groups['all'])
                directions = (common, replace(common, f_c=common.f_c + tested.offset))
    values = {k: p.value for k, p in fit.groups['all'].items()}
    model = replace(from_params.model, f_c0=values['F_c'], f_c_load=0.0, f_s0=values['F_s'],
                    f_s_load=0.0, f_s_temp=0.0, f_v0=values['F_v'], f_v_temp=0.0,
                    phi_s0=values['phi_s'], phi_s_temp=0.0, alpha=values['alpha'],
                    extension=None)
    speed = table.numeric['speed']
    # the noise of a level: of one direction's model when the directions differ (the
    # symmetric fit's error would hold the difference between the directions)
    if directions is not None and per_direction is not None and tested is not None \
            and tested.differ:
        noise, source = per_direction.held_out_std, ('the held-out std of model (4) per '
                                                     'direction')
    else:
        noise, source = fit.held_out_std, 'the held-out std of the symmetric fit'
    if noise < SIGMA_MIN:
        source += f', raised to the floor {SIGMA_MIN:g}'
    params = from_params.with_overrides(
        name=name.strip(), model=model, sigma=max(noise, SIGMA_MIN),
        speed_min_rad_s=float(speed.min()), speed_max_rad_s=float(speed.max()),
        speed_separation_rad_s=0.0,
        not_identified=('temperature', 'load', 'wear'), friction_unit=friction_unit,
        direction_model=directions, source=f'identify {table.source}')
    return SpeedOnlySet(params=params, fit=fit, per_direction=per_direction,
                        direction_test=tested, sigma_source=source)
