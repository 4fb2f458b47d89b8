"""
Notifications sent, kept in the wear history (schema version 5): each event once.

A notifier claims an event before it sends it: the claim inserts one row under the event's
key (``INSERT ... ON CONFLICT DO NOTHING``, a unique key), so of any number of notifiers at
once, and across restarts, exactly one gets True and sends.  A notifier whose sending failed
for good may release its claim, so that a later pass tries again.

A claim made with a lease (``lease_s``, schema version 13) is pending until the notifier
settles it (:func:`settle_notification`, after the send, delivered or failed):
``pending_until_s`` holds the end of the lease, NULL once settled (and in the rows of older
versions).  A pending claim whose lease has passed belongs to a notifier that died between its
claim and the end of its send (a dashboard worker killed mid-pass): the next claim of the same
key takes it over in one statement (``ON CONFLICT ... DO UPDATE ... WHERE`` the lease has
passed), so of several notifiers exactly one sends it again; a settled claim is never taken.
"""

from __future__ import annotations

import json
import time
from typing import Any, Optional

from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.records import HistoryError

#: Longest event key [characters].
MAX_EVENT_KEY_CHARS = 512
_COLUMNS = ('id, event_key, robot, joint, kind, wall_time_s, channel, payload, '
            'pending_until_s')


def _event_key(value: Any) -> str:
    if not isinstance(value, str) or not value or len(value) > MAX_EVENT_KEY_CHARS \
            or '\x00' in value:
        raise HistoryError(f'a notification event key is a text of 1-{MAX_EVENT_KEY_CHARS} '
                           f'characters without NUL, got {str(value)[:40]!r}')
    return value


def claim_notification(backend: HistoryBackend, *, event_key: str, robot: Optional[str],
                       joint: Optional[str], kind: str, channel: str,
                       payload: dict[str, Any], lease_s: Optional[float] = None) -> bool:
    """
    Store the notification of ``event_key``; True when this call stored it (send it).

    False when the event was claimed before (by this or another notifier) and that claim is
    settled or its lease runs: do not send.  ``payload``: what is sent, as JSON (kept for the
    audit).  ``lease_s``: the claim stays pending this long [s] unless settled (None: settled
    at once); a pending claim past its lease is taken over (True).
    """
    key = _event_key(event_key)
    try:
        body = json.dumps(payload, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise HistoryError(f'the payload of notification {key[:80]!r} is not JSON: '
                           f'{error}') from None
    now = time.time()
    until = None if lease_s is None else now + float(lease_s)
    with backend.transaction():
        rows = backend.execute(
            'INSERT INTO notifications (event_key, robot, joint, kind, wall_time_s, channel, '
            'payload, pending_until_s) VALUES (?, ?, ?, ?, ?, ?, ?, ?) '
            'ON CONFLICT (event_key) DO UPDATE SET robot = excluded.robot, '
            'joint = excluded.joint, kind = excluded.kind, wall_time_s = excluded.wall_time_s, '
            'channel = excluded.channel, payload = excluded.payload, '
            'pending_until_s = excluded.pending_until_s '
            'WHERE notifications.pending_until_s IS NOT NULL '
            'AND notifications.pending_until_s < excluded.wall_time_s RETURNING id',
            (key, robot, joint, str(kind), now, str(channel), body, until))
    return bool(rows)


def settle_notification(backend: HistoryBackend, *, event_key: str) -> bool:
    """End the lease of the claim of ``event_key`` (its send ended); True when it was pending."""
    with backend.transaction():
        rows = backend.execute('UPDATE notifications SET pending_until_s = NULL WHERE '
                               'event_key = ? AND pending_until_s IS NOT NULL RETURNING id',
                               (_event_key(event_key),))
    return bool(rows)


def release_notification(backend: HistoryBackend, *, event_key: str) -> bool:
    """Remove the claim of ``event_key`` (its sending failed); True when there was one."""
    with backend.transaction():
        rows = backend.execute('DELETE FROM notifications WHERE event_key = ? RETURNING id',
                               (_event_key(event_key),))
    return bool(rows)


def list_notifications(backend: HistoryBackend, *,
                       limit: Optional[int] = None) -> list[dict[str, Any]]:
    """Return the notifications sent, newest first, as dicts (``payload`` parsed)."""
    query = f'SELECT {_COLUMNS} FROM notifications ORDER BY id DESC'
    params: tuple = ()
    if limit is not None:
        if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
            raise HistoryError(f'the notifications limit must be an integer >= 1, got '
                               f'{str(limit)[:40]!r}')
        query += ' LIMIT ?'
        params = (limit,)
    out = []
    for row in backend.execute(query, params):
        out.append({'id': int(row[0]), 'event_key': row[1], 'robot': row[2], 'joint': row[3],
                    'kind': row[4], 'wall_time_s': row[5], 'channel': row[6],
                    'payload': json.loads(row[7]) if row[7] else None,
                    'pending_until_s': None if row[8] is None else float(row[8])})
    return out
