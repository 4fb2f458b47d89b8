"""Tests of the notifications against real servers on 127.0.0.1 started here.

A webhook receiver (http.server in a thread) records the JSON bodies and can fail its first
requests; an SMTP server (aiosmtpd) receives the e-mails, with STARTTLS and a login in one test.
The fleet histories are written row by row with known values (SQLite and PostgreSQL): an alarm
raised, a forecast crossing inside the horizon and one outside, a stale joint.  Checked: one
notification per event, also after another pass, after re-opening the history and with two
notifiers at once; none for an acknowledged joint; a new alarm cycle after a reset; staleness
judged at a given time; the payloads against the history's values; retries with back-off and
failed sends stored and retried on the next pass; the configuration's errors.
"""

from email import message_from_bytes, policy
import hashlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
import json
import math
import shutil
import socket
import subprocess
import threading

from aiosmtpd.controller import Controller
from aiosmtpd.smtp import AuthResult
import pytest
import yaml

from robot_wear_monitor.fleet.notifications import (load_notification_config, notify_once,
                                                    NotificationConfigError)
from robot_wear_monitor.fleet.notify_config import notification_config_from_mapping
from robot_wear_monitor.fleet.ranking import iso_time
from robot_wear_monitor.monitoring.history import AlarmEvent, HistoryRecord, WearHistory
from robot_wear_monitor.yaml_files import load_yaml_file

from conftest import REPO_ROOT

HOUR = 3600.0
DAY = 86400.0
#: the experiments of the joints that are not stale end at T0, T0 + 1 h, ... (1 h apart)
T0 = 1_790_000_000.0
#: the time of the first pass: one hour after the last experiment, nothing stale but one joint
NOW = T0 + 4 * HOUR
DASHBOARD = 'https://wear.example.local:8443'


# --------------------------------------------------------------------------- servers

class WebhookReceiver:
    """An HTTP server on 127.0.0.1 that records JSON bodies; it can fail its first requests."""

    def __init__(self) -> None:
        self.bodies: list = []
        self.requests = 0
        self.fail_first = 0
        self.fail_status = 503
        self._lock = threading.Lock()
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 - http.server's name
                body = self.rfile.read(int(self.headers.get('Content-Length', 0)))
                with receiver._lock:
                    receiver.requests += 1
                    fail = receiver.requests <= receiver.fail_first
                    if not fail:
                        receiver.bodies.append((self.path, self.headers.get('Content-Type'),
                                                json.loads(body)))
                self.send_response(receiver.fail_status if fail else 200)
                self.send_header('Content-Length', '0')
                self.end_headers()

            def log_message(self, *args) -> None:
                pass

        self.server = ThreadingHTTPServer(('127.0.0.1', 0), Handler)
        self.url = f'http://127.0.0.1:{self.server.server_address[1]}/hook'
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def alerts(self) -> list:
        return [body for _, _, body in self.bodies]

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


class MailHandler:
    """aiosmtpd handler that keeps the messages; it can answer 451 (or 550) to the first."""

    def __init__(self) -> None:
        self.messages: list = []
        self.envelopes: list = []
        self.fail_first = 0
        self.fail_reply = '451 4.3.0 try again later'
        self.calls = 0

    async def handle_DATA(self, server, session, envelope):  # noqa: N802 - aiosmtpd's name
        self.calls += 1
        if self.calls <= self.fail_first:
            return self.fail_reply
        self.envelopes.append((envelope.mail_from, list(envelope.rcpt_tos)))
        self.messages.append(message_from_bytes(envelope.original_content,
                                                policy=policy.default))
        return '250 OK'


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


@pytest.fixture
def webhook():
    receiver = WebhookReceiver()
    yield receiver
    receiver.close()


@pytest.fixture
def smtp():
    handler = MailHandler()
    controller = Controller(handler, hostname='127.0.0.1', port=_free_port())
    controller.start()
    handler.port = controller.port
    yield handler
    controller.stop()


def _config(tmp_path, *, webhook=None, smtp=None, name='notifications.yaml', **extra):
    document = {'forecast_horizon_days': 30, 'dashboard_url': DASHBOARD,
                'retry': {'attempts': 3, 'backoff_initial_s': 0.01, 'backoff_max_s': 0.02,
                          'total_s': 30, 'passes': 2}}
    if webhook is not None:
        document['webhooks'] = [{'name': 'ops', 'url': webhook.url, 'receiver': 'maint',
                                 'timeout_s': 5}]
    if smtp is not None:
        document['email'] = {'host': '127.0.0.1', 'port': smtp.port, 'starttls': False,
                             'from': 'Wear monitor <wear@example.local>',
                             'to': ['maintenance@example.local', 'lead@example.local'],
                             'timeout_s': 5}
    document.update(extra)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(document))
    return load_notification_config(path)


