"""
The fleet page's and ``/api/fleet``'s data: one page of the fleet read through its index.

A page, a state filter, one robot's joints and the counts per state are index reads of the
history's stored ranking keys (:mod:`~robot_wear_monitor.fleet.indexed`, schema version 12):
the order and the ``state`` words are those of
:func:`~robot_wear_monitor.fleet.ranking.fleet_view` of the whole fleet, and only the rows sent
are read in full and made into JSON.  Every row (``/api/fleet`` without paging) is streamed,
read a chunk at a time (:func:`stream_json`).  The robot filter is a search
(:func:`robot_choices`), not a list of every robot.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any, Iterator, Optional
from urllib.parse import urlencode

from robot_wear_monitor.dashboard.views import fleet_row_json, FleetCache, PAGE_ROWS
from robot_wear_monitor.display_time import Zone
from robot_wear_monitor.fleet.indexed import (fleet_clock, page_views, reescalated_views,
                                              stream_views)
from robot_wear_monitor.fleet.ranking import DEFAULT_REESCALATION_MARGIN
from robot_wear_monitor.fleet.reescalation_log import try_log_reescalations
from robot_wear_monitor.fleet.states import DAY_S, DEFAULT_FORECAST_HORIZON_DAYS
from robot_wear_monitor.fleet.thresholds import ParameterSets

#: The most robots the robot search suggests.
ROBOT_CHOICES = 20
#: About how many characters of rows a streamed answer writes at once.
STREAM_PART_CHARS = 256 * 1024


def fleet_json(history: Any, *, now_s: float, parameter_sets: ParameterSets,
               robot: Optional[str] = None, state: Optional[str] = None,
               cache: Optional[FleetCache] = None, page: Optional[int] = None,
               limit: Optional[int] = None,
               reescalation_margin: float = DEFAULT_REESCALATION_MARGIN,
               forecast_horizon_s: float = DEFAULT_FORECAST_HORIZON_DAYS * DAY_S,
               source: str = '', stream: bool = False, zone: Zone = None) -> dict[str, Any]:
    """
    Return the fleet worst first, the counts per state and the robots, as one dict.

    ``robot`` and ``state`` filter the rows (the counts are those of the whole fleet);
    ``cache``: the JSON of a row state made once.  ``page`` (from 1) and ``limit`` (rows per
    page) give one page of the filtered rows (a page past the last is the last); without
    both, every row: a list, or with ``stream`` an iterator read a chunk at a time (then
    ``robots`` is filled as the rows go by: :func:`stream_json` writes it last).  ``total``
    counts the filtered rows, ``pages`` their pages; ``robots``: the robots of the rows sent;
    ``robot_count``: the fleet's robots.  ``reescalation_margin``: see
    :func:`~robot_wear_monitor.fleet.ranking.fleet_view`.  ``source`` ('web', 'api'): log
    each re-escalation not yet in the alarm log, with it (:mod:`~robot_wear_monitor.fleet.
    reescalation_log`); '' logs nothing.  ``zone``: of the rows' texts (None: UTC).
    """
    index = history.fleet_index()
    clock = fleet_clock(index, now_s=now_s, reescalation_margin=reescalation_margin,
                        forecast_horizon_s=forecast_horizon_s, parameter_sets=parameter_sets)
    if source:  # the audit trail: a re-escalation this request is the first to see, once
        log_reescalations(history, clock, parameter_sets=parameter_sets, source=source)
    make = cache.row_json if cache is not None else fleet_row_json
    counts = index.counts(clock)
    joints = sum(counts.values())
    total = (joints if robot is None and state is None else counts[state] if robot is None
             else index.total(clock, robot=robot, state=state))
    pages, first = 1, 0
    robots: list[str] = []
    rows: Any
    if page is not None or limit is not None:
        limit = max(1, limit if limit is not None else PAGE_ROWS)
        pages = max(1, -(-total // limit))
        page = min(max(1, page if page is not None else 1), pages)
        first = (page - 1) * limit
        views = page_views(index, clock, robot=robot, state=state, offset=first, limit=limit,
                           parameter_sets=parameter_sets)
        rows = [make(v, zone=zone) for v in views]
        robots = sorted({v.state.robot for v in views})
    else:
        seen: set[str] = set()

        def every_row() -> Iterator[dict[str, Any]]:
            for view in stream_views(index, clock, robot=robot, state=state,
                                     parameter_sets=parameter_sets):
                if view.state.robot not in seen:
                    seen.add(view.state.robot)
                    robots.append(view.state.robot)
                yield make(view, zone=zone)
            robots.sort()

        rows = every_row() if stream else list(every_row())
    return {'counts': counts, 'joints': joints, 'robots': robots,
            'robot_count': index.robot_count(), 'robot': robot, 'state': state, 'rows': rows,
            'total': total, 'page': page if limit is not None else 1, 'pages': pages,
            'limit': limit, 'first': first + 1 if total and (rows or stream) else 0}


def log_reescalations(history: Any, clock: Any, *, parameter_sets: Optional[ParameterSets],
                      source: str) -> None:
    """Log each re-escalated acknowledged alarm at ``clock`` not yet logged (few; index read)."""
    found = reescalated_views(history.fleet_index(), clock, parameter_sets=parameter_sets)
    if found:
        try_log_reescalations(history, found, source=source)


def _dumps(value: Any) -> str:
    return json.dumps(value, ensure_ascii=False, allow_nan=False, separators=(',', ':'))


def stream_json(payload: dict[str, Any]) -> Iterator[bytes]:
    """
    Yield ``payload`` (of :func:`fleet_json` with ``stream``) as one JSON document, row by row.

    Its keys in order, ``rows`` written as they are read (in parts of about
    :data:`STREAM_PART_CHARS`), ``robots`` (filled meanwhile) last.
    """
    head = {k: v for k, v in payload.items() if k not in ('rows', 'robots')}
    parts = [_dumps(head)[:-1] + ',"rows":[']
    size = 0
    for number, row in enumerate(payload['rows']):
        parts.append((',' if number else '') + _dumps(row))
        size += len(parts[-1])
        if size >= STREAM_PART_CHARS:  # one write per part, not per row
            yield ''.join(parts).encode()
            parts, size = [], 0
    parts.append('],"robots":' + _dumps(payload['robots']) + '}')
    yield ''.join(parts).encode()


def fleet_etag(history: Any, *, now_s: float, query: str,
               parameter_sets: Optional[ParameterSets] = None,
               reescalation_margin: float = DEFAULT_REESCALATION_MARGIN,
               forecast_horizon_s: float = DEFAULT_FORECAST_HORIZON_DAYS * DAY_S,
               source: str = '') -> str:
    """
    Return an ETag of the fleet at ``now_s`` without reading its rows (index reads only).

    The history's newest ids (a new row changes them) and the next stored time of each kind
    the clock will pass (stale moments, crossing dates, planned dates: a tag changes when one
    passes), with the query and the settings: equal tags, equal documents.  ``source``: log
    the re-escalations first (see :func:`fleet_json`).
    """
    index = history.fleet_index()
    clock = fleet_clock(index, now_s=now_s, reescalation_margin=reescalation_margin,
                        forecast_horizon_s=forecast_horizon_s, parameter_sets=parameter_sets)
    if source:  # logged first: the tag is that of the history the rows are read from
        log_reescalations(history, clock, parameter_sets=parameter_sets, source=source)
    text = repr((history.path, index.marks(), index.next_times(clock), query,
                 reescalation_margin, forecast_horizon_s))
    return f'"{hashlib.sha256(text.encode()).hexdigest()[:32]}"'


def robot_choices(history: Any, *, search: str, limit: int = ROBOT_CHOICES) -> dict[str, Any]:
    """Return the robots whose name holds ``search`` (prefix matches first), at most ``limit``."""
    index = history.fleet_index()
    found = index.robots(search=search, limit=limit + 1)
    return {'search': search, 'robots': found[:limit], 'more': len(found) > limit}


def fleet_page_url(fleet: dict[str, Any], page: int) -> str:
    """Return the fleet page's address of ``page``, with the fleet's filters and page size."""
    query = {'robot': fleet['robot'], 'state': fleet['state'], 'page': page,
             'limit': fleet['limit'] if fleet['limit'] != PAGE_ROWS else None}
    return '/?' + urlencode({k: v for k, v in query.items() if v is not None})


def page_links(fleet: dict[str, Any]) -> list[dict[str, Any]]:
    """
    Return the links of the fleet page's pager: previous, the pages near, first, last, next.

    Each: ``text``, ``url`` (None: not a link, the page shown or a gap), ``rel``.
    """
    page, pages = fleet['page'], fleet['pages']
    if pages <= 1:
        return []
    near = sorted({1, pages, *range(max(1, page - 2), min(pages, page + 2) + 1)})
    links = [{'text': '\u2039 previous', 'url': fleet_page_url(fleet, page - 1)
              if page > 1 else None, 'rel': 'prev'}]
    for index, number in enumerate(near):
        if index and number > near[index - 1] + 1:
            links.append({'text': '\u2026', 'url': None, 'rel': 'gap'})
        links.append({'text': str(number), 'rel': 'current' if number == page else 'page',
                      'url': None if number == page else fleet_page_url(fleet, number)})
    links.append({'text': 'next \u203a', 'url': fleet_page_url(fleet, page + 1)
                  if page < pages else None, 'rel': 'next'})
    return links
