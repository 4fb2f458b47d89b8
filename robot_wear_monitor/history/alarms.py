"""
Alarm events of the wear history: acknowledge and reset by people, the fleet's alarm log.

The latch of a robot's joint is its last ``raised`` or ``reset`` event: latched when that is a
raise.  An ``acknowledged`` event (schema version 5) is a remark on a latched alarm (who takes
it on, the planned maintenance date, the work order (version 7), a comment): it never unlatches
it.  Since version 7 an acknowledgement can be edited (``acknowledgement_edited``: who, when
and the values after the edit) or withdrawn (``acknowledgement_withdrawn``: who, when, why);
the alarm is acknowledged while the last of these events after its last raise is not a
withdrawal, and the current acknowledgement is that event.  A reset stored here looks to a
restarted estimator exactly like the ROS ``~/reset_alarm``: a ``reset`` event tied to the
joint's latest estimate, so that the evidence restores as 0 and the trend restarts there.
A person may reset a joint at any time (schema version 9): maintenance or a replacement done
before any alarm starts the joint's new life just as a reset of a latched alarm does; only a
second reset with no experiment since the first is refused (nothing new to reset).  Every
person's event names its ``source`` (web, api, cli, ros) and an edit what it changed.

Each check and its write are one transaction, serialised per robot and joint (SQLite
``BEGIN IMMEDIATE``, PostgreSQL an advisory transaction lock), so two people acknowledging or
resetting at once store one event and the other gets a clear :class:`HistoryError`.
"""

from __future__ import annotations

import datetime
import math
import re
import time
from typing import Any, Optional, Sequence

from robot_wear_monitor.history import fleet_index
from robot_wear_monitor.history.backends import HistoryBackend, lock_key
from robot_wear_monitor.history.records import (  # noqa: F401 - the SQL handed on
    ACKNOWLEDGEMENT_SQL, ALARM_EVENT_KINDS, AlarmEvent, EVENT_SOURCES, HistoryError,
    LATCH_EVENTS)
from robot_wear_monitor.json_values import finite_or_none

#: The columns of an alarm event, in the order of :func:`event_from_row`.
EVENT_COLUMNS = ('id, robot, joint, stamp_s, wall_time_s, event, wear, note, estimate_id, '
                 'user_name, owner, planned_maintenance, work_order, source, changes')
#: Longest note (a reason, a comment) [characters].
MAX_NOTE_CHARS = 2000
#: Longest user or owner name [characters].
MAX_PERSON_CHARS = 128
#: Longest work order [characters].
MAX_WORK_ORDER_CHARS = 128

_ISO_DATE = re.compile(r'\d{4}-\d{2}-\d{2}')


class AlarmStateError(HistoryError):
    """The joint's alarm is not in the state the action needs (no latch, acknowledged...)."""


class UnknownJointError(HistoryError):
    """The history holds no estimate of the robot's joint (an action on it is refused)."""


def event_from_row(row: Sequence[Any]) -> AlarmEvent:
    """Return the :class:`AlarmEvent` of a row of :data:`EVENT_COLUMNS`."""
    return AlarmEvent(id=int(row[0]), robot=row[1], joint=row[2], stamp_s=float(row[3]),
                      wall_time_s=float(row[4]), event=row[5],
                      wear=None if row[6] is None else float(row[6]), note=row[7],
                      estimate_id=None if row[8] is None else int(row[8]),
                      user=row[9] or '', owner=row[10] or '', planned_maintenance=row[11] or '',
                      work_order=row[12] or '', source=row[13] or '',
                      changes=row[14] or '')


