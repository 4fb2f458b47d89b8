"""
The fleet as a text table for a terminal (``robot-wear-monitor fleet``).

Default: a table that fits ``width`` columns (the terminal's, at least 80; 100 when the output
is not a terminal).  Each joint's row holds what triage needs: robot, joint, state, w-hat with
its 95 % interval, the threshold, the forecast crossing and the last experiment; a cell wider
than its column wraps within it (:mod:`textwrap`), and the long texts (the latched alarm, who
acknowledged, the owner, comment and work order of the acknowledgement, the reset and its
reason, why the estimate cannot be judged) go on an indented detail line below, wrapped to the
width.  ``wide``: one line per joint, every column, however wide (``fleet --wide``).  Times are
shown by :func:`robot_wear_monitor.text.shown_time` (the plant's ``display_timezone``).
"""

from __future__ import annotations

import math
import textwrap
from typing import Any, Mapping, Optional, Sequence

from robot_wear_monitor.display_time import Zone
from robot_wear_monitor.fleet.ranking import crossing_text, FleetView, threshold_text
from robot_wear_monitor.text import escaped, shorten, shown_time

__all__ = ['DEFAULT_WIDTH', 'fleet_table', 'MIN_WIDTH']

#: The table's width when the output is not a terminal [characters].
DEFAULT_WIDTH = 100
#: The narrowest table made (a terminal narrower gets lines this wide) [characters].
MIN_WIDTH = 80
#: The narrowest each column of :data:`HEADER` is squeezed to [characters] (their sum with
#: the spaces between fits :data:`MIN_WIDTH`): a date is 10, the longest state 12.
MIN_COLUMNS = (12, 8, 12, 10, 9, 12, 10)
#: The columns squeezed first (robot, joint, forecast crossing): long texts that wrap well.
SQUEEZED_FIRST = (0, 1, 5)
#: The indent of a joint's detail line.
DETAIL_INDENT = '    '
#: The note under a default table with an assumed threshold ('35*').
ASSUMED_NOTE = ("* the parameter set's threshold, assumed: the history stores none with the "
                'estimate (an older history)')
#: The columns of the default table.
HEADER = ('robot', 'joint', 'state', 'w [95 %]', 'threshold', 'forecast crossing',
          'last experiment')
#: The columns of ``--wide`` (one line per joint).
WIDE_HEADER = ('robot', 'joint', 'state', 'w [95 %]', 'trend w', 'threshold', 'alarm',
               'forecast crossing', 'experiments', 'last experiment', 'details')


def _wear_text(view: FleetView) -> str:
    state = view.state
    if state.awaiting_first_experiment:
        return 'new life: awaiting the first experiment'
    if not math.isfinite(state.wear) or state.invalid_reason:
        return 'CANNOT JUDGE'
    if math.isfinite(state.wear_low) and math.isfinite(state.wear_high):
        return f'{state.wear:.1f} [{state.wear_low:.1f}, {state.wear_high:.1f}]'
    return f'{state.wear:.1f} [interval unknown]'


def alarm_text(view: FleetView, *, local: bool = False, zone: Zone = None) -> str:
    """Return the alarm in words: 'no', 'no (reset T)', 'LATCHED since T, acknowledged ...'."""
    state = view.state
    if not state.alarm:
        if math.isfinite(state.life_started_s):
            return f'no (reset {shown_time(state.life_started_s, local=local, zone=zone)})'
        return 'no'
    text = f'LATCHED since {shown_time(state.alarm_since_stamp_s, local=local, zone=zone)}'
    if state.acknowledged:
        text += f', acknowledged by {shorten(state.acknowledged_by, 40)}'
        if state.planned_maintenance:
            text += f', maintenance planned {state.planned_maintenance}'
        if view.reescalated:
            text += ', RE-ESCALATED'
    return text


def detail_text(view: FleetView, *, acknowledgement: Any = None, local: bool = False,
                zone: Zone = None) -> str:
    """
    Return a joint's long texts in one line ('' when there are none).

    The latched alarm and its acknowledgement (``acknowledgement``: the history's current one,
    an :class:`~robot_wear_monitor.history.AlarmEvent`, for its owner, comment and work order),
    why it is re-escalated, the last reset and its reason, why the estimate cannot be judged,
    an assumed threshold.
    """
    state = view.state
    parts = []
    if state.alarm:
        parts.append(alarm_text(view, local=local, zone=zone))
        if view.reescalated:
            parts.append(f're-escalated: {shorten(view.reescalated, 300)}')
        if acknowledgement is not None:
            for label, value in (('edited by', state.edited_by),
                                 ('owner', acknowledgement.owner),
                                 ('work order', acknowledgement.work_order),
                                 ('comment', acknowledgement.note)):
                if value:
                    parts.append(f'{label} {shorten(value, 2000)}')
    if math.isfinite(state.life_started_s):
        reset = f'reset {shown_time(state.life_started_s, local=local, zone=zone)}'
        if state.reset_by:
            reset += f' by {shorten(state.reset_by, 128)}'
        if state.reset_reason:
            reset += f': {shorten(state.reset_reason, 2000)}'
        parts.append(reset)
    if state.invalid_reason:
        parts.append(f'cannot judge: {shorten(state.invalid_reason, 300)}')
    return '; '.join(parts)