# --------------------------------------------------------------------------- histories

def _record(robot, joint, stamp_s, *, wear=20.0, alarm=False, crossing=math.nan):
    return HistoryRecord(
        robot=robot, joint=joint, stamp_s=stamp_s, speeds_rad_s=(2.1, 28.5),
        frictions=(0.1, 0.05), temperature_degc=40.0, temperature_std_degc=1.0, wear=wear,
        wear_std=2.0, chi2=1.0, dof=1, p_value=0.5, temperature_at_bound=False,
        wear_at_bound=False, alarm_active=alarm, alarm_evidence=3.0 if alarm else 0.0,
        status_level=2 if alarm else 0, parameter_set='p', wear_low=wear - 4.0,
        wear_high=wear + 4.0, trend_wear=wear, crossing_experiments=crossing)


#: the raise of cell_1/joint_2 (the stamp of its 4th experiment)
RAISE_S = T0 + 3 * HOUR


def _fleet(history):
    """Four joints, 1 h between experiments (the last at T0 + 3 h, except the stale one).

    cell_1/joint_2: alarm raised at RAISE_S, w = 80, its trend past the threshold (crossing
    -1 experiments); cell_1/joint_3: crossing in 5
    experiments (T0 + 8 h, inside 30 days); cell_2/joint_1: crossing in 2000 experiments
    (~83 days, outside); cell_2/joint_2: last experiment 10 days before T0 (stale at NOW).
    """
    for k in range(4):
        stamp = T0 + k * HOUR
        events = [AlarmEvent(robot='cell_1', joint='joint_2', stamp_s=stamp, event='raised',
                             wear=80.0)] if k == 3 else []
        history.append(_record('cell_1', 'joint_2', stamp, wear=60.0 + 20 * (k == 3),
                               alarm=k == 3, crossing=-1.0 if k == 3 else math.nan),
                       events=events)
        history.append(_record('cell_1', 'joint_3', stamp, wear=50.0, crossing=5.0))
        history.append(_record('cell_2', 'joint_1', stamp, wear=30.0, crossing=2000.0))
        history.append(_record('cell_2', 'joint_2', stamp - 10 * DAY, wear=25.0))


def _kinds(receiver):
    return sorted((b['commonLabels']['robot'], b['commonLabels']['joint'],
                   b['commonLabels']['alertname']) for b in receiver.alerts())


EXPECTED = [('cell_1', 'joint_2', 'WearAlarmRaised'),
            ('cell_1', 'joint_2', 'WearForecastCrossing'),
            ('cell_1', 'joint_3', 'WearForecastCrossing'),
            ('cell_2', 'joint_2', 'WearJointStale')]


# --------------------------------------------------------------------------- once per event

def test_each_event_once_per_channel_also_after_another_pass_and_a_restart(
        history_location, tmp_path, webhook, smtp):
    config = _config(tmp_path, webhook=webhook, smtp=smtp)
    with WearHistory(history_location) as history:
        _fleet(history)
        sent = notify_once(history=history, config=config, now_s=NOW)
        assert sorted((s.robot, s.joint, s.kind, s.channel) for s in sent) == sorted(
            (robot, joint, kind, channel) for robot, joint, kind in [
                ('cell_1', 'joint_2', 'alarm_raised'), ('cell_1', 'joint_2', 'forecast_crossing'),
                ('cell_1', 'joint_3', 'forecast_crossing'), ('cell_2', 'joint_2', 'joint_stale')]
            for channel in ('webhook:ops', 'email'))
        assert all(s.delivered and s.attempts == 1 and s.pass_number == 1 for s in sent)
        assert _kinds(webhook) == EXPECTED and len(smtp.messages) == 4
        assert notify_once(history=history, config=config, now_s=NOW + 60) == []
        logged = history.notifications()
        assert len(logged) == 8 and {row['channel'] for row in logged} == {'webhook:ops',
                                                                          'email'}
    with WearHistory(history_location) as again:  # a restarted notifier
        assert notify_once(history=again, config=config, now_s=NOW + 120) == []
        # the far crossing comes inside the horizon: one new event, once
        again.append(_record('cell_2', 'joint_1', T0 + 4 * HOUR, wear=35.0, crossing=100.0))
        sent = notify_once(history=again, config=config, now_s=NOW + 180)
        assert [(s.robot, s.joint, s.kind) for s in sent] == [
            ('cell_2', 'joint_1', 'forecast_crossing')] * 2
        assert notify_once(history=again, config=config, now_s=NOW + 240) == []
    assert len(webhook.bodies) == 5 and len(smtp.messages) == 5


