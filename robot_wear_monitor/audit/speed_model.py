"""The speed-only friction model (4) identified from levels without temperature or load.

:func:`identify_speed_model` fits (4) per group (e.g. per joint) with the shared variable
projection core, with standard errors and the held-out error by experiment.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
from numpy.typing import NDArray

from robot_wear_monitor.audit.cross_validation import cv_rms, fold_indices
from robot_wear_monitor.audit.fitting import (as_text, AuditTable, multistart_fit,
                                              parameter_errors, speed_base)
from robot_wear_monitor.audit.identification_result import Parameter
from robot_wear_monitor.json_values import json_clean

FloatArray = NDArray[np.float64]


# --------------------------------------------------------------------------- model (4)

@dataclass(frozen=True)
class SpeedIdentification:
    """The speed-only model (4) identified per group.

    Attributes:
        groups: group -> {F_c, F_s, phi_s, alpha, F_v: :class:`Parameter`}.
        held_out_mean: mean of the held-out error [friction units].
        held_out_std: its std [friction units].
        folds: how the levels were split.
        fit_rms: in-sample RMS error.
        n_levels: levels used.
        excluded: groups left out (fewer than six distinct speeds), with the reason.

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
    """Identify the speed model (4) per value of ``group`` with standard errors.

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