def _cells(view: FleetView, *, local: bool, zone: Zone) -> list[str]:
    state = view.state
    return [escaped(state.robot), escaped(state.joint),
            view.condition.upper() if view.condition != 'ok' else 'ok',
            'new life' if state.awaiting_first_experiment else _wear_text(view),
            threshold_words_short(view), crossing_text(view, local=local, zone=zone),
            shown_time(state.last_stamp_s, local=local, zone=zone)
            if not state.awaiting_first_experiment else 'none since the reset']


def threshold_words_short(view: FleetView) -> str:
    """Return the threshold as a number: '35', an assumed one '35*' (:data:`ASSUMED_NOTE`)."""
    if not math.isfinite(view.threshold):
        return '-'
    return f'{view.threshold:g}*' if view.threshold_assumed else f'{view.threshold:g}'


def _fit(widths: list[int], limit: int) -> list[int]:
    """
    Return ``widths`` narrowed until the row (1 space apart) fits ``limit``.

    The widest of :data:`SQUEEZED_FIRST` first, then the widest of all, none below its
    :data:`MIN_COLUMNS`.
    """
    widths = list(widths)
    for columns in (SQUEEZED_FIRST, range(len(widths))):
        while sum(widths) + len(widths) - 1 > limit:
            widest = max(columns, key=lambda i: widths[i] if widths[i] > MIN_COLUMNS[i] else 0)
            if widths[widest] <= MIN_COLUMNS[widest]:
                break
            widths[widest] -= 1
    return widths


def _block(cells: Sequence[str], widths: Sequence[int]) -> list[str]:
    """Return the lines of one row: each cell wrapped within its column."""
    wrapped = [textwrap.wrap(cell, width=w, break_on_hyphens=False) or ['']
               for cell, w in zip(cells, widths)]
    height = max(len(lines) for lines in wrapped)
    return [' '.join((lines[k] if k < len(lines) else '').ljust(w)
                     for lines, w in zip(wrapped, widths)).rstrip() for k in range(height)]


def fleet_table(rows: Sequence[FleetView], *, local: bool = False, zone: Zone = None,
                width: int = DEFAULT_WIDTH, wide: bool = False,
                acknowledgements: Optional[Mapping[tuple[str, str], Any]] = None) -> str:
    """
    Return the fleet as a text table, worst first (see the module's text).

    ``width``: the most characters of a line [characters, at least :data:`MIN_WIDTH`];
    ``wide``: one line per joint, all columns, no limit; ``acknowledgements``: the current
    acknowledgement per (robot, joint), for the detail lines; ``zone``, ``local``: see
    :func:`~robot_wear_monitor.text.shown_time`.
    """
    found = acknowledgements or {}
    if wide:
        lines = [(shorten(v.state.robot, 128), shorten(v.state.joint, 128),
                  *_cells(v, local=local, zone=zone)[2:4],
                  f'{v.state.trend_wear:.1f}' if math.isfinite(v.state.trend_wear) else '-',
                  threshold_text(v), alarm_text(v, local=local, zone=zone),
                  crossing_text(v, local=local, zone=zone), str(v.state.experiments),
                  _cells(v, local=local, zone=zone)[6],
                  detail_text(v, acknowledgement=found.get((v.state.robot, v.state.joint)),
                              local=local, zone=zone) or '-')
                 for v in rows]
        widths = [max(len(h), *(len(line[i]) for line in lines)) if lines else len(h)
                  for i, h in enumerate(WIDE_HEADER)]
        out = ['  '.join(h.ljust(w) for h, w in zip(WIDE_HEADER, widths)).rstrip()]
        out += ['  '.join(c.ljust(w) for c, w in zip(line, widths)).rstrip() for line in lines]
        return '\n'.join(out)
    limit = max(MIN_WIDTH, int(width))
    cells = [_cells(v, local=local, zone=zone) for v in rows]
    widths = _fit([max(len(h), *(len(c[i]) for c in cells)) if cells else len(h)
                   for i, h in enumerate(HEADER)], limit)
    out = _block(HEADER, widths)
    for view, row in zip(rows, cells):
        out += _block(row, widths)
        detail = detail_text(view, local=local, zone=zone,
                             acknowledgement=found.get((view.state.robot, view.state.joint)))
        if detail:
            out += textwrap.wrap(detail, width=limit, initial_indent=DETAIL_INDENT,
                                 subsequent_indent=DETAIL_INDENT, break_on_hyphens=False)
    if any(view.threshold_assumed for view in rows):
        out += textwrap.wrap(ASSUMED_NOTE, width=limit)
    return '\n'.join(out)
