"""
What the dashboard shows, as JSON-ready dicts: the fleet, one joint and the alarm log.

The pages and the ``/api/`` routes both render these, so that a page and its API never tell
two stories.  The fleet keeps the order of ``robot-wear-monitor fleet``
(:func:`robot_wear_monitor.fleet.ranking.fleet_view`, worst first).  Numbers that are not
finite become None (JSON null).  Wear is the model's w (0 new, 100 failure), temperatures in
degC, speeds motor side in rad/s, frictions normalised, times in seconds since the epoch and
ISO 8601 UTC; the ``text`` of a fleet row and an event's ``time_text`` (words people read) are
in the dashboard's ``display_timezone`` (``zone``, :func:`robot_wear_monitor.text.shown_time`).
"""

from __future__ import annotations

import math
import re
import threading
import time
from typing import Any, Optional, Sequence
from urllib.parse import quote

from markupsafe import escape, Markup
import numpy as np
from robot_wear_monitor.display_time import Zone
from robot_wear_monitor.fleet.ranking import (crossing_text, DEFAULT_REESCALATION_MARGIN,
                                              fleet_view, FleetView, plural, threshold_text)
from robot_wear_monitor.fleet.states import DAY_S, DEFAULT_FORECAST_HORIZON_DAYS
from robot_wear_monitor.fleet.thresholds import ParameterSets, threshold_words
from robot_wear_monitor.history.alarms import event_time_s, note_text
from robot_wear_monitor.json_values import finite_or_none
from robot_wear_monitor.model.params import ParameterSet
from robot_wear_monitor.text import iso_time, shorten, shown_time

#: An experiment whose model check has a p-value below this is marked on the joint page.
MODEL_CHECK_P_VALUE = 0.01
#: How many of the latest experiments the friction-level chart draws against the model.
FRICTION_EXPERIMENTS = 5
#: A crossing this many experiments ahead or sooner gets the steep arrow.
SOON_EXPERIMENTS = 10.0
#: Every fleet bar spans 0 to this many times the joint's wear threshold.
BAR_SCALE = 1.5
#: The fleet page's rows per page unless ``?limit=`` says otherwise, and the most it shows.
PAGE_ROWS = 100
MAX_PAGE_ROWS = 1000


def reescalation_margin(request: Any) -> float:
    """
    Return the re-escalation margin of the dashboard [wear units].

    That of its notification configuration (``dashboard --notify``, ``reescalation_margin``),
    else :data:`~robot_wear_monitor.fleet.ranking.DEFAULT_REESCALATION_MARGIN`: the page
    orders as the notifier notifies.
    """
    settings = getattr(request.app.state, 'settings', None)
    config = getattr(settings, 'notifications', None)
    return float(getattr(config, 'reescalation_margin', DEFAULT_REESCALATION_MARGIN))


def forecast_horizon_s(request: Any) -> float:
    """
    Return the forecast horizon of the dashboard's ``warning`` state [s].

    That of its notification configuration (``forecast_horizon_days``), else
    :data:`~robot_wear_monitor.fleet.states.DEFAULT_FORECAST_HORIZON_DAYS`: one setting for
    the page's warnings and the notifications.
    """
    settings = getattr(request.app.state, 'settings', None)
    config = getattr(settings, 'extra', {}).get('notify') if settings is not None else None
    return float(getattr(config, 'forecast_horizon_days', DEFAULT_FORECAST_HORIZON_DAYS)) * DAY_S


def history_version(history: Any) -> tuple:
    """
    Return what changes whenever the history gets a row: the last estimate and event ids.

    Estimates and alarm events are only ever added (ids grow), so equal versions mean equal
    fleets.  Two index lookups.
    """
    return (history.path, *history.latest_ids())