def insert_event(backend: HistoryBackend, event: AlarmEvent, *, robot: str, joint: str,
                 estimate_id: Optional[int], wall_time_s: Optional[float] = None,
                 refresh: bool = True) -> AlarmEvent:
    """
    Store ``event`` of (robot, joint) in the open transaction; return it as stored.

    ``refresh``: store the joint's new ranking keys too (:func:`fleet_index.refresh`; False:
    the caller does, once for an estimate and its events).
    """
    if event.event not in ALARM_EVENT_KINDS:
        raise HistoryError(f'{backend.name}: alarm event must be one of '
                           f'{", ".join(ALARM_EVENT_KINDS)}, got {str(event.event)[:80]!r}')
    now = time.time() if wall_time_s is None else float(wall_time_s)
    values = (robot, joint, float(event.stamp_s), now, event.event, finite_or_none(event.wear),
              estimate_id, str(event.note)[:MAX_NOTE_CHARS], str(event.user)[:MAX_PERSON_CHARS],
              str(event.owner)[:MAX_PERSON_CHARS],
              check_planned_maintenance(event.planned_maintenance),
              check_work_order(event.work_order), check_source(event.source),
              str(event.changes)[:MAX_NOTE_CHARS])
    rows = backend.execute(
        'INSERT INTO alarm_events (robot, joint, stamp_s, wall_time_s, event, wear, '
        'estimate_id, note, user_name, owner, planned_maintenance, work_order, source, '
        'changes) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id', values)
    if refresh:
        fleet_index.refresh(backend, robot=robot, joint=joint)
    return AlarmEvent(id=int(rows[0][0]), robot=robot, joint=joint, stamp_s=values[2],
                      wall_time_s=now, event=event.event, wear=values[5], note=values[7],
                      estimate_id=estimate_id, user=values[8], owner=values[9],
                      planned_maintenance=values[10], work_order=values[11],
                      source=values[12], changes=values[13])


def check_source(value: Any) -> str:
    """Return an event's source (one of :data:`EVENT_SOURCES`, or ''); else HistoryError."""
    text = '' if value is None else str(value)
    if text and text not in EVENT_SOURCES:
        raise HistoryError(f'the event source must be one of {", ".join(EVENT_SOURCES)}, got '
                           f'{text[:40]!r}')
    return text


def check_work_order(value: Any) -> str:
    """Return a work order (1-128 printable characters, '' for none); else HistoryError."""
    text = '' if value is None else str(value).strip()
    if len(text) > MAX_WORK_ORDER_CHARS or not text.isprintable():
        raise HistoryError(f'the work order must be at most {MAX_WORK_ORDER_CHARS} printable '
                           f'characters, got {text[:40]!r}')
    return text


def check_planned_maintenance(value: Any) -> str:
    """Return a planned maintenance date as 'YYYY-MM-DD' ('' for none); else HistoryError."""
    text = '' if value is None else str(value).strip()
    if not text:
        return ''
    try:
        if not _ISO_DATE.fullmatch(text):
            raise ValueError
        datetime.date.fromisoformat(text)
    except ValueError:
        raise HistoryError('the planned maintenance date must be an ISO date YYYY-MM-DD, got '
                           f'{text[:40]!r}') from None
    return text


def _person(what: str, value: Any) -> str:
    text = value.strip() if isinstance(value, str) else ''
    if not text or len(text) > MAX_PERSON_CHARS or not text.isprintable():
        raise HistoryError(f'the {what} must be a name of 1-{MAX_PERSON_CHARS} printable '
                           f'characters, got {str(value)[:40]!r}')
    return text


def _note(what: str, value: Any, *, required: bool) -> str:
    text = value.strip() if isinstance(value, str) else None
    if text is None or '\x00' in text or len(text) > MAX_NOTE_CHARS or (required and not text):
        need = 'a non-empty text' if required else 'a text'
        raise HistoryError(f'the {what} must be {need} of at most {MAX_NOTE_CHARS} characters '
                           f'without NUL, got {str(value)[:40]!r}')
    return text


def action_lock(robot: str, joint: str) -> int:
    """Return the key of the transaction lock of (robot, joint) around its latch."""
    # not the writer lock's key: an estimator holds that one for its whole run
    return lock_key(f'alarm action\0{robot}', joint)


def latch_events(backend: HistoryBackend, *, robot: str, joint: str
                 ) -> tuple[Optional[AlarmEvent], Optional[AlarmEvent]]:
    """
    Return the latch of (robot, joint): its last raise/reset and the acknowledgement after.

    The acknowledgement is the last acknowledgement or edit that follows a latched raise
    (None otherwise, and None when the last such event is a withdrawal).
    """
    rows = backend.execute(
        f'SELECT {EVENT_COLUMNS} FROM alarm_events WHERE robot = ? AND joint = ? AND '
        f'{LATCH_EVENTS} ORDER BY id DESC LIMIT 1', (robot, joint))
    latch = event_from_row(rows[0]) if rows else None
    if latch is None or latch.event != 'raised':
        return latch, None
    rows = backend.execute(
        f'SELECT {EVENT_COLUMNS} FROM alarm_events WHERE robot = ? AND joint = ? AND '
        f'{ACKNOWLEDGEMENT_SQL} AND id > ? ORDER BY id DESC LIMIT 1', (robot, joint, latch.id))
    current = event_from_row(rows[0]) if rows else None
    if current is not None and current.event == 'acknowledgement_withdrawn':
        current = None
    return latch, current


