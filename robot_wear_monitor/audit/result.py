"""
The audit's result: the effects it added and the report (JSON and text).

Units: friction in the table's own unit; temperatures [degC].
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Mapping

from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.audit.noise import LackOfFit
from robot_wear_monitor.json_values import json_clean
from robot_wear_monitor.model.extensions import extension_to_mapping
from robot_wear_monitor.model.params import ParameterSet


#: What the audit's friction numbers are in (the table's own unit; nothing converts it).
FRICTION_UNIT_NOTE = ('normalised torque for levels from segment and history; effort / '
                      '--torque-scale for raw runs, N.m with the default 1')


@dataclass(frozen=True)
class Effect:
    """
    An effect the audit traced and added to the model.

    :ivar name: human-readable name of the term (shape and variables).
    :ivar shape: 'linear', 'periodic', 'Stribeck interaction', 'smooth', ... .
    :ivar variables: the table columns it depends on.
    :ivar df: number of parameters the term adds (amplitudes, plus a period or Stribeck speed).
    :ivar log10_p: log10 of the F-test p-value that found it (BH-controlled family).
    :ivar rms_cv_before: held-out RMS error before adding it [friction units].
    :ivar rms_cv_after: held-out RMS error after adding it [friction units].
    :ivar size_rms: RMS over the table of the change of the fitted friction when the term is
        added and everything re-identified [friction units].
    :ivar size_range: max - min of that change [friction units].
    :ivar info: shape constants (period, Stribeck speed).
    :ivar candidate: the candidate family that found it.
    :ivar confounded_with: the other significant candidates that lost their evidence once this
        effect was in the model (each {'candidate', 'log10_p_alone',
        'log10_p_given_chosen'}): named here, not added.

    """

    name: str
    shape: str
    variables: tuple[str, ...]
    df: int
    log10_p: float
    rms_cv_before: float
    rms_cv_after: float
    size_rms: float
    size_range: float
    info: Mapping[str, float]
    candidate: str = ''
    confounded_with: tuple = ()

    @property
    def rms_gain(self) -> float:
        """Reduction of the held-out RMS error the term brings [friction units]."""
        return self.rms_cv_before - self.rms_cv_after

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (finite numbers only)."""
        return {'name': self.name, 'shape': self.shape, 'variables': list(self.variables),
                'df': self.df, 'log10_p': _finite(self.log10_p),
                'rms_cv_before': self.rms_cv_before, 'rms_cv_after': self.rms_cv_after,
                'rms_gain': self.rms_gain,
                'relative_gain': self.rms_gain / self.rms_cv_before
                if self.rms_cv_before > 0 else 0.0,
                'size_rms': self.size_rms, 'size_range': self.size_range,
                'info': {k: float(v) for k, v in self.info.items()},
                'candidate': self.candidate,
                'confounded_with': [dict(c) for c in self.confounded_with]}