class FleetCache:
    """
    The history's fleet rows, read again only when the history changed.

    The pages poll every few seconds; between two experiments the fleet query is skipped.
    Staleness is judged anew at every call (:func:`fleet_view` on the cached rows).  The JSON
    of a row is kept too (:meth:`row_json`): a new experiment makes one row anew, not all.
    """

    def __init__(self) -> None:
        """Start empty."""
        self._lock = threading.Lock()
        self._version: Optional[tuple] = None
        self._rows: list = []
        self._json: dict[tuple, dict[str, Any]] = {}

    def row_json(self, view: FleetView, *, zone: Zone = None) -> dict[str, Any]:
        """Return :func:`fleet_row_json` of ``view``, made once per row state."""
        key = (repr(view.state), view.stale, view.crossing_time_s, view.reescalated,
               view.threshold, view.threshold_assumed, view.condition,
               view.crossing_overdue, str(zone))
        with self._lock:
            found = self._json.get(key)
        if found is None:
            found = RowJson(fleet_row_json(view, zone=zone))
            with self._lock:
                if len(self._json) > 4 * max(1000, len(self._rows)):
                    self._json.clear()  # rows of states long gone
                self._json[key] = found
        return found

    def rows(self, history: Any) -> list:
        """Return ``history.fleet()``, from the cache when the history has not changed."""
        version = history_version(history)
        with self._lock:
            if version == self._version:
                return self._rows
        rows = history.fleet()
        with self._lock:
            self._version, self._rows = version, rows
        return rows


class RowJson(dict):
    """A fleet row's JSON (a dict) that keeps its HTML once made (:func:`fleet_row_html`)."""

    html: Optional[Markup] = None


def fleet_row_html(row: dict[str, Any]) -> Markup:
    """
    Return the fleet table's ``<tr>`` of a row, every text escaped (kept on a RowJson).

    The same cells as the page's script writes (static/fleet.js): one string per row instead
    of a template loop, so that the page of a thousand joints is made fast.  The bar comes
    first in its cell (its threshold tick at the same x in every row), then the numbers.
    """
    made = getattr(row, 'html', None)
    if made is not None:
        return made
    bar, text = row['bar'], row['text']
    low = bar['low'] if bar['low'] > 0 else 0
    width = (bar['high'] - bar['low'] if bar['high'] > bar['low'] else 0) \
        if bar['low'] >= 0 else 0
    html = Markup(
        '<tr class="state-{state}{stale}" data-robot="{robot}" data-joint="{joint}">'
        '<td class="c-robot">{robot}</td>'
        '<td class="c-joint"><a href="{url}">{joint}</a></td>'
        '<td class="c-state"><span class="badge">{state_text}</span></td>'
        '<td class="c-wear"><svg class="bar" '
        'viewBox="0 0 100 14" preserveAspectRatio="none"><rect class="track" x="0" y="4" '
        'width="100" height="6"></rect><rect class="interval" x="{low}" y="3" width="{width}" '
        'height="8"></rect><line class="estimate" x1="{mark}" x2="{mark}" y1="1" y2="13" '
        'visibility="{visible}"></line><line class="threshold" x1="{threshold}" '
        'x2="{threshold}" y1="0" y2="14"></line><polygon class="clip" '
        'points="94,1 100,7 94,13" visibility="{clipped}"></polygon></svg>'
        '<span class="num">{wear}</span> <span class="thr">threshold {threshold_text}'
        '</span></td>'
        '<td class="c-trend">{trend}</td><td class="c-crossing">{crossing}</td>'
        '<td class="c-alarm">{alarm}</td><td class="c-last">{last}</td>'
        '<td class="c-experiments">{experiments}</td></tr>\n').format(
            state=row['state'].replace(' ', '-'), stale=' stale' if row['stale'] else '',
            robot=row['robot'], joint=row['joint'], url=row['url'], state_text=row['state'],
            wear=text['wear'], threshold_text=text['threshold'], low=low, width=width,
            mark=bar['wear'],
            visible='hidden' if bar['wear'] < 0 else 'visible', threshold=bar['threshold'],
            clipped='visible' if bar['clipped'] else 'hidden',
            trend=text['trend'], crossing=time_spans(text['crossing']),
            alarm=time_spans(text['alarm']), last=time_spans(text['last']),
            experiments=row['experiments'])
    if isinstance(row, RowJson):
        row.html = html
    return html