def _latest_estimate(backend: HistoryBackend, robot: str,
                     joint: str) -> tuple[Optional[int], Optional[float]]:
    rows = backend.execute('SELECT id, wear FROM estimates WHERE robot = ? AND joint = ? '
                           'ORDER BY id DESC LIMIT 1', (robot, joint))
    return (int(rows[0][0]), float(rows[0][1])) if rows else (None, None)


def _known_joint(backend: HistoryBackend, robot: str,
                 joint: str) -> tuple[int, Optional[float]]:
    """Return the joint's latest estimate (id, w-hat); :class:`UnknownJointError` if none."""
    estimate_id, wear = _latest_estimate(backend, robot, joint)
    if estimate_id is None:
        raise UnknownJointError(f'{backend.name}: no estimates of robot {robot[:80]!r} joint '
                                f'{joint[:80]!r}')
    return estimate_id, wear


def _no_latch(name: str, robot: str, joint: str, what: str) -> HistoryError:
    return AlarmStateError(f'{name}: robot {robot[:80]!r} joint {joint[:80]!r} has no '
                           f'latched alarm to {what}')


def _acknowledgement_fields(user: str, owner: str, comment: str, planned_maintenance: str,
                            work_order: str) -> tuple[str, str, str, str, str]:
    """Return (user, owner, comment, planned date, work order) checked, or HistoryError."""
    return (_person('user', user), _person('owner', owner),
            _note('comment', comment, required=False),
            check_planned_maintenance(planned_maintenance), check_work_order(work_order))


def acknowledge_alarm(backend: HistoryBackend, *, robot: str, joint: str, user: str, owner: str,
                      comment: str, planned_maintenance: str = '', work_order: str = '',
                      source: str = '') -> AlarmEvent:
    """
    Store an acknowledgement of the latched alarm of (robot, joint); return the event.

    Raises :class:`HistoryError` when the joint has no latched alarm, when it is acknowledged
    already, or on bad text (see :meth:`WearHistory.acknowledge_alarm`).
    """
    user, owner, comment, planned, order = _acknowledgement_fields(
        user, owner, comment, planned_maintenance, work_order)
    with backend.transaction():
        backend.lock_in_transaction(action_lock(robot, joint))
        _known_joint(backend, robot, joint)
        latch, acknowledged = latch_events(backend, robot=robot, joint=joint)
        if latch is None or latch.event != 'raised':
            raise _no_latch(backend.name, robot, joint, 'acknowledge')
        if acknowledged is not None:
            raise AlarmStateError(f'{backend.name}: the alarm of robot {robot[:80]!r} joint '
                                  f'{joint[:80]!r} is already acknowledged by '
                                  f'{acknowledged.user[:80]!r}')
        estimate_id, wear = _latest_estimate(backend, robot, joint)
        now = time.time()
        return insert_event(backend, AlarmEvent(
            joint=joint, stamp_s=now, event='acknowledged', wear=wear, note=comment,
            user=user, owner=owner, planned_maintenance=planned, work_order=order,
            source=source),
            robot=robot, joint=joint, estimate_id=estimate_id, wall_time_s=now)


