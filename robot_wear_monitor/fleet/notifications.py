"""
Notifications of the fleet's events: a webhook and e-mail, once per event, across restarts.

A pass (:func:`notify_once`) reads the fleet from the wear history (:func:`fleet_view` at
``now_s``) and finds the events that are due (:func:`due_events`), each with a key that is the
same on every pass and in every process:

* ``alarm_raised``: a latched alarm, one per raise (key ``alarm_raised/ROBOT/JOINT/STAMP``, the
  stamp of the raise [s]);
* ``forecast_crossing``: the forecast crossing of the wear threshold (the one the joint's
  latest estimate was judged by, stored with it: ``fleet/thresholds.py``; the fleet view's
  date, or the trend already past the threshold) at most ``forecast_horizon_days`` ahead of
  ``now_s``, once per alarm cycle (key ``forecast_crossing/ROBOT/JOINT/cycle-STAMP``, the stamp
  of the joint's last reset, ``cycle-0`` before the first); a crossing date that has passed
  without an alarm (``crossing_overdue``) is notified once more as overdue (key
  ``.../cycle-STAMP/overdue-DATE``);
* ``joint_stale``: no experiment for longer than the fleet view's stale limit, once per stale
  episode (key ``joint_stale/ROBOT/JOINT/last-STAMP``, the stamp of the last experiment).

* ``alarm_reescalated`` (sent when ``alarm_raised`` is configured): an acknowledged alarm back
  on top (:func:`~robot_wear_monitor.fleet.ranking.reescalation`: its wear rose
  ``reescalation_margin`` past its value at the acknowledgement, or its planned maintenance
  date passed), once per acknowledgement and reason (key
  ``alarm_reescalated/ROBOT/JOINT/ack-WALLTIME/margin`` or ``.../date-YYYY-MM-DD``: a date
  postponed by an edit and missed again is notified again);
* ``alarm_resolved`` (sent when ``alarm_raised`` is configured): the reset of a latched alarm
  after maintenance, as Alertmanager ``status: resolved`` with the fingerprint of the raise's
  alert, once per reset (key ``alarm_resolved/ROBOT/JOINT/reset-ID``), on the channels that
  were sent the raise (a reset of an alarm never notified sends nothing).

* ``alarm_acknowledged`` (sent when ``alarm_raised`` is configured): the dashboard's
  acknowledgement, once (key ``alarm_acknowledged/ROBOT/JOINT/ack-WALLTIME``);
* resolved (``RESOLVES``): an alert sent before whose key is no longer active (its cause ended:
  the crossing no longer due or a new cycle, a new experiment of a stale joint, a re-escalation
  acknowledged anew or reset, an acknowledged alarm reset) is sent once more as ``resolved``
  (key ``KIND/FIRING_KEY``), on the channels that were sent it.

An acknowledged alarm holds back the joint's other notifications (not ended: not resolved)
until it is reset.  The first pass on a channel (``first_pass_summary``) sends the events due
as one summary (:func:`_send_summary`).  After a reset the fleet row is the joint's new life
(no wear, trend, crossing or alarm of the old life; stale counted from the reset), so nothing
of the old life is notified.  Robot and joint names are percent-encoded in the keys (replaced
by their SHA-256 when very long).

Each event goes to every channel (``webhook:NAME``, ``email``) of the configuration.  Before a
send the notifier claims ``KEY@CHANNEL`` in the history (:meth:`WearHistory.claim_notification`,
a unique row): only the process whose claim inserted the row sends, so an event is sent once
also across restarts and with several notifiers (the dashboard's and a cron job) on one
history.  When every try of a send fails (see :class:`RetryPolicy`) the failure is stored as a
row ``KEY@CHANNEL#failed1`` (its payload holds the error) and the send is claimed and tried
again on the next pass (``KEY@CHANNEL#pass2``, ...) up to ``retry.passes`` passes in all; a
channel that failed is not tried again in the same pass (its other events wait for the next
one).  A claim is pending, with a lease (:func:`claim_lease_s`: the retry policy's
``total_s`` and :data:`CLAIM_MARGIN_S`), until its send has ended, delivered or failed; then it
is settled (:meth:`WearHistory.settle_notification`).  A notifier killed between its claim and
the end of its send (a dashboard worker that died mid-pass) leaves its claim pending: once the
lease has passed, the next pass of any notifier takes the claim over and sends (one notifier
does: the takeover is one statement).  Only a notifier killed in the instant between a
delivered send and its settling makes a second send after the lease.
"""

