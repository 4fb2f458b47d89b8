"""
The channels of the notifications: what an event says, a webhook POST and an SMTP e-mail.

:class:`DueEvent` is one event of one robot's joint that is due (built by
:mod:`robot_wear_monitor.fleet.notifications`); :func:`webhook_payload` turns it into an
Alertmanager-like JSON body (version 4, one alert) and :func:`email_message` into a plain-text
e-mail.  :func:`post_webhook` (httpx) and :func:`send_email` (smtplib) send them, retrying
connection errors, timeouts, HTTP 5xx/429 and SMTP 4xx with exponential back-off within the
:class:`~robot_wear_monitor.fleet.notify_config.RetryPolicy` (bounded tries and total time);
other answers (HTTP 4xx, SMTP 5xx) fail at once.  Neither raises: the result says what
happened.
"""

from __future__ import annotations

import contextvars
from dataclasses import dataclass
from email.message import EmailMessage
import email.utils
import hashlib
import math
import smtplib
import ssl
import time
from typing import Any, Callable
from urllib.parse import quote

from robot_wear_monitor import __version__
from robot_wear_monitor.fleet.notify_config import (EmailConfig, NotificationConfig,
                                                    RetryPolicy, WebhookConfig)
from robot_wear_monitor.fleet.ranking import FleetView, threshold_text
from robot_wear_monitor.text import iso_time, shorten

#: Alertmanager's ``endsAt`` of an alert that is still firing.
NO_END = '0001-01-01T00:00:00Z'
#: Per event kind: the alert's name and severity, and the title in the e-mail's subject.
KINDS = {
    'alarm_raised': ('WearAlarmRaised', 'critical', 'wear alarm raised'),
    'forecast_crossing': ('WearForecastCrossing', 'warning',
                          'wear threshold crossing forecast within the horizon'),
    'joint_stale': ('WearJointStale', 'warning', 'no experiment for too long (stale)'),
    'alarm_reescalated': ('WearAlarmRaised', 'critical',
                          'acknowledged wear alarm re-escalated'),
    'alarm_resolved': ('WearAlarmRaised', 'critical',
                       'wear alarm resolved (reset after maintenance)'),
    'alarm_acknowledged': ('WearAlarmAcknowledged', 'info', 'wear alarm acknowledged'),
    'forecast_resolved': ('WearForecastCrossing', 'warning',
                          'forecast crossing no longer due (resolved)'),
    'stale_resolved': ('WearJointStale', 'warning', 'experiments again (stale resolved)'),
    'reescalation_resolved': ('WearAlarmRaised', 'critical',
                              're-escalation ended (resolved)'),
    'acknowledgement_resolved': ('WearAlarmAcknowledged', 'info',
                                 'acknowledged alarm ended (resolved)'),
}
#: Per firing kind: the kind that ends its alert once its cause ends (the raise of an alarm:
#: ``alarm_resolved``, by its reset).
RESOLVES = {'forecast_crossing': 'forecast_resolved', 'joint_stale': 'stale_resolved',
            'alarm_reescalated': 'reescalation_resolved',
            'alarm_acknowledged': 'acknowledgement_resolved'}
#: The kinds sent as Alertmanager ``status: resolved`` (the end of the alert of ``firing_key``).
RESOLVED_KINDS = ('alarm_resolved',) + tuple(RESOLVES.values())
#: The key of the summary a channel's first pass sends (``first_pass_summary``).
SUMMARY_KEY = 'first-pass-summary'
_USER_AGENT = f'robot-wear-monitor/{__version__}'