#: A date or an ISO 8601 UTC time in a text (kept on one line by :func:`time_spans`).
TIME_TOKEN = re.compile(r'\d{4}-\d{2}-\d{2}(?:T\d{2}:\d{2}(?::\d{2})?Z?'
                        r'| \d{2}:\d{2} (?:[A-Z]{2,6}|[+-]\d{2,4})\b)?')


def time_spans(text: str) -> Markup:
    """
    Return ``text`` escaped, each date or time in a ``<span class="t">`` (never broken).

    The style sheet keeps a ``.t`` on one line (``white-space: nowrap``); the text itself is
    unchanged (static/common.js ``setTimes`` does the same in the browser).
    """
    escaped = str(escape(text))
    return Markup(TIME_TOKEN.sub(lambda m: f'<span class="t">{m.group(0)}</span>', escaped))


def joint_url(robot: str, joint: str) -> str:
    """Return the path of a joint's page (names percent-encoded)."""
    return f'/robots/{quote(robot, safe="")}/joints/{quote(joint, safe="")}'


def utc_text(stamp_s: Optional[float], zone: Zone = None) -> str:
    """
    Return a stamp [s since the epoch] as ISO 8601 UTC to the second ('-' when unknown).

    The text of :func:`robot_wear_monitor.text.iso_time`, made faster (the fleet page
    writes thousands); with a ``zone``, :func:`~robot_wear_monitor.text.shown_time`'s.
    """
    if zone is not None:
        return shown_time(stamp_s, zone=zone)
    if stamp_s is None or not math.isfinite(stamp_s) or not -1e11 < stamp_s < 2.5e11:
        return iso_time(stamp_s)
    return time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime(stamp_s))


def _number(value: Optional[float]) -> Optional[float]:
    return None if value is None else finite_or_none(float(value))


def row_state(view: FleetView) -> str:
    """
    Return the state of a fleet row: one of :data:`STATES` (``fleet/states.py``).

    A re-escalated acknowledged alarm is ``alarm`` (its row says ``reescalated`` and why); a
    joint reset and awaiting its first experiment is ``new life`` (or ``stale``).
    """
    return view.condition


def trend_arrow(view: FleetView) -> str:
    """
    Return the trend arrow of a row from its forecast crossing.

    Steep up: the trend is past the threshold or crosses it within :data:`SOON_EXPERIMENTS`
    experiments; up: it crosses within the forecast horizon; flat: not within the horizon;
    '?': no trend stored.
    """
    state = view.state
    if not math.isfinite(state.trend_wear):
        return '?'
    crossing = state.crossing_experiments
    if math.isfinite(crossing):
        return '\u2191' if crossing <= SOON_EXPERIMENTS else '\u2197'
    return '\u2192'


def _interval_text(wear: float, low: float, high: float) -> str:
    if not math.isfinite(wear):
        return 'cannot judge'
    if math.isfinite(low) and math.isfinite(high):
        return f'{wear:.1f} [{low:.1f}, {high:.1f}]'
    return f'{wear:.1f} [interval unknown]'


def _bar(state: Any, threshold: float) -> dict[str, Any]:
    """
    Return the wear bar's positions [% of its width]: interval, estimate, threshold.

    One scale for every row: 0 to :data:`BAR_SCALE` x the threshold, so the threshold's tick
    is at the same place in every row; a w-hat or an upper end past the scale is drawn at the
    right end and ``clipped`` says so (the row's text gives the number).
    """
    top = BAR_SCALE * threshold

    def pct(value: float) -> float:
        return round(100.0 * min(max(value, 0.0), top) / top, 2) if math.isfinite(value) \
            else -1.0
    wear = state.wear if not state.invalid_reason else math.nan
    low = state.wear_low if math.isfinite(state.wear_low) else wear
    high = state.wear_high if math.isfinite(state.wear_high) else wear
    clipped = any(math.isfinite(v) and v > top for v in (wear, high))
    return {'low': pct(low), 'high': pct(high), 'wear': pct(wear),
            'threshold': pct(threshold), 'scale_max': top, 'clipped': clipped}