from __future__ import annotations

from dataclasses import dataclass
import hashlib
import logging
import math
import threading
import time
from typing import Any, Callable, Optional
from urllib.parse import quote

from robot_wear_monitor.display_time import Zone
from robot_wear_monitor.fleet.notify_channels import (
    describe_wear, DueEvent, email_message, email_subject, KINDS, post_webhook, RESOLVES,
    send_email, SendResult, summary_email, SUMMARY_KEY, summary_payload, webhook_payload)
from robot_wear_monitor.fleet.notify_config import (
    EmailConfig, EVENTS, load_notification_config, NotificationConfig,
    NotificationConfigError, RetryPolicy, WebhookConfig)
from robot_wear_monitor.fleet.notify_marks import advance, joints_to_read, PassMarks
from robot_wear_monitor.fleet.ranking import fleet_view, FleetView, STALE_FACTOR, threshold_text
from robot_wear_monitor.fleet.reescalation_log import try_log_reescalations
from robot_wear_monitor.fleet.thresholds import ParameterSets
from robot_wear_monitor.history import HistoryError, open_history, WearHistory
from robot_wear_monitor.text import iso_time, shorten, shown_time

__all__ = ['DueEvent', 'due_events', 'EmailConfig', 'EVENTS', 'KINDS',
           'load_notification_config', 'NotificationConfig', 'NotificationConfigError',
           'notify_forever', 'notify_once', 'RetryPolicy', 'SentNotification', 'WebhookConfig']

_LOG = logging.getLogger('robot_wear_monitor.notifications')
#: Longer percent-encoded robot/joint parts of a key are replaced by their SHA-256.
_MAX_WHERE_CHARS = 300


@dataclass(frozen=True)
class SentNotification:
    """
    One send of one event to one channel in a pass, delivered or not.

    ``event_key``: the event's key; ``claim_key``: the history row claimed for this send
    (``KEY@CHANNEL``, ``#passN`` for a retry on pass N); ``pass_number``: 1 for the first pass
    of the event on the channel; ``attempts``: tries within the pass; ``error``: the last one
    ('' when delivered).
    """

    event_key: str
    claim_key: str
    kind: str
    robot: str
    joint: str
    channel: str
    summary: str
    delivered: bool
    attempts: int
    pass_number: int
    error: str = ''
    #: the passes a failing send gets in all (``retry.passes``)
    passes: int = 1

    @property
    def retried_later(self) -> bool:
        """Return True when a failed send will be tried again on a later pass."""
        return not self.delivered and self.pass_number < self.passes

    def as_json(self) -> dict[str, Any]:
        """Return the send as a JSON-ready dict."""
        return {'event_key': self.event_key, 'claim_key': self.claim_key, 'kind': self.kind,
                'robot': self.robot, 'joint': self.joint, 'channel': self.channel,
                'summary': self.summary, 'delivered': self.delivered,
                'attempts': self.attempts, 'pass': self.pass_number, 'error': self.error or None,
                'retried_later': self.retried_later}


# --------------------------------------------------------------------------- events

def _name(text: str) -> str:
    return quote(text, safe='')


def _stamp(value: float) -> str:
    return f'{value:.6f}'


def _crossing_inside(view: FleetView, *, now_s: float, horizon_s: float) -> bool:
    crossing = view.state.crossing_experiments
    if not math.isfinite(crossing):
        return False
    if crossing <= 0:
        return True  # the trend is past the threshold already
    return view.crossing_time_s is not None and view.crossing_time_s <= now_s + horizon_s