def edit_acknowledgement(backend: HistoryBackend, *, robot: str, joint: str, user: str,
                         owner: Optional[str] = None, comment: Optional[str] = None,
                         planned_maintenance: Optional[str] = None,
                         work_order: Optional[str] = None, source: str = '') -> AlarmEvent:
    """
    Store an edit of the current acknowledgement of (robot, joint); return the event.

    Only the fields given change (None keeps the current value: an edit that sends the owner
    alone keeps the comment, the planned date and the work order).  The event carries the
    acknowledgement as it stands after the edit, ``user`` (who edited), ``changes`` (what
    changed, 'field: old -> new' joined by '; ') and the wear the acknowledgement was made at
    (an edit acknowledges no new wear).  Raises :class:`HistoryError` when the alarm is not
    acknowledged, when the edit changes nothing, or on bad text.
    """
    user = _person('user', user)
    given = {'owner': None if owner is None else _person('owner', owner),
             'comment': None if comment is None else _note('comment', comment, required=False),
             'planned_maintenance': None if planned_maintenance is None
             else check_planned_maintenance(planned_maintenance),
             'work_order': None if work_order is None else check_work_order(work_order)}
    with backend.transaction():
        backend.lock_in_transaction(action_lock(robot, joint))
        _known_joint(backend, robot, joint)
        current = _current_acknowledgement(backend, robot, joint, 'edit')
        before = {'owner': current.owner, 'comment': current.note,
                  'planned_maintenance': current.planned_maintenance,
                  'work_order': current.work_order}
        after = {k: before[k] if v is None else v for k, v in given.items()}
        changes = '; '.join(f'{k}: {_shown(before[k])} -> {_shown(after[k])}'
                            for k in before if before[k] != after[k])
        if not changes:
            raise AlarmStateError(f'{backend.name}: the edit of the acknowledgement of robot '
                                  f'{robot[:80]!r} joint {joint[:80]!r} changes nothing')
        estimate_id, _ = _latest_estimate(backend, robot, joint)
        now = time.time()
        return insert_event(backend, AlarmEvent(
            joint=joint, stamp_s=now, event='acknowledgement_edited', wear=current.wear,
            note=after['comment'], user=user, owner=after['owner'],
            planned_maintenance=after['planned_maintenance'], work_order=after['work_order'],
            source=source, changes=changes),
            robot=robot, joint=joint, estimate_id=estimate_id, wall_time_s=now)


def _shown(value: str) -> str:
    """Return a value in an edit's ``changes``: quoted, cut at 60 characters ('' as none)."""
    return repr(value[:60]) if value else 'none'


def withdraw_acknowledgement(backend: HistoryBackend, *, robot: str, joint: str, user: str,
                             reason: str, source: str = '') -> AlarmEvent:
    """
    Withdraw the current acknowledgement of (robot, joint), with a reason; return the event.

    The alarm stays latched and is unacknowledged again (it may be acknowledged anew).
    Raises :class:`HistoryError` when the alarm is not acknowledged or on bad text.
    """
    user = _person('user', user)
    reason = _note('withdrawal reason', reason, required=True)
    with backend.transaction():
        backend.lock_in_transaction(action_lock(robot, joint))
        _known_joint(backend, robot, joint)
        current = _current_acknowledgement(backend, robot, joint, 'withdraw')
        estimate_id, wear = _latest_estimate(backend, robot, joint)
        now = time.time()
        return insert_event(backend, AlarmEvent(
            joint=joint, stamp_s=now, event='acknowledgement_withdrawn', wear=wear, note=reason,
            user=user, owner=current.owner, planned_maintenance=current.planned_maintenance,
            work_order=current.work_order, source=source), robot=robot, joint=joint,
            estimate_id=estimate_id, wall_time_s=now)


def _current_acknowledgement(backend: HistoryBackend, robot: str, joint: str,
                             what: str) -> AlarmEvent:
    latch, current = latch_events(backend, robot=robot, joint=joint)
    if latch is None or latch.event != 'raised':
        raise _no_latch(backend.name, robot, joint, what + ' the acknowledgement of')
    if current is None:
        raise AlarmStateError(f'{backend.name}: the alarm of robot {robot[:80]!r} joint '
                              f'{joint[:80]!r} is not acknowledged: nothing to {what}')
    return current