def crossing_days(view: FleetView) -> Optional[float]:
    """
    Return the forecast crossing in days after the latest experiment, or None.

    The crossing in experiments times the joint's usual experiment interval (the time of
    ``crossing_time_s``); None without a crossing ahead or an interval.
    """
    crossing = view.state.crossing_experiments
    if view.crossing_time_s is None or not (math.isfinite(crossing) and crossing > 0):
        return None
    return (view.crossing_time_s - view.state.last_stamp_s) / DAY_S


def crossing_words(view: FleetView, zone: Zone = None) -> str:
    """
    Return the forecast crossing as the page shows it: days, the date, and experiments.

    "in 12 experiments \u2248 3.5 days (~2025-06-01)": both counted from the latest
    experiment, at the joint's usual experiment interval; the date is UTC.
    """
    days = crossing_days(view)
    if view.crossing_overdue or days is None or view.crossing_time_s is None:
        text = crossing_text(view, zone=zone)
        if math.isfinite(view.state.crossing_experiments) and \
                view.state.crossing_experiments > 0:
            text += ' (no date: the experiment interval is not known yet)'
        return text
    amount = f'{days:.1f}' if days < 10 else f'{days:,.0f}'
    return (f'in {plural(round(view.state.crossing_experiments), "experiment")} \u2248 '
            f'{amount} days (~{shown_time(view.crossing_time_s, zone=zone, date_only=True)})')


def life_text(state: Any, zone: Zone = None) -> str:
    """
    Return the line of a joint reset after maintenance ('' when never reset or latched again).

    "reset <time> by <user> (<reason>): awaiting the first experiment" until an experiment
    follows the reset, then "new life since the reset <time> by <user> (<reason>)".
    """
    if not math.isfinite(state.life_started_s):
        return ''
    who = f' by {shorten(state.reset_by, 60)}' if state.reset_by else ''
    why = f' ({shorten(state.reset_reason, 120)})' if state.reset_reason else ''
    if state.awaiting_first_experiment:
        return (f'reset {utc_text(state.life_started_s, zone)}{who}{why}: awaiting the first '
                'experiment')
    return f'new life since the reset {utc_text(state.life_started_s, zone)}{who}{why}'


def _alarm_text(view: FleetView, zone: Zone = None) -> str:
    state = view.state
    if not state.alarm:
        return 'clear'
    text = f'LATCHED since {utc_text(state.alarm_since_stamp_s, zone)}'
    if getattr(state, 'acknowledged', False):
        text += f'; acknowledged by {getattr(state, "acknowledged_by", "")}'
        if getattr(state, 'planned_maintenance', ''):
            text += f', maintenance planned {state.planned_maintenance}'
        if view.reescalated:
            text += f'; RE-ESCALATED: {view.reescalated}'
    return text