def _cycle(history: WearHistory, *, robot: str, joint: str) -> str:
    resets = [e for e in history.events(joint=joint, robot=robot) if e.event == 'reset']
    return f'cycle-{_stamp(resets[-1].stamp_s)}' if resets else 'cycle-0'


def _facts(view: FleetView, zone: Zone = None) -> str:
    s = view.state
    lines = [f'Robot: {s.robot}', f'Joint: {s.joint}',
             f'Latest wear: {describe_wear(view)} (0 new .. 100 failure)',
             f'Wear threshold: {threshold_text(view)} (the alarm level the latest estimate '
             'was judged by)']
    if math.isfinite(s.trend_wear):
        lines.append(f'Trend wear: {s.trend_wear:.1f}')
    crossing = s.crossing_experiments
    if math.isfinite(crossing):
        when = ' trend past the threshold' if crossing <= 0 else \
            f' in {crossing:.0f} experiments'
        if crossing > 0 and view.crossing_time_s is not None:
            when += f' (~{shown_time(view.crossing_time_s, zone=zone)})'
        lines.append(f'Forecast crossing of the wear threshold:{when}')
    if s.alarm:
        lines.append(f'Alarm latched since {shown_time(s.alarm_since_stamp_s, zone=zone)}')
    if math.isfinite(s.life_started_s):
        lines.append(f'New life since the reset {shown_time(s.life_started_s, zone=zone)} '
                     f'({s.experiments} experiments since)')
    lines.append(f'Last experiment: {shown_time(s.last_stamp_s, zone=zone)} '
                 f'({max(s.total_experiments, s.experiments)} in all)')
    return '\n'.join(lines)


def _where(robot: str, joint: str) -> str:
    where = f'{_name(robot)}/{_name(joint)}'
    if len(where) > _MAX_WHERE_CHARS:  # the history keeps keys of up to 512 characters
        where = 'sha256-' + hashlib.sha256(f'{robot}\x00{joint}'.encode()).hexdigest()
    return where


