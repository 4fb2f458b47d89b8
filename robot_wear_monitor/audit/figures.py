"""
Figures of an audit: residuals against every variable before and after, and the errors.

Matplotlib with the Agg backend (no display needed); small PNGs for documentation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from robot_wear_monitor.atomic_files import save_figure
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.audit.identification_result import Identification
from robot_wear_monitor.audit.result import AuditResult
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.friction import wear_friction


#: Units of the audit's usual variables on a figure's axis (others are the table's own).
_UNITS = {'speed': ' [rad/s]', 'temperature': ' [degC]', 'load': ' [normalised]',
          'wear': ' [-]', 'position': ' [rad]', 'time_s': ' [s]'}


def _pyplot():
    # deferred import: start-up time (matplotlib: only when a figure is drawn)
    import matplotlib
    matplotlib.use('Agg')
    # deferred import: start-up time (matplotlib: only when a figure is drawn)
    import matplotlib.pyplot as plt
    return plt


def plot_audit(*, result: AuditResult, table: AuditTable, out_dir: str | Path,
               prefix: str = 'audit_', dpi: int = 80) -> list[Path]:
    """
    Write ``<prefix>residuals.png`` and ``<prefix>errors.png`` into ``out_dir``.

    :param result: the audit of ``table``.
    :param table: the audited table (after any groups were left out: ``result.n_levels`` rows).
    :param out_dir: folder, created when missing.
    :param prefix: file-name prefix.
    :param dpi: resolution of the PNGs.

    :return: The paths written.

    """
    plt = _pyplot()
    folder = Path(out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    if table.n_rows != result.n_levels:
        table = _matching_rows(table, result)
    names = ['speed'] + [c for c in (*result.candidates, 'temperature', 'load', 'wear')
                         if c in table.columns and c not in ('speed',)]
    names = list(dict.fromkeys(names))
    if result.group and result.group not in names:
        names.append(result.group)
    columns = min(4, len(names))
    rows = int(np.ceil(len(names) / columns))
    figure, axes = plt.subplots(rows, columns, figsize=(3.0 * columns, 2.4 * rows),
                                squeeze=False)
    traced = {v for effect in result.effects for v in effect.variables}
    for axis, name in zip(axes.ravel(), names):
        x, ticks = _axis_values(table, name)
        axis.plot(x, result.residual_before, '.', color='0.65', markersize=3,
                  label='before')
        axis.plot(x, result.residual_after, '.', color='tab:blue', markersize=3,
                  label='after')
        axis.axhline(0.0, color='k', linewidth=0.6)
        axis.set_xlabel(name + _UNITS.get(name, '') + (' (traced)' if name in traced else ''),
                        color='tab:red' if name in traced else 'k')
        if name == 'speed' and np.ptp(np.log(table.numeric['speed'])) > 2:
            axis.set_xscale('log')
        if ticks is not None:
            axis.set_xticks(range(len(ticks)))
            axis.set_xticklabels(ticks, rotation=45, fontsize=7)
        axis.tick_params(labelsize=7)
    for axis in axes.ravel()[len(names):]:
        axis.set_visible(False)
    axes[0, 0].set_ylabel("residual [table's friction unit]")
    axes[0, 0].legend(fontsize=7, markerscale=2)
    figure.suptitle(f'{result.model} model residuals before / after the audit '
                    f'({len(result.effects)} effect(s))', fontsize=9)
    figure.tight_layout()
    residual_path = folder / f'{prefix}residuals.png'
    save_figure(figure, residual_path, dpi=dpi)
    plt.close(figure)

    figure, axis = plt.subplots(figsize=(5.5, 2.8))
    labels = ['model alone'] + [f'+ {i}: ' + ', '.join(e.variables)
                                for i, e in enumerate(result.effects, start=1)]
    values = [result.rms_before] + [e.rms_cv_after for e in result.effects]
    axis.bar(range(len(values)), values, color=['0.6'] + ['tab:blue'] * len(result.effects))
    axis.axhline(result.noise_floor, color='tab:red', linestyle='--',
                 label=f'noise floor ({result.noise_floor_method.split(" (")[0]})')
    axis.set_xticks(range(len(values)))
    axis.set_xticklabels(labels, rotation=20, fontsize=7, ha='right')
    axis.set_ylabel("held-out RMS error [table's friction unit]", fontsize=8)
    axis.tick_params(labelsize=7)
    axis.legend(fontsize=7)
    figure.tight_layout()
    error_path = folder / f'{prefix}errors.png'
    save_figure(figure, error_path, dpi=dpi)
    plt.close(figure)
    return [residual_path, error_path]


def _axis_values(table: AuditTable, name: str) -> tuple[np.ndarray, list | None]:
    """Numeric x values of a column; categories as jittered indices with their labels."""
    if name in table.numeric and len(np.unique(table.numeric[name])) > 8:
        return table.numeric[name], None
    values = table.text[name] if name in table.text else np.array(
        [f'{v:g}' for v in table.numeric[name]])
    labels = sorted(set(values.tolist()))
    index = np.array([labels.index(v) for v in values], dtype=float)
    jitter = np.random.default_rng(0).uniform(-0.2, 0.2, len(index))
    return index + jitter, labels


def _matching_rows(table: AuditTable, result: AuditResult) -> AuditTable:
    """Drop the rows of the groups the audit left out."""
    if not result.group:
        return table
    left_out = {text.split(':')[0].split(' ', 1)[1] for text in result.excluded}
    values = table.text[result.group] if result.group in table.text else np.array(
        [f'{v:g}' for v in table.numeric[result.group]])
    return table.subset(~np.isin(values, list(left_out)))


def plot_identification(*, result: Identification, baseline: AuditTable,
                        wear_test: AuditTable | None = None, out_dir: str | Path,
                        dpi: int = 80) -> list[Path]:
    """
    Write the identification figures into ``out_dir``; return their paths.

    ``identify_residuals.png``: held-out residuals of (5) against speed, temperature and load
    (and the wear-model error against experiment with a wear test), with +- sigma_eps;
    ``identify_wear.png`` (wear test only): the identified w of every experiment and the wear
    profile (6) of the critical experiment with model (7).
    """
    plt = _pyplot()
    folder = Path(out_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f'{folder}: cannot create the figure folder: {error.strerror}') from None
    nominal = result.nominal
    panels = [('speed [rad/s]', baseline.numeric['speed'], nominal.held_out_residual),
              ('temperature [degC]', baseline.numeric['temperature'],
               nominal.held_out_residual),
              ('load [-]', baseline.numeric['load'], nominal.held_out_residual)]
    wear = result.wear
    if wear is not None and wear_test is not None:
        order = {lv.experiment: i for i, lv in enumerate(wear.levels)}
        index = np.array([order[e] for e in wear.experiment], dtype=float)
        panels.append(('experiment (index in time order)', index, wear.residual))
    figure, axes = plt.subplots(1, len(panels), figsize=(2.9 * len(panels), 2.5),
                                squeeze=False)
    for i, (axis, (label, x, residual)) in enumerate(zip(axes[0], panels)):
        axis.plot(x, residual, '.', markersize=2.5,
                  color='tab:orange' if label.startswith('experiment') else 'tab:blue')
        std = (wear.error_std if wear is not None and label.startswith('experiment')
               else nominal.held_out_std)
        for level in (-std, 0.0, std):
            axis.axhline(level, color='k' if level == 0 else '0.5', linewidth=0.6,
                         linestyle='-' if level == 0 else '--')
        if label.startswith('speed') and np.ptp(np.log(x)) > 2:
            axis.set_xscale('log')
        axis.set_xlabel(label, fontsize=8)
        axis.tick_params(labelsize=7)
    axes[0, 0].set_ylabel('held-out residual of (5) [normalised]', fontsize=8)
    if len(panels) == 4:
        axes[0, 3].set_ylabel('error of (7) [normalised]', fontsize=8)
    figure.suptitle(f'{result.params.name}: held-out error [mu, sigma] = '
                    f'[{nominal.held_out_mean:.2e}, {nominal.held_out_std:.2e}]', fontsize=9)
    figure.tight_layout()
    paths = [folder / 'identify_residuals.png']
    save_figure(figure, paths[0], dpi=dpi)
    plt.close(figure)
    if wear is None or wear_test is None:
        return paths
    figure, (left, right) = plt.subplots(1, 2, figsize=(8.0, 2.8))
    w = np.array([lv.wear for lv in wear.levels])
    wear_std = np.array([lv.wear_std for lv in wear.levels])
    positions = np.arange(len(w))
    left.errorbar(positions, w, yerr=np.where(np.isfinite(wear_std), wear_std, 0.0), fmt='.',
                  markersize=3, linewidth=0.7)
    critical = [i for i, lv in enumerate(wear.levels) if lv.experiment == wear.critical_experiment]
    left.plot(critical, [wear.critical_wear], 's', color='tab:red',
              label=f'K = {wear.critical_experiment} (w = {wear.critical_wear:g})')
    left.set_xlabel('experiment (index in time order)', fontsize=8)
    left.set_ylabel('identified w [-]', fontsize=8)
    left.legend(fontsize=7)
    rows = wear.experiment == wear.critical_experiment
    speed = wear_test.numeric['speed'][rows]
    right.plot(speed, wear.profile[rows], 'o', markersize=3, label='wear profile (6)')
    grid = np.linspace(speed.min(), speed.max(), 200)
    right.plot(grid, wear_friction(grid, wear.critical_wear, result.params.model), '-',
               color='tab:red', label='model (7)')
    right.set_xlabel('speed [rad/s]', fontsize=8)
    right.set_ylabel('tau_f - tau_f0 [normalised]', fontsize=8)
    right.legend(fontsize=7)
    for axis in (left, right):
        axis.tick_params(labelsize=7)
    figure.tight_layout()
    paths.append(folder / 'identify_wear.png')
    save_figure(figure, paths[1], dpi=dpi)
    plt.close(figure)
    return paths