def fleet_row_json(view: FleetView, *, zone: Zone = None) -> dict[str, Any]:
    """
    Return one fleet row for the page and ``/api/fleet`` (``fleet --json`` keys and more).

    The times of ``text`` (and ``acknowledged_at_text``) are in ``zone``; the others UTC.

    The bar is drawn on the threshold the row's latest estimate was judged by (the row's
    ``threshold``; the parameter set's when ``threshold_assumed``).
    """
    state = view.state
    threshold = view.threshold
    row = view.as_json()
    row.update({
        'state': row_state(view), 'arrow': trend_arrow(view),
        'acknowledged': bool(getattr(state, 'acknowledged', False)),
        'acknowledged_by': getattr(state, 'acknowledged_by', '') or None,
        'acknowledged_s': _number(getattr(state, 'acknowledged_wall_time_s', math.nan)),
        'acknowledged_at': utc_text(getattr(state, 'acknowledged_wall_time_s', math.nan)),
        'acknowledged_at_text': utc_text(getattr(state, 'acknowledged_wall_time_s', math.nan),
                                         zone),
        'edited_by': getattr(state, 'edited_by', '') or None,
        'planned_maintenance': getattr(state, 'planned_maintenance', '') or None,
        'parameter_set': state.parameter_set,
        'alarm_since': utc_text(state.alarm_since_stamp_s) if state.alarm else None,
        'last_experiment': utc_text(state.last_stamp_s),
        'crossing_date': (utc_text(view.crossing_time_s)[:10]
                          if view.crossing_time_s is not None else None),
        'crossing_days': _number(crossing_days(view)),
        'bar': _bar(state, threshold), 'url': joint_url(state.robot, state.joint),
        'text': {'wear': (life_text(state, zone) if state.awaiting_first_experiment else
                          _interval_text(state.wear if not state.invalid_reason else math.nan,
                                         state.wear_low, state.wear_high)),
                 'life': life_text(state, zone),
                 'trend': (f'{trend_arrow(view)} {state.trend_wear:.1f}'
                           if math.isfinite(state.trend_wear) else '?'),
                 # a new life awaiting its first experiment: nothing of the old life
                 'crossing': ('no experiment since the reset'
                              if state.awaiting_first_experiment else crossing_words(view, zone)),
                 'alarm': _alarm_text(view, zone),
                 'threshold': threshold_text(view),
                 'last': ('none since the reset' if state.awaiting_first_experiment
                          else utc_text(state.last_stamp_s, zone)) + (' STALE' if view.stale
                                                                      else ''),
                 'invalid': state.invalid_reason or ''},
    })
    return row


def event_json(event: Any, *, zone: Zone = None) -> dict[str, Any]:
    """
    Return one alarm event (raised, reset, an acknowledgement, its edit or withdrawal).

    ``time``/``event_time_s``: the event's time in the log (a raise's experiment stamp, an
    acknowledgement's, an edit's, a withdrawal's or a reset's wall time; ``time_text``: in
    ``zone``, as people read it); ``note_text``: its note in words.
    """
    wall = _number(getattr(event, 'wall_time_s', math.nan))
    when = _number(event_time_s(event))
    return {
        'id': getattr(event, 'id', None), 'robot': event.robot, 'joint': event.joint,
        'event': event.event, 'stamp_s': _number(event.stamp_s),
        'time': utc_text(when), 'time_text': utc_text(when, zone), 'event_time_s': when,
        'wall_time_s': wall, 'wear': _number(event.wear), 'note': event.note,
        'note_text': note_text(event),
        'user': getattr(event, 'user', '') or '', 'owner': getattr(event, 'owner', '') or '',
        'planned_maintenance': getattr(event, 'planned_maintenance', '') or '',
        'estimate_id': getattr(event, 'estimate_id', None),
        'work_order': getattr(event, 'work_order', '') or '',
        'source': getattr(event, 'source', '') or '',
        'changes': getattr(event, 'changes', '') or '',
    }


#: The columns of ``/alarms.csv`` (those of ``history --alarms --csv``; ``work_order``,
#: ``source`` and ``changes`` are last, so that the columns before them keep their places).
ALARM_CSV_COLUMNS = ('id', 'time', 'robot', 'joint', 'event', 'wear', 'user', 'owner',
                     'planned_maintenance', 'note', 'note_text', 'work_order', 'source',
                     'changes')


def alarm_log(history: Any, *, robot: Optional[str] = None, joint: Optional[str] = None,
              limit: Optional[int] = None,
              stored_after_s: Optional[float] = None, zone: Zone = None
              ) -> list[dict[str, Any]]:
    """
    Return the fleet's alarm events newest first (one robot's joint with ``joint``).

    ``stored_after_s``: only the events stored after that wall time [s] (``?since=``).
    """
    if hasattr(history, 'alarm_log'):
        kwargs = {} if stored_after_s is None else {'stored_after_s': stored_after_s}
        events = history.alarm_log(robot=robot, joint=joint, limit=limit, **kwargs)
    else:  # a history layer without the fleet-wide log: each joint's events
        pairs = ([(robot, joint)] if joint is not None and robot is not None else
                 [(r, j) for r in ([robot] if robot else history.robots())
                  for j in history.joints(robot=r)])
        events = sorted((e for r, j in pairs for e in history.events(joint=j, robot=r)),
                        key=lambda e: (event_time_s(e), e.id or 0), reverse=True)
        events = events[:limit] if limit is not None else events
    return [event_json(e, zone=zone) for e in events]