def due_events(*, history: WearHistory, config: NotificationConfig, now_s: float,
               parameter_sets: Optional[ParameterSets] = None,
               sent: Optional[dict[str, str]] = None, zone: Zone = None,
               joints: Optional[set[tuple[str, str]]] = None) -> list[DueEvent]:
    """
    Return the events due at ``now_s`` [s since the epoch] that the configuration names.

    Worst joint first (the fleet's order); see the module's text for the events and keys.
    Sent or not, an event stays due while its condition holds: :func:`notify_once` keeps it
    from being sent twice.  ``parameter_sets``: where a row without a stored threshold finds
    its parameter set's (None: the packaged sets; see :func:`fleet_view`).  ``sent``: the keys
    of the firing events sent before (key -> kind, from the history's log): each whose cause
    has ended (its key no longer active) is due as its ``resolved`` event (``RESOLVES``).
    ``zone``: the texts' times in the plant's ``display_timezone`` (None: UTC; keys stay UTC).
    ``joints``: read only these (robot, joint) (:mod:`~robot_wear_monitor.fleet.notify_marks`;
    the alerts of the others are left as they are); None: every joint.
    """
    events: list[DueEvent] = []
    #: keys whose cause holds now, sent or not, notified now or held back by an acknowledgement
    active: set[str] = set()
    views_by_joint: dict[tuple[str, str], FleetView] = {}
    rows = history.fleet() if joints is None else history.fleet_index().rows(sorted(joints))
    views = fleet_view(rows, now_s=now_s,
                       reescalation_margin=config.reescalation_margin,
                       parameter_sets=parameter_sets,
                       forecast_horizon_s=config.forecast_horizon_s)
    if 'alarm_raised' in config.events:  # the audit trail: each re-escalation, once
        try_log_reescalations(history, views, source='notify')
    resolved = ({(r[0], r[1]): r[2:] for r in history.resolved_raises()}
                if 'alarm_raised' in config.events else {})
    for view in views:
        s = view.state
        views_by_joint[(s.robot, s.joint)] = view
        where = _where(s.robot, s.joint)
        facts = _facts(view, zone)

        def add(kind: str, key: str, starts_s: float, summary: str, *, send: bool = True,
                **more: Any) -> None:
            active.add(f'{kind}/{where}/{key}')
            if send:
                events.append(DueEvent(kind=kind, key=f'{kind}/{where}/{key}', robot=s.robot,
                                       joint=s.joint, starts_s=starts_s,
                                       summary=f'{s.robot} {s.joint}: {summary}',
                                       description=facts, view=view, **more))
        ended = resolved.get((s.robot, s.joint))
        if ended is not None:
            raised_s, reset_wall_s, reset_id = ended
            by = f' by {s.reset_by}' if s.reset_by else ''
            why = f' ({s.reset_reason[:200]})' if s.reset_reason else ''
            add('alarm_resolved', f'reset-{reset_id}', raised_s,
                f'wear alarm resolved: reset{by}{why}, a new life',
                firing_key=f'alarm_raised/{where}/{_stamp(raised_s)}', ends_s=reset_wall_s)
        quiet = bool(s.acknowledged)  # its forecast and staleness: held back, not ended
        if s.acknowledged and 'alarm_raised' in config.events:
            ack = f'ack-{_stamp(s.acknowledged_wall_time_s)}'
            add('alarm_acknowledged', ack, s.acknowledged_wall_time_s,
                f'wear alarm acknowledged{_acknowledgement(s)}')
            if view.reescalated:
                reasons = [why for why, word in (
                    ('margin', 'rose'), (f'date-{s.planned_maintenance}', 'passed'))
                    if word in view.reescalated]
                for reason in reasons:
                    add('alarm_reescalated', f'{ack}/{reason}', now_s,
                        f'acknowledged wear alarm re-escalated: {view.reescalated}')
        if 'alarm_raised' in config.events and s.alarm and not s.acknowledged:
            add('alarm_raised', _stamp(s.alarm_since_stamp_s), s.alarm_since_stamp_s,
                f'wear alarm raised ({describe_wear(view)})')
        if 'forecast_crossing' in config.events and _crossing_inside(
                view, now_s=now_s, horizon_s=config.forecast_horizon_s):
            threshold = threshold_text(view)
            when = (f'the trend is past the wear threshold {threshold}'
                    if s.crossing_experiments <= 0
                    else f'the wear threshold {threshold} is forecast to be crossed by '
                         f'{shown_time(view.crossing_time_s, zone=zone)} (within '
                         f'{config.forecast_horizon_days:g} days)')
            cycle = _cycle(history, robot=s.robot, joint=s.joint)
            if view.crossing_overdue and view.crossing_time_s is not None:
                date = iso_time(view.crossing_time_s)[:10]
                day = shown_time(view.crossing_time_s, zone=zone, date_only=True)
                add('forecast_crossing', f'{cycle}/overdue-{date}', view.crossing_time_s,
                    f'the forecast crossing of the wear threshold is overdue since {day}: '
                    f'no experiment since {shown_time(s.last_stamp_s, zone=zone)} to '
                    'confirm it',
                    send=not quiet)
                active.add(f'forecast_crossing/{where}/{cycle}')  # still due, now overdue
            else:
                add('forecast_crossing', cycle, s.last_stamp_s, when, send=not quiet)
        if 'joint_stale' in config.events and view.stale:
            last = s.last_stamp_s
            if math.isfinite(s.life_started_s):
                last = max(last, s.life_started_s)  # a new life: counted from its reset
            since = last + STALE_FACTOR * s.usual_interval_s
            add('joint_stale', f'last-{_stamp(last)}', since,
                f'no experiment since {shown_time(last, zone=zone)} (usual interval '
                f'{s.usual_interval_s / 3600.0:.1f} h)', send=not quiet)
    if sent:
        events += _resolutions(sent=sent, active=active, views=views_by_joint,
                               config=config, now_s=now_s, zone=zone)
    return events