@dataclass(frozen=True)
class AuditResult:
    """
    Outcome of :func:`run_audit`.

    :ivar model: 'speed', 'nominal' or 'complete'.
    :ivar n_levels: rows audited.
    :ivar group: column the base model is identified per group of (or None).
    :ivar candidates: the candidate variables examined.
    :ivar rms_before: held-out RMS error of the model alone [friction units].
    :ivar rms_after: held-out RMS error with the effects added.
    :ivar fit_rms_before: in-sample RMS error of the model alone.
    :ivar fit_rms_after: in-sample RMS error with the effects.
    :ivar noise_floor: estimated std of the irreducible level error [friction units].
    :ivar noise_floor_method: how it was estimated (see :func:`noise_floor`).
    :ivar folds: description of the cross-validation folds.
    :ivar effects: the effects added, in order.
    :ivar steps: per step, the best candidates and the decision (for the report).
    :ivar residual_before: in-sample residuals of the model alone, shape (n,).
    :ivar residual_after: in-sample residuals of the extended model, shape (n,).
    :ivar parameters_before: identified base-model parameters without effects.
    :ivar parameters_after: identified base-model parameters with the effects.
    :ivar estimate_changes: how the (T, w) estimates change (None when not applicable).
    :ivar stop_reason: why the loop stopped.
    :ivar excluded: groups left out (too few distinct speeds), with the reason.
    :ivar extended_params: the input parameter set plus the added terms (nominal and complete
        models; None for the speed model), what ``audit --out-params`` writes.
    :ivar offline: variable -> (default, how chosen) for the terms' variables that the service
        does not measure online (evaluated at the default there).
    :ivar parameter_flags: fitted parameters at a bound of the fit (the speed model (4)) or
        with a sign friction cannot have (every model), one sentence each.
    :ivar impossible_values: the fitted terms with a sign friction cannot have (negative
        Coulomb level, Stribeck amplitude or viscous slope, at the data's load and temperature
        for (5) and (8)), one dict each: group, parameter, value, meaning, where.
    :ivar lack_of_fit: the final model against the pure error of replicated conditions (repeated
        runs at the same speed and direction), None without replicates.
    :ivar rms_by_group: group -> (held-out RMS error before, after) when fitted per ``group``.
    :ivar stribeck_dropped: the groups whose Stribeck term the fit before any effect left out
        (BIC), as ``identify --speed-only`` does.
    :ivar friction_unit: the unit of the levels (``audit --friction-unit`` or what the input
        says); '' when not known (the summary then describes the table's unit).

    """

    model: str
    n_levels: int
    group: str | None
    candidates: tuple[str, ...]
    rms_before: float
    rms_after: float
    fit_rms_before: float
    fit_rms_after: float
    noise_floor: float
    noise_floor_method: str
    folds: str
    effects: tuple[Effect, ...]
    steps: tuple[dict, ...]
    residual_before: FloatArray
    residual_after: FloatArray
    parameters_before: dict
    parameters_after: dict
    estimate_changes: dict | None
    stop_reason: str
    excluded: tuple[str, ...] = ()
    extended_params: ParameterSet | None = None
    offline: Mapping[str, tuple] = field(default_factory=dict)
    parameter_flags: tuple[str, ...] = ()
    impossible_values: tuple[Mapping[str, object], ...] = ()
    lack_of_fit: LackOfFit | None = None
    rms_by_group: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    friction_unit: str = ''
    stribeck_dropped: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """Return the JSON report (valid JSON: no NaN or inf)."""
        return json_clean({
            'model': self.model, 'n_levels': self.n_levels, 'group': self.group,
            'candidates': list(self.candidates),
            'rms_before': self.rms_before, 'rms_after': self.rms_after,
            'fit_rms_before': self.fit_rms_before, 'fit_rms_after': self.fit_rms_after,
            'noise_floor': self.noise_floor, 'noise_floor_method': self.noise_floor_method,
            'folds': self.folds, 'effects': [e.to_dict() for e in self.effects],
            'steps': list(self.steps), 'stop_reason': self.stop_reason,
            'parameters_before': self.parameters_before,
            'parameters_after': self.parameters_after,
            'estimate_changes': self.estimate_changes, 'excluded': list(self.excluded),
            'added_terms': self._added_terms(),
            'parameter_flags': list(self.parameter_flags),
            'impossible_values': [dict(v) for v in self.impossible_values],
            'rms_by_group': {k: {'before': b, 'after': a}
                             for k, (b, a) in self.rms_by_group.items()},
            'lack_of_fit': None if self.lack_of_fit is None else self.lack_of_fit.to_dict(),
            'offline_variables': [{'variable': k, 'default': v, 'how': how}
                                  for k, (v, how) in self.offline.items()],
            'friction_unit': self.friction_unit or None,
            'stribeck_dropped_before': list(self.stribeck_dropped)})

    def _added_terms(self) -> dict | None:
        if self.extended_params is None or self.extended_params.model.extension is None:
            return None
        return extension_to_mapping(self.extended_params.model.extension)

    def summary(self) -> str:
        """Return a short plain-text report."""
        lines = [f'audit of the {self.model} model on {self.n_levels} friction levels'
                 + (f' (identified per {self.group})' if self.group else ''),
                 f'  candidates: {", ".join(self.candidates) or "(none)"}',
                 (f'  friction unit [f]: {self.friction_unit}' if self.friction_unit else
                  f"  friction unit [f]: the table's ({FRICTION_UNIT_NOTE})"),
                 f'  held-out RMS error before: {self.rms_before:.4g} [f]',
                 f'  held-out RMS error after:  {self.rms_after:.4g} [f]',
                 f'  noise floor: {self.noise_floor:.4g} [f] ({self.noise_floor_method})',
                 f'  folds: {self.folds}']
        for key, (before, after) in self.rms_by_group.items():
            lines.append(f'  held-out RMS error of {self.group} {key}: {before:.4g} -> '
                         f'{after:.4g} [f]')
        if self.lack_of_fit is not None:
            lines.append(f'  replicates: {self.lack_of_fit.statement()}')
        lines += [f'  left out: {text}' for text in self.excluded]
        if not self.effects:
            lines.append('  no effect added')
        for i, effect in enumerate(self.effects, start=1):
            lines.append(f'  effect {i}: {effect.name} [{", ".join(effect.variables)}], '
                         f'size {effect.size_rms:.3g} [f] rms, held-out error '
                         f'{effect.rms_cv_before:.4g} -> {effect.rms_cv_after:.4g} [f] '
                         f'(log10 p {effect.log10_p:.1f})')
            for other in effect.confounded_with:
                lines.append(f'    confounded with {other["candidate"]} (not added: no evidence '
                             f'of its own given this effect)')
        lines += [f'  directions: {step["decision"]}' for step in self.steps
                  if step.get('tried') == 'model (4) per direction' and 'preferred' in step]
        lines.append(f'  stopped: {self.stop_reason}')
        lines += _parameter_lines(self.parameters_after)
        lines += [f'  FLAG: {flag}' for flag in self.parameter_flags]
        for name, (value, how) in self.offline.items():
            lines.append(f'  not measured online: {name}, evaluated at {value!r} ({how}) by '
                         'the extended parameter set')
        if self.estimate_changes:
            for key, value in self.estimate_changes.items():
                if isinstance(value, bool):
                    continue
                if isinstance(value, (int, float)):
                    lines.append(f'  {key}: {value:.4g}')
                elif isinstance(value, str):
                    lines.append(f'  {key}: {value}')
        return '\n'.join(lines)


def _parameter_lines(parameters: Mapping) -> list[str]:
    """Return the fitted parameters as text: one line per group (or one for the model)."""
    def values(mapping: Mapping) -> str:
        return ', '.join(f'{name} {value:.4g}' for name, value in mapping.items()
                         if isinstance(value, (int, float)))
    if parameters and all(isinstance(v, Mapping) for v in parameters.values()):
        return [f'  fitted ({key}): {values(group)}' for key, group in parameters.items()]
    text = values(parameters)
    return [f'  fitted: {text}'] if text else []


def _finite(value: float) -> float:
    return float(value) if math.isfinite(value) else (-1e300 if value < 0 else 1e300)