def reset_alarm(backend: HistoryBackend, *, robot: str, joint: str, user: str, reason: str,
                stamp_s: Optional[float] = None, work_order: str = '',
                source: str = '') -> AlarmEvent:
    """
    Store a reset of (robot, joint) after maintenance or a replacement; return it.

    With or without a latched alarm (a preventive replacement is a new life too).  The event
    is tied to the joint's latest estimate, as the ROS reset service ties it: a restarted
    estimator restores evidence 0 and restarts the trend after that estimate.  Raises
    :class:`UnknownJointError` when the history holds no estimate of the joint,
    :class:`AlarmStateError` when the joint was reset already and no experiment followed
    (nothing new to reset: a second click, or two people at once), :class:`HistoryError`
    on bad text.
    """
    user = _person('user', user)
    reason = _note('reset reason', reason, required=True)
    order = check_work_order(work_order)
    now = time.time()
    stamp = now if stamp_s is None else float(stamp_s)
    if not math.isfinite(stamp):
        raise HistoryError(f'the reset stamp must be a finite time [s], got {stamp_s!r}')
    with backend.transaction():
        backend.lock_in_transaction(action_lock(robot, joint))
        estimate_id, _ = _known_joint(backend, robot, joint)
        latch, _ = latch_events(backend, robot=robot, joint=joint)
        if latch is not None and latch.event == 'reset' and latch.estimate_id == estimate_id:
            by = f' by {latch.user[:80]!r}' if latch.user else ''
            raise AlarmStateError(f'{backend.name}: robot {robot[:80]!r} joint {joint[:80]!r} '
                                  f'was reset already{by} and awaits its first experiment: '
                                  'nothing new to reset')
        return insert_event(backend, AlarmEvent(
            joint=joint, stamp_s=stamp, event='reset', wear=None, note=reason, user=user,
            work_order=order, source=source),
            robot=robot, joint=joint, estimate_id=estimate_id, wall_time_s=now)


#: An event's time in the alarm log: a raise's experiment stamp, else the wall clock when a
#: person (or the ROS service) acknowledged or reset [s since the epoch].
EVENT_TIME = "CASE WHEN event = 'raised' THEN stamp_s ELSE wall_time_s END"


def event_time_s(event: AlarmEvent) -> float:
    """Return the time of ``event`` in the alarm log (:data:`EVENT_TIME`) [s since the epoch]."""
    return float(event.stamp_s if event.event == 'raised' else event.wall_time_s)


def alarm_log(backend: HistoryBackend, *, robot: Optional[str] = None, joint: Optional[str] = None,
              limit: Optional[int] = None, before_id: Optional[int] = None,
              stored_after_s: Optional[float] = None) -> list[AlarmEvent]:
    """
    Return the fleet's alarm events, newest first by event time (:data:`EVENT_TIME`).

    Whatever order the recordings were replayed in: a raise counts at its experiment's time,
    an acknowledgement or a reset at the moment it was made; the id breaks ties.
    ``robot``/``joint`` keep one robot's or one joint's events (a joint name of every robot
    when ``robot`` is None); ``before_id`` keeps the events after that event in this order
    (the next page); ``limit`` at most that many; ``stored_after_s`` only the events stored
    after that wall time [s since the epoch] (for a system that polls: a raise replayed late
    is new to it although its event time is old).
    """
    conditions: list[str] = []
    params: list[Any] = []
    for column, value in (('robot', robot), ('joint', joint)):
        if value is not None:
            conditions.append(f'{column} = ?')
            params.append(str(value))
    if before_id is not None:
        conditions.append(f'(({EVENT_TIME}) < (SELECT {EVENT_TIME} FROM alarm_events WHERE '
                          f'id = ?) OR (({EVENT_TIME}) = (SELECT {EVENT_TIME} FROM alarm_events '
                          'WHERE id = ?) AND id < ?))')
        before = _positive('before_id', before_id)
        params += [before, before, before]
    if stored_after_s is not None:
        if not math.isfinite(float(stored_after_s)):
            raise HistoryError(f'the alarm log since must be a finite time [s], got '
                               f'{str(stored_after_s)[:40]!r}')
        conditions.append('wall_time_s > ?')
        params.append(float(stored_after_s))
    query = f'SELECT {EVENT_COLUMNS} FROM alarm_events'
    if conditions:
        query += ' WHERE ' + ' AND '.join(conditions)
    query += f' ORDER BY {EVENT_TIME} DESC, id DESC'
    if limit is not None:
        query += ' LIMIT ?'
        params.append(_positive('limit', limit))
    return [event_from_row(row) for row in backend.execute(query, params)]