def _experiment_json(record: Any) -> dict[str, Any]:
    p_value = _number(record.p_value)
    return {
        'id': record.id, 'stamp_s': record.stamp_s, 'time': utc_text(record.stamp_s),
        'wear': _number(record.wear), 'wear_low': _number(record.wear_low),
        'wear_high': _number(record.wear_high), 'trend_wear': _number(record.trend_wear),
        'trend_low': _number(record.trend_low), 'trend_high': _number(record.trend_high),
        'temperature_degc': _number(record.temperature_degc),
        'temperature_low_degc': _number(record.temperature_low_degc),
        'temperature_high_degc': _number(record.temperature_high_degc),
        'p_value': p_value,
        'model_check_failed': p_value is not None and p_value < MODEL_CHECK_P_VALUE,
        'alarm': bool(record.alarm_active), 'valid': record.valid,
        'invalid_reason': record.invalid_reason or None,
        'crossing_experiments': _number(record.crossing_experiments),
        'crossing_time_s': _number(record.crossing_time_s),
    }


def forecast_cone(records: Sequence[Any], *, threshold: float,
                  spacing_s: Optional[float] = None) -> Optional[dict[str, Any]]:
    """
    Return the forecast cone of the latest trend up to the threshold, or None.

    The history keeps the median crossing of the trend's forecast (``crossing_experiments``).
    The cone runs from the latest trend and its 95 % band at the median rate
    ((threshold - trend) / crossing per experiment), so that its middle line reaches the
    threshold at the stored crossing; the band's edges reach it earliest and latest, which is
    the crossing's interval shown (an approximation: the full forecast distribution is not
    stored).  Times use the joint's usual experiment spacing ``spacing_s`` [s] (the fleet
    row's, :attr:`FleetRow.usual_interval_s`; else the mean spacing of ``records``).
    """
    if len(records) < 2:
        return None
    last = records[-1]
    crossing = last.crossing_experiments
    if not (math.isfinite(crossing) and crossing > 0 and math.isfinite(last.trend_wear)):
        return None
    rate = (threshold - last.trend_wear) / crossing
    if not rate > 0:
        return None
    spacing = (spacing_s if spacing_s is not None and math.isfinite(spacing_s) and spacing_s > 0
               else (last.stamp_s - records[0].stamp_s) / (len(records) - 1))
    high = last.trend_high if math.isfinite(last.trend_high) else last.trend_wear
    low = last.trend_low if math.isfinite(last.trend_low) else last.trend_wear
    early = max(0.0, (threshold - high) / rate)
    late = max(crossing, (threshold - low) / rate)
    steps = np.linspace(0.0, late, 25)
    times = last.stamp_s + steps * spacing
    return {
        'time_s': times.tolist(), 'time': [utc_text(t) for t in times],
        'wear': np.minimum(last.trend_wear + rate * steps, threshold).tolist(),
        'high': np.minimum(high + rate * steps, threshold).tolist(),
        'low': np.minimum(low + rate * steps, threshold).tolist(),
        'crossing_experiments': crossing, 'crossing_low_experiments': early,
        'crossing_high_experiments': late, 'crossing_time_s': last.stamp_s + crossing * spacing,
        'crossing_low_time_s': last.stamp_s + early * spacing,
        'crossing_high_time_s': last.stamp_s + late * spacing,
        'crossing': utc_text(last.stamp_s + crossing * spacing),
        'crossing_low': utc_text(last.stamp_s + early * spacing),
        'crossing_high': utc_text(last.stamp_s + late * spacing),
        'rate_per_experiment': rate, 'spacing_s': spacing,
    }