@dataclass(frozen=True)
class DueEvent:
    """
    One event of one robot's joint that is due to be notified.

    ``key``: the event's identity (the same on every pass and in every process, see
    :mod:`robot_wear_monitor.fleet.notifications`); ``starts_s``: when it happened [s since the
    epoch]; ``view``: the joint's fleet row at the pass.  A ``resolved`` event (the reset of
    an alarm) names the key of the alert it ends (``firing_key``, whose fingerprint it
    carries) and when it ended (``ends_s``).
    """

    kind: str
    key: str
    robot: str
    joint: str
    starts_s: float
    summary: str
    description: str
    view: FleetView
    firing_key: str = ''
    ends_s: float = math.nan

    @property
    def resolved(self) -> bool:
        """Return True for the end of an alert (Alertmanager ``status: resolved``)."""
        return self.kind in RESOLVED_KINDS

    @property
    def fingerprint(self) -> str:
        """Return a stable 16-hex-digit identity of the alert (a resolved one: the firing's)."""
        key = self.firing_key or self.key
        return hashlib.sha256(key.encode('utf-8')).hexdigest()[:16]


@dataclass(frozen=True)
class SendResult:
    """What one send did: ``delivered``, the ``attempts`` made and the last ``error``."""

    delivered: bool
    attempts: int
    error: str = ''


def joint_url(config: NotificationConfig, *, robot: str, joint: str) -> str:
    """Return the dashboard page of the joint ('' without ``dashboard_url``)."""
    if not config.dashboard_url:
        return ''
    return (f'{config.dashboard_url}/robots/{quote(robot, safe="")}/joints/'
            f'{quote(joint, safe="")}')


def webhook_payload(event: DueEvent, *, config: NotificationConfig,
                    receiver: str) -> dict[str, Any]:
    """Return the Alertmanager-like JSON body (webhook version 4) of one event."""
    name, severity, _ = KINDS[event.kind]
    labels = {'alertname': name, 'robot': event.robot, 'joint': event.joint,
              'severity': severity, 'state': event.view.condition}
    annotations = {'summary': event.summary, 'description': event.description,
                   'threshold': threshold_text(event.view)}
    status = 'resolved' if event.resolved else 'firing'
    alert = {'status': status, 'labels': labels, 'annotations': annotations,
             'startsAt': iso_time(event.starts_s),
             'endsAt': iso_time(event.ends_s) if event.resolved else NO_END,
             'generatorURL': joint_url(config, robot=event.robot, joint=event.joint),
             'fingerprint': event.fingerprint}
    return {'version': '4', 'groupKey': event.firing_key or event.key, 'truncatedAlerts': 0,
            'status': status,
            'receiver': receiver, 'groupLabels': {'alertname': name},
            'commonLabels': dict(labels), 'commonAnnotations': dict(annotations),
            'externalURL': config.dashboard_url, 'alerts': [alert]}


def summary_payload(events: list[DueEvent], *, config: NotificationConfig,
                    receiver: str) -> dict[str, Any]:
    """
    Return one Alertmanager-like body (version 4) holding the alerts of all ``events``.

    The first pass on a channel: each alert as :func:`webhook_payload` gives it (its own
    fingerprint, so a later ``resolved`` ends it), the labels all alerts share as
    ``commonLabels`` and a ``summary`` annotation counting them.
    """
    bodies = [webhook_payload(event, config=config, receiver=receiver) for event in events]
    alerts = [body['alerts'][0] for body in bodies]
    common = {key: value for key, value in alerts[0]['labels'].items()
              if all(a['labels'].get(key) == value for a in alerts)}
    text = summary_text(events)
    return {'version': '4', 'groupKey': SUMMARY_KEY, 'truncatedAlerts': 0,
            'status': 'firing', 'receiver': receiver, 'groupLabels': {},
            'commonLabels': common,
            'commonAnnotations': {'summary': text.splitlines()[0], 'description': text},
            'externalURL': config.dashboard_url, 'alerts': alerts}


def summary_text(events: list[DueEvent]) -> str:
    """Return the first pass's summary: a count by kind, then one line per event."""
    counts: dict[str, int] = {}
    for event in events:
        counts[event.kind] = counts.get(event.kind, 0) + 1
    by_kind = ', '.join(f'{n} {KINDS[kind][2]}' for kind, n in counts.items())
    lines = [f'{len(events)} events due at the first pass: {by_kind}']
    lines += [f'- {event.summary}' for event in events]
    return '\n'.join(lines)