def _acknowledgement(s: Any) -> str:
    """Return who acknowledged the alarm and the planned maintenance date (for a summary)."""
    by = f' by {shorten(s.acknowledged_by, 60)}' if s.acknowledged_by else ''
    planned = (f', maintenance planned {s.planned_maintenance}'
               if s.planned_maintenance else '')
    return by + planned


def _resolutions(*, sent: dict[str, str], active: set[str],
                 views: dict[tuple[str, str], FleetView], config: NotificationConfig,
                 now_s: float, zone: Zone = None) -> list[DueEvent]:
    """Return the ``resolved`` events of the sent alerts whose cause has ended."""
    out = []
    for key, kind in sorted(sent.items()):
        ending = RESOLVES.get(kind)
        own = kind in config.events or kind in ('forecast_crossing', 'joint_stale')
        judged = kind if own else 'alarm_raised'
        if ending is None or key in active or judged not in config.events:
            continue  # still due, or a kind this configuration does not judge
        view = next((v for (robot, joint), v in views.items()
                     if key.startswith(f'{kind}/{_where(robot, joint)}/')), None)
        if view is None:
            continue  # a joint no longer in the history: nothing to say of it
        s = view.state
        why = {'forecast_resolved': 'the forecast crossing is no longer due',
               'stale_resolved': 'experiments again (the last '
                                 f'{shown_time(s.last_stamp_s, zone=zone)})',
               'reescalation_resolved': 'the re-escalation ended (acknowledged anew, or reset)',
               'acknowledgement_resolved': 'the acknowledged alarm ended (reset)'}[ending]
        if math.isfinite(s.life_started_s) and ending != 'stale_resolved':
            why += f'; a new life since the reset {shown_time(s.life_started_s, zone=zone)}'
        out.append(DueEvent(kind=ending, key=f'{ending}/{key}', robot=s.robot, joint=s.joint,
                            starts_s=now_s, summary=f'{s.robot} {s.joint}: resolved: {why}',
                            description=_facts(view, zone), view=view, firing_key=key,
                            ends_s=now_s))
    return out


# --------------------------------------------------------------------------- one pass

#: How long a claim outlasts the retry policy's ``total_s`` before another notifier takes a
#: claim left pending over (its notifier died mid-send) [s].
CLAIM_MARGIN_S = 300.0


def claim_lease_s(config: NotificationConfig) -> float:
    """Return how long a claimed send stays pending before another notifier may take it [s]."""
    return float(config.retry.total_s) + CLAIM_MARGIN_S


def _settled_log(rows: list[dict[str, Any]], *, wall_s: float) -> set[str]:
    """Return the claimed keys but those pending past their lease (their notifier died)."""
    return {str(row['event_key']) for row in rows
            if row.get('pending_until_s') is None or row['pending_until_s'] >= wall_s}


def _next_pass(base: str, log: set[str], passes: int) -> Optional[int]:
    """Return the pass number of the next send of ``base``; None when done (or given up)."""
    for number in range(1, passes + 1):
        if (base if number == 1 else f'{base}#pass{number}') not in log:
            return number
        if f'{base}#failed{number}' not in log:
            return None  # delivered (or being sent by another notifier)
    return None


def _send(event: DueEvent, channel: str, config: NotificationConfig,
          sleep: Callable[[float], None]) -> tuple[dict[str, Any], Callable[[], SendResult]]:
    if channel == 'email':
        mail = config.email
        if mail is None:
            raise ValueError('no e-mail channel configured')
        message = email_message(event, config=config, mail=mail)
        record = {'subject': email_subject(event), 'from': mail.sender, 'to': list(mail.to)}
        return record, lambda: send_email(mail, message, retry=config.retry, sleep=sleep)
    hook = next(h for h in config.webhooks if f'webhook:{h.name}' == channel)
    payload = webhook_payload(event, config=config, receiver=hook.receiver)
    return payload, lambda: post_webhook(hook, payload, retry=config.retry, sleep=sleep)