def resolved_raises(backend: HistoryBackend) -> list[tuple[str, str, float, float, int]]:
    """
    Return the alarms a reset resolved: per joint whose latch is a reset, the raise before it.

    Rows (robot, joint, the raise's stamp [s], the reset's wall time [s], the reset's id), one
    query for the fleet (a reset with no raise since the reset before it resolves nothing:
    a joint reset without an alarm is left out).
    """
    rows = backend.execute(
        'SELECT a.robot, a.joint, r.stamp_s, a.wall_time_s, a.id FROM alarm_events a JOIN '
        f'(SELECT MAX(id) AS last_id FROM alarm_events WHERE {LATCH_EVENTS} '
        'GROUP BY robot, joint) l ON a.id = l.last_id JOIN alarm_events r ON r.id = '
        '(SELECT MAX(p.id) FROM alarm_events p WHERE p.robot = a.robot AND p.joint = a.joint '
        "AND p.event = 'raised' AND p.id < a.id) WHERE a.event = 'reset' AND NOT EXISTS "
        '(SELECT 1 FROM alarm_events q WHERE q.robot = a.robot AND q.joint = a.joint AND '
        "q.event = 'reset' AND q.id > r.id AND q.id < a.id)")
    return [(r[0], r[1], float(r[2]), float(r[3]), int(r[4])) for r in rows]


_NUMBER = r'(-?[0-9.]+(?:e[-+]?[0-9]+)?|unknown|nan)'
#: The note of a raise by the ``trend`` rule (the estimator's ``_raise_note``).
_TREND_NOTE = re.compile(rf'trend P\(w >= {_NUMBER}\) = {_NUMBER} >= {_NUMBER}; trend w '
                         rf'{_NUMBER} \[{_NUMBER}, {_NUMBER}\], w-hat {_NUMBER}')
#: The note of a raise by the ``estimate`` rule.
_ESTIMATE_NOTE = re.compile(rf'w-hat {_NUMBER} >= {_NUMBER}, evidence {_NUMBER}')


def _percent(text: str) -> str:
    try:
        value = float(text)
    except ValueError:
        return text
    return f'{100.0 * value:.0f} %' if math.isfinite(value) else 'unknown'


def note_text(event: AlarmEvent) -> str:
    """
    Return the note of ``event`` in words.

    A raise: the rule and the numbers that raised it ("the trend's chance of w >= 35 reached
    21 % (rule: 15 %)", or "w-hat 36.2 reached the wear threshold 35 (alarm evidence 4.5)");
    an acknowledgement: who, for whom, the planned date and the comment; a reset: who and why.
    A note in another form is given as it is.
    """
    note = (event.note or '').strip()
    if event.event == 'raised':
        found = _TREND_NOTE.fullmatch(note)
        if found:
            threshold, chance, rule, trend, low, high, wear = found.groups()
            return (f"the trend's chance of w >= {threshold} reached {_percent(chance)} "
                    f'(rule: {_percent(rule)}); trend w {trend} [95 %: {low}, {high}], '
                    f'latest w-hat {wear}')
        found = _ESTIMATE_NOTE.fullmatch(note)
        if found:
            wear, threshold, evidence = found.groups()
            return (f'w-hat {wear} reached the wear threshold {threshold} (alarm evidence '
                    f'{evidence})')
        return note
    if event.event == 'acknowledged':
        text = f'acknowledged by {event.user or "someone"}'
        if event.owner and event.owner != event.user:
            text += f', taken on by {event.owner}'
        if event.planned_maintenance:
            text += f', maintenance planned {event.planned_maintenance}'
        return text + (f': {note}' if note else '')
    if event.event in ('acknowledgement_edited', 'acknowledgement_withdrawn'):
        what = 'edited' if event.event == 'acknowledgement_edited' else 'withdrawn'
        text = f'acknowledgement {what} by {event.user or "someone"}'
        if what == 'edited' and event.planned_maintenance:
            text += f', maintenance planned {event.planned_maintenance}'
        return text + (f': {note}' if note else '')
    if event.event == 'reescalated':
        return f're-escalated: {note}'
    if event.event == 'reset':
        who = f'reset by {event.user}' if event.user else 'reset'
        return f'{who}: {note}' if note else who
    return note


def _positive(what: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise HistoryError(f'the alarm log {what} must be an integer >= 1, got '
                           f'{str(value)[:40]!r}')
    return value
