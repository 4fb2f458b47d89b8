"""
The speed-only friction model (4) identified from levels without temperature or load.

:func:`identify_speed_model` fits (4) per group (e.g. per joint) with the shared variable
projection core, with standard errors and the held-out error by experiment;
:func:`speed_only_parameter_set` makes a parameter set of it for levels that vary in speed
only (the set says that temperature, load and wear were not identified).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import math
from typing import Mapping, Optional

import numpy as np
from robot_wear_monitor.audit.cross_validation import cv_rms, fold_indices
from robot_wear_monitor.audit.fitting import (as_text, AuditTable, multistart_fit,
                                              parameter_errors, speed_base)
from robot_wear_monitor.audit.identification_result import Parameter
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
    """
    Identify the speed model (4) per value of ``group`` with standard errors.

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


#: Significance level at which the directions of motion are said to differ.
DIRECTION_ALPHA = 0.01


@dataclass(frozen=True)
class DirectionTest:
    """
    Does model (4) differ per direction?  An F-test of 10 against 5 parameters.

    :ivar f_statistic: ((RSS_symmetric - RSS_per_direction) / 5) / (RSS_per_direction / (n - 10)).
    :ivar p_value: its upper tail probability.
    :ivar differ: p_value < :data:`DIRECTION_ALPHA`: the set holds the per-direction model.

    """

    f_statistic: float
    p_value: float
    differ: bool

    def text(self) -> str:
        """Return the test in words."""
        verdict = ('the directions differ: the set holds model (4) per direction '
                   '(direction_model) beside the symmetric fit of eq. (3)' if self.differ
                   else 'no difference between the directions: one symmetric model')
        return (f'direction test: F = {self.f_statistic:.3g}, p = {self.p_value:.2g} '
                f'(level {DIRECTION_ALPHA:g}): {verdict}')


def direction_test(symmetric: SpeedIdentification,
                   per_direction: SpeedIdentification) -> DirectionTest:
    """Return the F-test of the per-direction fit of model (4) against the symmetric fit."""
    from scipy import stats
    n = symmetric.n_levels
    rss_symmetric = symmetric.fit_rms ** 2 * n
    rss_directions = per_direction.fit_rms ** 2 * n
    dof = n - 10
    if dof <= 0 or not rss_directions > 0:
        return DirectionTest(math.nan, math.nan, False)
    f_statistic = max(rss_symmetric - rss_directions, 0.0) / 5 / (rss_directions / dof)
    p_value = float(stats.f.sf(f_statistic, 5, dof))
    return DirectionTest(float(f_statistic), p_value, p_value < DIRECTION_ALPHA)


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
    :ivar direction_test: the F-test of the per-direction fit against the symmetric one; when
        it is significant the set holds model (4) per direction (``direction_model``)
        beside the symmetric fit (the eq. (3) levels' model).

    """

    params: ParameterSet
    fit: SpeedIdentification
    per_direction: Optional[SpeedIdentification]
    direction_test: Optional[DirectionTest] = None

    def summary(self) -> str:
        """Return the report: the fitted terms with standard errors, what is not identified."""
        lines = [f'identified the speed model (4) on {self.fit.n_levels} friction levels '
                 f'(no temperature or load variation: {self.params.friction_unit})']
        for label, fit in (('all levels', self.fit), ('per direction', self.per_direction)):
            if fit is None:
                continue
            for group, values in fit.groups.items():
                shown = group if label == 'per direction' else label
                lines.append(f'  {shown}: ' + ', '.join(
                    f'{p.name} {p.value:.4g} +- {p.std_error:.2g}' for p in values.values()))
        if self.direction_test is not None:
            lines.append(f'  {self.direction_test.text()}')
        lines.append(f'  held-out error [mu, sigma] = [{self.fit.held_out_mean:.3e}, '
                     f'{self.fit.held_out_std:.3e}] ({self.fit.folds})')
        lines += [f'  warning: {w}' for w in self.fit.warnings]
        lines.append(f'  not identified: {", ".join(self.params.not_identified)}: the set '
                     'refuses to estimate wear and temperature and to design an experiment; '
                     'give levels that vary them (and a wear test) for a complete set')
        return '\n'.join(lines)

    def to_dict(self) -> dict:
        """Return the JSON report."""
        return json_clean({'kind': 'speed_only', 'fit': self.fit.to_dict(),
                           'per_direction': None if self.per_direction is None
                           else self.per_direction.to_dict(),
                           'direction_test': None if self.direction_test is None else {
                               'f_statistic': self.direction_test.f_statistic,
                               'p_value': self.direction_test.p_value,
                               'differ': self.direction_test.differ,
                               'level': DIRECTION_ALPHA},
                           'not_identified': list(self.params.not_identified),
                           'friction_unit': self.params.friction_unit,
                           'name': self.params.name})


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
            tested = direction_test(fit, per_direction)
            if tested.differ:
                directions = (_terms(per_direction.groups['positive']),
                              _terms(per_direction.groups['negative']))
    values = {k: p.value for k, p in fit.groups['all'].items()}
    model = replace(from_params.model, f_c0=values['F_c'], f_c_load=0.0, f_s0=values['F_s'],
                    f_s_load=0.0, f_s_temp=0.0, f_v0=values['F_v'], f_v_temp=0.0,
                    phi_s0=values['phi_s'], phi_s_temp=0.0, alpha=values['alpha'],
                    extension=None)
    speed = table.numeric['speed']
    # the noise of a level: of one direction's model when the directions differ (the
    # symmetric fit's error would hold the difference between the directions)
    noise = (per_direction.held_out_std if directions is not None and per_direction
             is not None else fit.held_out_std)
    params = from_params.with_overrides(
        name=name.strip(), model=model, sigma=max(noise, SIGMA_MIN),
        speed_min_rad_s=float(speed.min()), speed_max_rad_s=float(speed.max()),
        speed_separation_rad_s=0.0,
        not_identified=('temperature', 'load', 'wear'), friction_unit=friction_unit,
        direction_model=directions, source=f'identify {table.source}')
    return SpeedOnlySet(params=params, fit=fit, per_direction=per_direction,
                        direction_test=tested)