def friction_curves(records: Sequence[Any], *, params: ParameterSet) -> list[dict[str, Any]]:
    """
    Return the friction levels of the last experiments and the model at their T-hat, w-hat.

    The model curve is the friction model (8) at the set's mean load, the experiment's T-hat
    [degC] and w-hat, over the speeds [rad/s, motor side] of the levels.
    """
    # deferred import: start-up time (model.friction: one page only)
    from robot_wear_monitor.model.friction import friction
    out = []
    for record in records[-FRICTION_EXPERIMENTS:]:
        speeds = np.asarray(record.speeds_rad_s, dtype=float)
        if speeds.size == 0:
            continue
        order = np.argsort(speeds)
        grid = np.linspace(max(0.5, speeds.min() * 0.8), speeds.max() * 1.1, 60)
        temperature, wear = record.temperature_degc, record.wear
        model = None
        if math.isfinite(temperature) and math.isfinite(wear):
            model = friction(grid, params.load_mean, temperature, max(0.0, wear),
                             params.model).tolist()
        out.append({'id': record.id, 'time': utc_text(record.stamp_s),
                    'speeds_rad_s': speeds[order].tolist(),
                    'frictions': np.asarray(record.frictions, dtype=float)[order].tolist(),
                    'model_speeds_rad_s': grid.tolist(), 'model_frictions': model,
                    'temperature_degc': _number(temperature), 'wear': _number(wear)})
    return out


def joint_json(history: Any, *, robot: str, joint: str, now_s: float,
               parameter_sets: ParameterSets,
               reescalation_margin: float = DEFAULT_REESCALATION_MARGIN,
               forecast_horizon_s: float = DEFAULT_FORECAST_HORIZON_DAYS * DAY_S,
               zone: Zone = None) -> Optional[dict[str, Any]]:
    """
    Return one joint's story (None when the history holds no estimate of it).

    The forecast cone is drawn at the fleet row's usual interval, so that the chart and the
    facts give one crossing date.
    """
    records = history.records(joint=joint, robot=robot)
    if not records:
        return None
    params, note = parameter_sets.resolve(records[-1].parameter_set)
    rows = (history.fleet_index().rows([(robot, joint)]) if hasattr(history, 'fleet_index')
            else history.fleet(robot=robot))
    state = next((v for v in fleet_view(rows, now_s=now_s,
                                        reescalation_margin=reescalation_margin,
                                        forecast_horizon_s=forecast_horizon_s,
                                        parameter_sets=parameter_sets)
                  if v.state.joint == joint), None)
    # the threshold the latest estimate was judged by (the parameter set's when not stored)
    if state is not None:
        threshold, warning, assumed = state.threshold, state.warning_level, \
            state.threshold_assumed
    else:
        last = records[-1]
        assumed = not math.isfinite(last.threshold)
        threshold = params.wear_threshold if assumed else last.threshold
        warning = params.wear_warning if assumed else last.warning_level
    events = alarm_log(history, robot=robot, joint=joint, zone=zone)
    # the joint's current life: the experiments after the estimate its last reset is tied to
    last_reset = max((e for e in events if e['event'] == 'reset'), key=lambda e: e['id'] or 0,
                     default=None)
    life_after = (last_reset or {}).get('estimate_id')
    if last_reset is not None and life_after is None:
        life_after = 0
    life = [r for r in records if life_after is None or (r.id or 0) > life_after]
    return {
        'robot': robot, 'joint': joint, 'threshold': threshold,
        'warning_level': _number(warning), 'threshold_assumed': assumed,
        'threshold_text': threshold_words(threshold, assumed=assumed),
        'parameter_set': records[-1].parameter_set, 'model_note': note or None,
        'model_check_p_value': MODEL_CHECK_P_VALUE,
        'state': fleet_row_json(state, zone=zone) if state is not None else None,
        'experiments': [{**_experiment_json(r), 'current_life': life_after is None
                         or (r.id or 0) > life_after} for r in records],
        'forecast': forecast_cone(life, threshold=threshold,
                                  spacing_s=None if state is None
                                  else state.state.usual_interval_s),
        'friction': friction_curves(records, params=params),
        'events': events,
    }
