"""
Figures and the Markdown report of a replay: wear trend like the paper's Fig. 11, friction.

:func:`plot_wear_trend` draws w-hat with its 95 % interval band, the filtered trend with its
interval, the threshold, the truth when known (simulated bags) with the region where detection
is due shaded, and the alarm; a second panel shows T-hat against the true temperature;
:func:`plot_replay` draws it for each joint of a replay with estimates.
:func:`plot_friction_curves` draws the friction levels of every experiment against speed,
coloured by experiment (like Fig. 2(b)), over the model at w = 0 and at the threshold.
:func:`write_report` writes ``report.md`` with a table.
"""

from __future__ import annotations

from dataclasses import replace
import math
import os
from pathlib import Path
from typing import Any, Optional

import numpy as np
from robot_wear_monitor.atomic_files import save_figure, write_text_atomic
from robot_wear_monitor.model.params import ParameterSet


def _pyplot():
    # deferred import: start-up time (matplotlib: only when a figure is drawn)
    import matplotlib
    matplotlib.use('Agg')
    # deferred import: start-up time (matplotlib: only when a figure is drawn)
    import matplotlib.pyplot as plt
    return plt


def _arrays(result: Any) -> dict[str, np.ndarray]:
    updates = result.updates
    truth = [result.truth_for(u) for u in updates]
    return {
        'index': np.array([u.index for u in updates], dtype=float),
        'wear': np.array([u.wear for u in updates], dtype=float),
        'wear_std': np.array([u.wear_std for u in updates], dtype=float),
        'wear_low': np.array([u.wear_interval[0] for u in updates], dtype=float),
        'wear_high': np.array([u.wear_interval[1] for u in updates], dtype=float),
        'trend': np.array([np.nan if u.trend is None else u.trend.wear for u in updates],
                          dtype=float),
        'trend_low': np.array([np.nan if u.trend is None else u.trend.wear_low
                               for u in updates], dtype=float),
        'trend_high': np.array([np.nan if u.trend is None else u.trend.wear_high
                                for u in updates], dtype=float),
        'temperature': np.array([u.temperature_degc for u in updates], dtype=float),
        'temperature_std': np.array([u.temperature_std_degc for u in updates], dtype=float),
        'alarm': np.array([u.alarm_active for u in updates], dtype=bool),
        'true_wear': np.array([t.wear if t else np.nan for t in truth], dtype=float),
        'true_temperature': np.array([t.temperature_degc if t else np.nan for t in truth],
                                     dtype=float),
    }


def plot_wear_trend(result: Any, path: str | os.PathLike, *, threshold: float,
                    title: str = 'Wear estimate') -> Path:
    """
    Draw w-hat with its 95 % interval, the trend with its interval, truth, alarm; save a PNG.

    The bands are the profile-likelihood intervals of each estimate and the trend's posterior
    interval (never +-2 std, which is meaningless near w = 0).
    """
    plt = _pyplot()
    data = _arrays(result)
    k = data['index']
    fig, (ax, ax_t) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True,
                                   gridspec_kw={'height_ratios': [2.2, 1]})
    top_data = np.nanmax(np.concatenate([data['wear'], data['true_wear'], [threshold]])) \
        if k.size else threshold
    top = 1.25 * max(top_data, threshold)
    if k.size:
        ax.fill_between(k, np.clip(data['wear_low'], 0, top), np.clip(data['wear_high'], 0, top),
                        color='tab:blue', alpha=0.15, linewidth=0,
                        label='w-hat 95 % interval (profile likelihood)')
        ax.plot(k, data['wear'], '.', color='tab:blue', ms=4, label='w-hat per experiment')
    if np.any(np.isfinite(data['trend'])):
        ax.fill_between(k, np.clip(data['trend_low'], 0, top),
                        np.clip(data['trend_high'], 0, top), color='tab:green', alpha=0.25,
                        linewidth=0, label='trend 95 % interval')
        ax.plot(k, data['trend'], '-', color='tab:green', lw=1.8, label='wear trend')
    if np.any(np.isfinite(data['true_wear'])):
        ax.plot(k, data['true_wear'], color='black', lw=1.5, label='true w (simulation)')
        due = data['true_wear'] >= threshold
        if np.any(due):
            ax.axvspan(k[np.argmax(due)] - 0.5, k[-1] + 0.5, color='tab:red', alpha=0.08,
                       label='detection due (true w >= threshold)')
    ax.axhline(threshold, color='tab:red', ls='--', lw=1.2, label=f'threshold w = {threshold:g}')
    first = result.first_alarm
    if first is not None:
        ax.axvline(first.index, color='tab:red', lw=1.5)
        ax.annotate(f'alarm (experiment {first.index})', (first.index, threshold),
                    xytext=(-150, 25), textcoords='offset points', color='tab:red',
                    arrowprops={'arrowstyle': '->', 'color': 'tab:red'})
    ax.set_ylim(0, top)
    ax.set_ylabel('wear w [-]')
    ax.set_title(title)
    ax.legend(loc='upper left', fontsize=8)
    ax.grid(alpha=0.3)
    if k.size:
        ax_t.plot(k, data['temperature'], '.-', color='tab:orange', lw=1, ms=3, label='T-hat')
    if np.any(np.isfinite(data['true_temperature'])):
        ax_t.plot(k, data['true_temperature'], color='black', lw=1, label='true T')
    ax_t.set_ylabel('T [degC]')
    ax_t.set_xlabel('experiment [index in time order]')
    ax_t.legend(loc='upper left', fontsize=8)
    ax_t.grid(alpha=0.3)
    return _save(plt, fig, path)