def notify_once(*, history: WearHistory, config: NotificationConfig, now_s: float,
                sleep: Callable[[float], None] = time.sleep,
                parameter_sets: Optional[ParameterSets] = None,
                zone: Zone = None,
                marks: Optional[PassMarks] = None) -> list[SentNotification]:
    """
    Send what is due at ``now_s`` [s since the epoch], once per event and channel.

    Returns the sends this call made (an empty list when nothing was due or every due event
    was sent already, by this process or another).  Failed sends are stored in the history
    and tried again on later passes (see the module's text).  Raises
    :class:`~robot_wear_monitor.history.HistoryError` when the history cannot be
    read or written; a channel that fails never raises.  ``parameter_sets``, ``zone``: see
    :func:`due_events`.  ``marks``: a notifier's marks of its last pass (kept across its
    passes): this pass reads only the joints that changed or that the clock moved since
    (:mod:`~robot_wear_monitor.fleet.notify_marks`); None: every joint.
    """
    rows = history.notifications()
    log = _settled_log(rows, wall_s=time.time())
    fired = {_base_key(key): str(row['kind']) for row in rows
             if '@' in (key := str(row['event_key']))}
    joints, after = (None, (0, 0)) if marks is None else joints_to_read(
        history, marks, now_s=now_s, horizon_s=config.forecast_horizon_s, log_rows=rows)
    events = due_events(history=history, config=config, now_s=now_s,
                        parameter_sets=parameter_sets, sent=fired, zone=zone,
                        joints=joints)
    if not events:
        if marks is not None:
            advance(marks, after, now_s=now_s)
        return []
    failed_channels: set[str] = set()
    sent: list[SentNotification] = []
    if config.first_pass_summary:
        used = {str(row['channel']) for row in rows}
        for channel in config.channels:
            if channel not in used and len(events) > 1:
                sent += _send_summary(events, channel=channel, history=history, config=config,
                                      sleep=sleep, failed_channels=failed_channels, log=log)
    for event in events:
        for channel in config.channels:
            base = f'{event.key}@{channel}'
            if event.resolved and f'{event.firing_key}@{channel}' not in log:
                continue  # the raise was never sent on this channel: nothing to resolve
            number = _next_pass(base, log, config.retry.passes)
            if number is None or channel in failed_channels:
                continue
            claim_key = base if number == 1 else f'{base}#pass{number}'
            record, send = _send(event, channel, config, sleep)
            if not history.claim_notification(event_key=claim_key, robot=event.robot,
                                              joint=event.joint, kind=event.kind,
                                              channel=channel, payload=record,
                                              lease_s=claim_lease_s(config)):
                continue  # another notifier has it
            try:
                result = send()
            except Exception as problem:  # a channel never stops the pass (claim kept)
                result = SendResult(delivered=False, attempts=1,
                                    error=f'{type(problem).__name__}: {str(problem)[:200]}')
            if not result.delivered:
                failed_channels.add(channel)
                history.claim_notification(
                    event_key=f'{base}#failed{number}', robot=event.robot, joint=event.joint,
                    kind=event.kind, channel=channel,
                    payload={'status': 'failed', 'error': result.error,
                             'attempts': result.attempts, 'pass': number,
                             'passes': config.retry.passes})
                _LOG.warning('%s: %s via %s failed after %d tries: %s', config.source,
                             event.key, channel, result.attempts, result.error)
            history.settle_notification(event_key=claim_key)  # the send has ended
            sent.append(SentNotification(
                event_key=event.key, claim_key=claim_key, kind=event.kind, robot=event.robot,
                joint=event.joint, channel=channel, summary=event.summary,
                delivered=result.delivered, attempts=result.attempts, pass_number=number,
                error=result.error, passes=config.retry.passes))
    if marks is not None:  # the pass went through: the next reads what changed after it
        advance(marks, after, now_s=now_s)
    return sent


def _base_key(claim_key: str) -> str:
    """Return the event key of a claim (``KEY@CHANNEL``, ``#passN`` / ``#failedN``)."""
    return claim_key.split('#', 1)[0].rsplit('@', 1)[0]