def summary_email(events: list[DueEvent], *, config: NotificationConfig,
                  mail: EmailConfig) -> EmailMessage:
    """Return the first pass's one e-mail: the summary, then each event's facts and link."""
    message = EmailMessage()
    message['Subject'] = (f'[robot-wear-monitor] first pass: {len(events)} events due')
    message['From'] = mail.sender
    message['To'] = ', '.join(mail.to)
    message['Date'] = email.utils.formatdate(localtime=False, usegmt=True)
    message['Message-ID'] = email.utils.make_msgid(domain='robot-wear-monitor.invalid')
    parts = [summary_text(events)]
    for event in events:
        link = joint_url(config, robot=event.robot, joint=event.joint)
        parts.append(f'{event.summary}\n{event.description}' +
                     (f'\nDashboard: {link}' if link else '') + f'\nEvent: {event.key}')
    parts.append(f'Sent once by robot-wear-monitor notify ({config.source}); later events '
                 'are sent one by one.')
    message.set_content('\n\n'.join(parts) + '\n')
    return message


def email_subject(event: DueEvent) -> str:
    """Return the subject line: the robot, the joint and the event (one line, cut short)."""
    title = KINDS[event.kind][2]
    return (f'[robot-wear-monitor] {shorten(event.robot, 60)} '
            f'{shorten(event.joint, 60)}: {title}')


def email_message(event: DueEvent, *, config: NotificationConfig,
                  mail: EmailConfig) -> EmailMessage:
    """Return the plain-text e-mail of one event (to every recipient of ``mail``)."""
    message = EmailMessage()
    message['Subject'] = email_subject(event)
    message['From'] = mail.sender
    message['To'] = ', '.join(mail.to)
    message['Date'] = email.utils.formatdate(localtime=False, usegmt=True)
    message['Message-ID'] = email.utils.make_msgid(domain='robot-wear-monitor.invalid')
    link = joint_url(config, robot=event.robot, joint=event.joint)
    body = f'{event.summary}\n\n{event.description}\n'
    if link:
        body += f'\nDashboard: {link}\n'
    body += (f'\nEvent: {event.key}\nSent once per event by robot-wear-monitor notify '
             f'({config.source}).\n')
    message.set_content(body)
    return message


# --------------------------------------------------------------------------- sending

def _retrying(attempt_once: Callable[[], tuple[bool, bool, str]], retry: RetryPolicy, *,
              sleep: Callable[[float], None], clock: Callable[[], float]) -> SendResult:
    """Run ``attempt_once`` -> (delivered, retryable, error) within the retry policy."""
    start = clock()
    error = ''
    for attempt in range(1, retry.attempts + 1):
        delivered, retryable, error = attempt_once()
        if delivered:
            return SendResult(delivered=True, attempts=attempt)
        if not retryable or attempt == retry.attempts:
            return SendResult(delivered=False, attempts=attempt, error=error)
        delay = retry.delay_s(attempt)
        if clock() - start + delay > retry.total_s:
            return SendResult(delivered=False, attempts=attempt,
                              error=f'{error} (gave up: {retry.total_s:g} s in all)')
        sleep(delay)
    return SendResult(delivered=False, attempts=retry.attempts, error=error)