def test_two_notifiers_at_once_send_each_event_once(history_location, tmp_path, webhook):
    config = _config(tmp_path, webhook=webhook)
    with WearHistory(history_location) as history:
        _fleet(history)
    barrier = threading.Barrier(2)
    results: list = []

    def notifier() -> None:
        with WearHistory(history_location) as history:
            barrier.wait()
            results.append(notify_once(history=history, config=config, now_s=NOW))
    threads = [threading.Thread(target=notifier) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(results) == 2
    assert sum(len(r) for r in results) == 4 and _kinds(webhook) == EXPECTED


# --------------------------------------------------------------------------- payloads

def test_the_webhook_payload_and_the_email_say_what_the_history_holds(tmp_path, webhook,
                                                                      smtp):
    config = _config(tmp_path, webhook=webhook, smtp=smtp, events=['alarm_raised'])
    with WearHistory(tmp_path / 'h.db') as history:
        _fleet(history)
        row = next(r for r in history.fleet() if r.alarm)
        notify_once(history=history, config=config, now_s=NOW)
    assert (row.robot, row.joint, row.alarm_since_stamp_s) == ('cell_1', 'joint_2', RAISE_S)
    [(path, content_type, body)] = webhook.bodies
    assert path == '/hook' and content_type == 'application/json'
    key = f'alarm_raised/cell_1/joint_2/{RAISE_S:.6f}'
    assert body['version'] == '4' and body['status'] == 'firing'
    assert body['receiver'] == 'maint' and body['groupKey'] == key
    assert body['externalURL'] == DASHBOARD
    labels = {'alertname': 'WearAlarmRaised', 'robot': 'cell_1', 'joint': 'joint_2',
              'severity': 'critical'}
    assert body['commonLabels'] == labels
    [alert] = body['alerts']
    assert alert['status'] == 'firing' and alert['labels'] == labels
    assert alert['startsAt'] == iso_time(RAISE_S) == '2026-09-21T17:13:20Z'
    assert alert['endsAt'] == '0001-01-01T00:00:00Z'
    assert alert['generatorURL'] == f'{DASHBOARD}/robots/cell_1/joints/joint_2'
    assert alert['fingerprint'] == hashlib.sha256(key.encode()).hexdigest()[:16]
    summary = alert['annotations']['summary']
    assert summary == 'cell_1 joint_2: wear alarm raised (w = 80.0 [95 %: 76.0, 84.0])'
    description = alert['annotations']['description']
    assert 'Alarm latched since 2026-09-21T17:13:20Z' in description
    assert 'Last experiment: 2026-09-21T17:13:20Z (4 in all)' in description
    [message] = smtp.messages
    assert message['Subject'] == '[robot-wear-monitor] cell_1 joint_2: wear alarm raised'
    assert message['From'] == 'Wear monitor <wear@example.local>'
    assert smtp.envelopes == [('wear@example.local', ['maintenance@example.local',
                                                      'lead@example.local'])]
    text = message.get_content()
    assert summary in text and f'{DASHBOARD}/robots/cell_1/joints/joint_2' in text
    assert key in text


def test_names_from_recordings_are_encoded_in_links_and_kept_out_of_mail_headers(
        tmp_path, webhook, smtp):
    config = _config(tmp_path, webhook=webhook, smtp=smtp, events=['alarm_raised'])
    robot, joint = 'cell/1 <img src=x onerror=alert(1)>', 'joint\r\nBcc: x@evil.example'
    with WearHistory(tmp_path / 'h.db') as history:
        history.append(_record(robot, joint, T0, wear=90.0, alarm=True), events=[
            AlarmEvent(robot=robot, joint=joint, stamp_s=T0, event='raised', wear=90.0)])
        [webhook_send, mail_send] = notify_once(history=history, config=config, now_s=NOW)
    assert webhook_send.delivered and mail_send.delivered
    [alert] = webhook.alerts()[0]['alerts']
    assert alert['labels']['robot'] == robot and alert['labels']['joint'] == joint
    assert alert['generatorURL'] == (
        f'{DASHBOARD}/robots/cell%2F1%20%3Cimg%20src%3Dx%20onerror%3Dalert%281%29%3E/joints/'
        'joint%0D%0ABcc%3A%20x%40evil.example')
    [message] = smtp.messages
    assert message['Bcc'] is None and '\\r\\n' in message['Subject']
    assert smtp.envelopes[0][1] == ['maintenance@example.local', 'lead@example.local']


# --------------------------------------------------------------------------- which events

def test_an_acknowledged_joint_gets_nothing_until_its_reset_starts_a_new_cycle(
        history_location, tmp_path, webhook):
    config = _config(tmp_path, webhook=webhook)
    with WearHistory(history_location) as history:
        _fleet(history)
        history.acknowledge_alarm(robot='cell_1', joint='joint_2', user='ana', owner='ben',
                                  comment='bearing ordered', planned_maintenance='2026-10-01')
        notify_once(history=history, config=config, now_s=NOW)
        assert _kinds(webhook) == [('cell_1', 'joint_3', 'WearForecastCrossing'),
                                   ('cell_2', 'joint_2', 'WearJointStale')]
        # stale as well: still nothing for the acknowledged joint
        assert notify_once(history=history, config=config, now_s=NOW + 30 * DAY) != []
        assert ('cell_1', 'joint_2') not in {(b['commonLabels']['robot'],
                                             b['commonLabels']['joint'])
                                            for b in webhook.alerts()}
        history.reset_alarm(robot='cell_1', joint='joint_2', user='ana',
                            reason='gearbox replaced', stamp_s=T0 + 5 * HOUR)
        # the new life: its trend again past the threshold soon -> a crossing of a new cycle
        history.append(_record('cell_1', 'joint_2', T0 + 6 * HOUR, wear=70.0, crossing=3.0))
        before = len(webhook.bodies)
        sent = notify_once(history=history, config=config, now_s=T0 + 6 * HOUR + 60)
        assert [(s.robot, s.joint, s.kind) for s in sent] == [
            ('cell_1', 'joint_2', 'forecast_crossing')]
        [body] = webhook.alerts()[before:]
        assert body['groupKey'] == (
            f'forecast_crossing/cell_1/joint_2/cycle-{T0 + 5 * HOUR:.6f}')
        assert notify_once(history=history, config=config, now_s=T0 + 6 * HOUR + 120) == []


def test_a_joint_is_stale_once_per_episode_judged_at_the_given_time(tmp_path, webhook):
    config = _config(tmp_path, webhook=webhook, events=['joint_stale'])
    with WearHistory(tmp_path / 'h.db') as history:
        for k in range(3):
            history.append(_record('r', 'j', T0 + k * HOUR))
        limit = T0 + 2 * HOUR + 3 * HOUR  # 3 usual intervals after the last experiment
        assert notify_once(history=history, config=config, now_s=limit - 1) == []
        [sent] = notify_once(history=history, config=config, now_s=limit + 1)
        assert sent.kind == 'joint_stale' and sent.delivered
        assert notify_once(history=history, config=config, now_s=limit + DAY) == []
        history.append(_record('r', 'j', limit + DAY))  # back, then quiet again
        assert notify_once(history=history, config=config, now_s=limit + DAY + 60) == []
        [again] = notify_once(history=history, config=config, now_s=limit + 30 * DAY)
    first, second = webhook.alerts()
    assert first['groupKey'] == f'joint_stale/r/j/last-{T0 + 2 * HOUR:.6f}'
    assert second['groupKey'] == f'joint_stale/r/j/last-{limit + DAY:.6f}'
    assert first['alerts'][0]['startsAt'] == iso_time(limit)
    assert first['alerts'][0]['annotations']['summary'] == (
        f'r j: no experiment since {iso_time(T0 + 2 * HOUR)} (usual interval 1.0 h)')


def test_the_horizon_and_the_chosen_events_are_kept(tmp_path, webhook):
    with WearHistory(tmp_path / 'h.db') as history:
        _fleet(history)
        far = _config(tmp_path, webhook=webhook, forecast_horizon_days=90,
                      events=['forecast_crossing'])
        sent = notify_once(history=history, config=far, now_s=NOW)
    # 2000 experiments 1 h apart after T0 + 3 h: day 83.5, inside 90 days
    assert sorted((s.robot, s.joint) for s in sent) == [
        ('cell_1', 'joint_2'), ('cell_1', 'joint_3'), ('cell_2', 'joint_1')]
    crossing = next(b for b in webhook.alerts() if b['commonLabels']['joint'] == 'joint_1')
    assert iso_time(T0 + 3 * HOUR + 2000 * HOUR) in \
        crossing['alerts'][0]['annotations']['summary']
