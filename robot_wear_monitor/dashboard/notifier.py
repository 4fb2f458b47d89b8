"""
``dashboard --notify CONFIG``: the notification loop of ``notify`` inside the server.

The configuration is read once at start (an error stops the start); every
``notify_interval_s`` a background task runs one pass of
:func:`robot_wear_monitor.fleet.notifications.notify_once` in a worker thread, on a history
of its own.  A notification is sent once per event, also across restarts: the history keeps
what was sent.  A failed pass is logged and the loop goes on.
"""

from __future__ import annotations

import asyncio
from contextlib import asynccontextmanager
import logging
import time
from typing import Any, AsyncIterator

from robot_wear_monitor.display_time import time_zone
from robot_wear_monitor.history import open_history

LOGGER = logging.getLogger('robot_wear_monitor.dashboard')


def load_config(path: str) -> Any:
    """Return the notification configuration of ``path`` (NotificationConfigError when bad)."""
    # deferred import: start-up time (fleet.notifications: only when notifying)
    from robot_wear_monitor.fleet.notifications import load_notification_config
    return load_notification_config(path)


def notify_pass(*, location: str, config: Any, parameter_sets: Any = None,
                zone: Any = None, marks: Any = None) -> int:
    """
    Run one notification pass on the history at ``location``; return the notices sent.

    ``parameter_sets``: the dashboard's (``--params``), for the rows without a stored threshold;
    ``zone``: its ``display_timezone``'s, for the texts' times.
    ``marks``: the loop's :class:`~robot_wear_monitor.fleet.notify_marks.PassMarks` (a pass
    reads what changed since the last one; None: every joint).
    """
    # deferred import: start-up time (fleet.notifications: only when notifying)
    from robot_wear_monitor.fleet.notifications import notify_once
    with open_history(location, init=False) as history:
        sent = notify_once(history=history, config=config, now_s=time.time(),
                           parameter_sets=parameter_sets, zone=zone, marks=marks)
    return len(sent)


async def notification_loop(*, location: str, config: Any, interval_s: float,
                            parameter_sets: Any = None, zone: Any = None) -> None:
    """Run a notification pass every ``interval_s`` [s] until cancelled (reading changes)."""
    # deferred import: start-up time (fleet.notify_marks: only when notifying)
    from robot_wear_monitor.fleet.notify_marks import PassMarks
    marks = PassMarks()  # the first pass reads every joint, the next what changed since
    while True:
        try:
            count = await asyncio.to_thread(notify_pass, location=location, config=config,
                                            parameter_sets=parameter_sets, zone=zone,
                                            marks=marks)
            if count:
                LOGGER.info('notifications: %d sent', count)
        except asyncio.CancelledError:
            raise
        except Exception as error:  # noqa: BLE001 - one failed pass must not stop the server
            LOGGER.warning('notifications: the pass failed: %s', str(error)[:200])
        await asyncio.sleep(interval_s)


@asynccontextmanager
async def notification_lifespan(app: Any) -> AsyncIterator[None]:
    """Run the notification loop while the app runs (when configured); close the histories."""
    settings = app.state.settings
    task = None
    if settings.notifications is not None:
        task = asyncio.create_task(notification_loop(
            location=settings.history, config=settings.notifications,
            interval_s=settings.notify_interval_s,
            parameter_sets=getattr(app.state, 'parameter_sets', None),
            zone=time_zone(settings.display_timezone)))
    try:
        yield
    finally:
        if task is not None:
            task.cancel()
            try:
                await task
            except asyncio.CancelledError:
                pass
        app.state.pool.close()