def post_webhook(hook: WebhookConfig, payload: dict[str, Any], *, retry: RetryPolicy,
                 sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic) -> SendResult:
    """
    POST ``payload`` as JSON to the webhook; retry connection errors, timeouts, 5xx, 429.

    Any 2xx answer is a delivery; another 4xx (or a redirect, never followed) fails at once.
    Each try has a hard deadline, ``hook.timeout_s`` or what is left of ``retry.total_s``
    whichever is sooner, that bounds the whole request (connect, send, headers and body):
    httpx's own timeouts bound each network operation only, so a server that trickles a byte
    every second would keep a try alive for ever.  The try runs in its own event loop
    (anyio, in a fresh context) and is cancelled at its deadline.
    """
    # deferred import: optional extra 'dashboard' (httpx)
    import anyio
    import httpx

    start = clock()

    async def post_once(limit_s: float) -> httpx.Response:
        async with httpx.AsyncClient(timeout=httpx.Timeout(hook.timeout_s),
                                     follow_redirects=False,
                                     headers={'User-Agent': _USER_AGENT}) as client:
            with anyio.fail_after(limit_s):
                return await client.post(hook.url, json=payload)

    def attempt_once() -> tuple[bool, bool, str]:
        limit_s = min(hook.timeout_s, retry.total_s - (clock() - start))
        if limit_s <= 0.0:
            return False, False, f'no time left (gave up: {retry.total_s:g} s in all)'
        try:
            # a context of its own: a caller's (asyncio.to_thread copies the event loop's
            # context vars) would make anyio believe a loop runs in this thread
            response = contextvars.Context().run(anyio.run, post_once, limit_s)
        except TimeoutError:
            return False, True, f'no whole answer within {limit_s:.3g} s'
        except httpx.TransportError as problem:
            text = shorten(str(problem), 200)
            return False, True, f'{type(problem).__name__}: {text}'
        if 200 <= response.status_code < 300:
            return True, False, ''
        retryable = response.status_code >= 500 or response.status_code == 429
        return False, retryable, (f'HTTP {response.status_code} '
                                  f'{shorten(response.reason_phrase, 80)}')
    return _retrying(attempt_once, retry, sleep=sleep, clock=clock)


def send_email(mail: EmailConfig, message: EmailMessage, *, retry: RetryPolicy,
               sleep: Callable[[float], None] = time.sleep,
               clock: Callable[[], float] = time.monotonic) -> SendResult:
    """
    Send ``message`` through the SMTP server; retry connection errors and SMTP 4xx answers.

    STARTTLS (when configured) verifies the server's certificate against ``mail.ca_file``
    (default: the system's certificate authorities; its text as read with a bound when the
    configuration was loaded, ``mail.ca_pem``); an SMTP 5xx answer (refused sender or
    recipient, failed login) fails at once.
    """
    def attempt_once() -> tuple[bool, bool, str]:
        try:
            with smtplib.SMTP(mail.host, mail.port, timeout=mail.timeout_s) as smtp:
                smtp.ehlo()
                if mail.starttls:
                    smtp.starttls(context=ssl.create_default_context(
                        cadata=mail.ca_pem or None,
                        cafile=None if mail.ca_pem else mail.ca_file or None))
                    smtp.ehlo()
                if mail.user:
                    smtp.login(mail.user, mail.password)
                refused = smtp.send_message(message)
        except smtplib.SMTPResponseException as problem:
            text = problem.smtp_error
            text = text.decode('utf-8', 'replace') if isinstance(text, bytes) else str(text)
            return False, 400 <= problem.smtp_code < 500, \
                f'SMTP {problem.smtp_code} {shorten(text, 200)}'
        except smtplib.SMTPRecipientsRefused as problem:
            codes = sorted({code for code, _ in problem.recipients.values()})
            return False, all(400 <= c < 500 for c in codes), \
                f'SMTP recipients refused ({", ".join(map(str, codes))})'
        except (OSError, smtplib.SMTPException) as problem:
            return False, True, f'{type(problem).__name__}: {shorten(str(problem), 200)}'
        if refused:
            return False, False, f'SMTP refused {len(refused)} of {len(mail.to)} recipients'
        return True, False, ''
    return _retrying(attempt_once, retry, sleep=sleep, clock=clock)


def describe_wear(view: FleetView) -> str:
    """Return the joint's latest wear with its 95 % interval as text (w 0..100)."""
    s = view.state
    if s.awaiting_first_experiment:
        return 'no experiment since the reset (a new life)'
    if not math.isfinite(s.wear) or s.invalid_reason:
        return 'cannot judge the wear of the latest experiment'
    if math.isfinite(s.wear_low) and math.isfinite(s.wear_high):
        return f'w = {s.wear:.1f} [95 %: {s.wear_low:.1f}, {s.wear_high:.1f}]'
    return f'w = {s.wear:.1f} (interval unknown)'