def plot_friction_curves(result: Any, path: str | os.PathLike, *, params: ParameterSet,
                         threshold: float) -> Path:
    """Draw the friction levels of every experiment against speed and the model; save a PNG."""
    # deferred import: start-up time (model.friction: the friction plot only)
    from robot_wear_monitor.model.friction import friction
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    updates = result.updates
    cmap = plt.get_cmap('viridis')
    for i, update in enumerate(updates):
        colour = cmap(i / max(1, len(updates) - 1))
        order = np.argsort(update.speeds_rad_s)
        ax.plot(np.asarray(update.speeds_rad_s)[order], np.asarray(update.frictions)[order],
                '.-', color=colour, lw=0.6, ms=3, alpha=0.8)
    speeds = np.linspace(1.0, max([max(u.speeds_rad_s) for u in updates] + [45.0]) * 1.05, 200)
    temperature = 0.5 * (params.temperature_min_degc + params.temperature_max_degc)
    for wear, style in ((0.0, ':'), (threshold, '--')):
        ax.plot(speeds, friction(speeds, params.load_mean, temperature, wear, params.model),
                style, color='black', lw=1.2,
                label=f'model, w = {wear:g}, T = {temperature:g} degC, load {params.load_mean:g}')
    mappable = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(
        1, max(1, len(updates))))
    fig.colorbar(mappable, ax=ax, label='experiment')
    ax.set_xlabel('motor-side speed [rad/s]')
    ax.set_ylabel('friction level tau_f [normalised]')
    ax.set_title('Friction levels of every experiment')
    ax.legend(loc='upper right', fontsize=8)
    ax.grid(alpha=0.3)
    return _save(plt, fig, path)


def _save(plt: Any, fig: Any, path: str | os.PathLike) -> Path:
    """Lay out ``fig``, save it as a PNG at ``path`` and close it."""
    fig.tight_layout()
    target = Path(path)
    save_figure(fig, target, dpi=110)
    plt.close(fig)
    return target


def _cell(value: Optional[float], digits: int = 1) -> str:
    if value is None or not math.isfinite(value):
        return '-'
    return f'{value:.{digits}f}'


def _trend_cell(trend: Any) -> str:
    if trend is None:
        return '-'
    return f'{_cell(trend.wear)} ({_cell(trend.wear_low)}-{_cell(trend.wear_high)})'


def _trend_text(update: Any) -> str:
    trend = update.trend
    if trend is None:
        return ''
    return (f', trend {trend.wear:.1f} (95 % {trend.wear_low:.1f}-{trend.wear_high:.1f}), '
            f'P(w >= threshold) = {trend.probability_above_threshold:.0%}')