def _send_summary(events: list[DueEvent], *, channel: str, history: WearHistory,
                  config: NotificationConfig, sleep: Callable[[float], None],
                  failed_channels: set[str], log: set[str]) -> list[SentNotification]:
    """
    Send the first pass's events on ``channel`` as one summary; their claims say so.

    The summary is claimed (``first-pass-summary@CHANNEL``), then every event's
    ``KEY@CHANNEL`` (payload: the summary's key), so the events are not sent one by one and
    their later ``resolved`` ends the alerts the summary held.  When the send fails every
    claim is released: the next pass is again a first pass (a summary again).
    """
    summary_key = f'{SUMMARY_KEY}@{channel}'
    if channel == 'email':
        mail = config.email
        if mail is None:
            return []
        message = summary_email(events, config=config, mail=mail)
        record: dict[str, Any] = {'subject': message['Subject'], 'from': mail.sender,
                                  'to': list(mail.to), 'events': len(events)}

        def send() -> SendResult:
            return send_email(mail, message, retry=config.retry, sleep=sleep)
    else:
        hook = next(h for h in config.webhooks if f'webhook:{h.name}' == channel)
        record = summary_payload(events, config=config, receiver=hook.receiver)

        def send() -> SendResult:
            return post_webhook(hook, record, retry=config.retry, sleep=sleep)
    lease_s = claim_lease_s(config)
    if not history.claim_notification(event_key=summary_key, robot=None, joint=None,
                                      kind='first_pass_summary', channel=channel,
                                      payload=record, lease_s=lease_s):
        failed_channels.add(channel)  # another notifier sends it: nothing more here this pass
        return []
    claims = [summary_key]
    for event in events:
        key = f'{event.key}@{channel}'
        if history.claim_notification(event_key=key, robot=event.robot, joint=event.joint,
                                      kind=event.kind, channel=channel,
                                      payload={'in_summary': summary_key}, lease_s=lease_s):
            claims.append(key)
            log.add(key)
    try:
        result = send()
    except Exception as problem:  # a channel never stops the pass
        result = SendResult(delivered=False, attempts=1,
                            error=f'{type(problem).__name__}: {str(problem)[:200]}')
    if not result.delivered:
        failed_channels.add(channel)
        for key in claims:
            history.release_notification(event_key=key)
            log.discard(key)
        _LOG.warning('%s: the first-pass summary via %s failed after %d tries: %s',
                     config.source, channel, result.attempts, result.error)
    else:
        for key in claims:
            history.settle_notification(event_key=key)
    return [SentNotification(
        event_key=event.key, claim_key=summary_key, kind=event.kind, robot=event.robot,
        joint=event.joint, channel=channel, summary=event.summary,
        delivered=result.delivered, attempts=result.attempts, pass_number=1,
        error=result.error, passes=config.retry.passes) for event in events]


def notify_forever(*, location: str, config: NotificationConfig, interval_s: float,
                   stop: threading.Event,
                   report: Callable[[list[SentNotification]], None] = lambda sent: None,
                   on_error: Callable[[Exception], None] = lambda error: None,
                   clock: Callable[[], float] = time.time, zone: Zone = None) -> None:
    """
    Run a pass every ``interval_s`` [s] until ``stop`` is set (the loop of ``notify``).

    Opens the history at ``location`` for each pass (a PostgreSQL server that restarts costs
    one pass, not the notifier); a pass that fails is given to ``on_error`` and the loop goes
    on; the sends of each pass go to ``report``.
    """

    def wait(seconds: float) -> None:
        stop.wait(seconds)
    marks = PassMarks()  # the first pass reads every joint, the next what changed since
    while not stop.is_set():
        try:
            with open_history(location, init=False) as history:
                report(notify_once(history=history, config=config, now_s=clock(),
                                   sleep=wait, zone=zone, marks=marks))
        except HistoryError as error:
            on_error(error)
        stop.wait(interval_s)