def _forecast_sentence(trend: Any) -> str:
    """Return a sentence on the trend and the forecast crossing of the threshold."""
    text = (f'wear trend {trend.wear:.1f} (95 % {trend.wear_low:.1f}-{trend.wear_high:.1f}), '
            f'P(w >= {trend.threshold:g}) = {trend.probability_above_threshold:.0%}')
    remaining = trend.remaining_experiments
    if trend.probability_above_threshold >= 0.5:
        return text + '; the threshold is most likely crossed.'
    if not math.isfinite(remaining):
        return text + '; no crossing of the threshold within the forecast horizon.'
    high = trend.remaining_experiments_high
    high_text = f'{high:.0f}' if math.isfinite(high) else 'beyond the horizon'
    return (text + f'; forecast crossing in {remaining:.0f} experiments (95 % '
            f'{trend.remaining_experiments_low:.0f} to {high_text}).')


def write_report(result: Any, folder: str | os.PathLike, *, threshold: float,
                 figures: dict[str, str], extra: str = '', elapsed_s: float | None = None
                 ) -> Path:
    """Write ``report.md``: what was run, the alarm verdict, figures and the table."""
    folder = Path(folder)
    first = result.first_alarm
    lines = ['# Wear monitoring demo: accelerated wear test', '']
    if extra:
        lines += [extra, '']
    if first is None:
        lines.append(f'**No alarm** (threshold w >= {threshold:g}).')
    else:
        truth = result.truth_for(first)
        true_text = f', true w = {truth.wear:.1f}' if truth is not None else ''
        low, high = first.wear_interval
        lines.append(f'**Alarm raised at experiment {first.index}**: w-hat = {first.wear:.1f} '
                     f'(95 % {low:.1f}-{high:.1f}){_trend_text(first)}{true_text} '
                     f'(threshold {threshold:g}).')
    crossing = next((u for u in result.updates
                     if (t := result.truth_for(u)) is not None and t.wear >= threshold), None)
    if crossing is not None:
        lines.append(f'The true wear first reaches {threshold:g} at experiment '
                     f'{crossing.index}.')
    if elapsed_s is not None:
        lines.append(f'Run time: {elapsed_s:.0f} s.')
    lines.append('')
    for caption, name in figures.items():
        lines += [f'![{caption}]({name})', '', f'*{caption}*', '']
    last = result.updates[-1] if result.updates else None
    if last is not None and last.trend is not None:
        lines.append(f'After the last experiment: {_forecast_sentence(last.trend)}')
    lines.append('')
    lines += ['| exp | speeds [rad/s] | friction levels | true w | w-hat | 95 % interval | '
              'trend (95 %) | true T | T-hat | p | alarm | status |',
              '|---|---|---|---|---|---|---|---|---|---|---|---|']
    for update in result.updates:
        truth = result.truth_for(update)
        lines.append(
            f'| {update.index} | {", ".join(f"{v:g}" for v in update.speeds_rad_s)} | '
            f'{", ".join(f"{f:.4f}" for f in update.frictions)} | '
            f'{_cell(truth.wear if truth else None)} | {_cell(update.wear)} | '
            f'{_cell(update.wear_interval[0])}-{_cell(update.wear_interval[1])} | '
            f'{_trend_cell(update.trend)} | '
            f'{_cell(truth.temperature_degc if truth else None)} | '
            f'{_cell(update.temperature_degc)} | {_cell(update.estimate.p_value, 2)} | '
            f'{"**ALARM**" if update.alarm_active else ""} | '
            f'{("OK", "WARN", "ERROR", "STALE")[update.status.level]} |')
    target = folder / 'report.md'
    write_text_atomic(target, '\n'.join(lines) + '\n')
    return target


def plot_replay(result: Any, path: str | os.PathLike, *, bag: str | os.PathLike,
                threshold: float) -> list[Path]:
    """
    Draw the wear trend of a replay, one PNG per joint with estimates; return the files.

    One joint (or none with estimates): ``path`` itself; several: ``<stem>_<joint><suffix>``
    beside it.  ``threshold``: the alarm threshold of w [-].
    """
    joints = [entry['joint'] for entry in result.joints if entry['estimates']]
    if len(joints) <= 1:
        return [plot_wear_trend(result, path, threshold=threshold,
                                title=f'Wear estimate, {Path(bag).name}, joint {result.joint}')]
    target = Path(path)
    written = []
    for joint in joints:
        part = replace(result, updates=[u for u in result.updates if u.joint == joint],
                       joint=joint)
        written.append(plot_wear_trend(
            part, target.with_name(f'{target.stem}_{joint}{target.suffix}'),
            threshold=threshold, title=f'Wear estimate, {Path(bag).name}, joint {joint}'))
    return written
