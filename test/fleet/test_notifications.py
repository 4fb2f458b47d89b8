"""
Tests of the notifications against real servers on 127.0.0.1 started here.

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
import time

from aiosmtpd.controller import Controller
from aiosmtpd.smtp import AuthResult
import pytest
from robot_wear_monitor.cli import main as cli_main
from robot_wear_monitor.fleet.notifications import (load_notification_config,
                                                    NotificationConfigError, notify_forever,
                                                    notify_once)
from robot_wear_monitor.fleet.notify_config import notification_config_from_mapping
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, WearHistory
from robot_wear_monitor.text import iso_time
from robot_wear_monitor.yaml_files import load_yaml_file
from wear_testing.paths import REPO_ROOT
import yaml

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
    # one send per event from the first pass on (the default summary: its own tests below)
    document = {'forecast_horizon_days': 30, 'dashboard_url': DASHBOARD,
                'first_pass_summary': False,
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
    """
    Four joints, 1 h between experiments (the last at T0 + 3 h, except the stale one).

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
        assert len(logged) == 8
        assert {row['channel'] for row in logged} == {'webhook:ops', 'email'}
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
              'severity': 'critical', 'state': 'alarm'}
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


def test_the_texts_show_the_plants_clock_the_payload_stays_utc(tmp_path, webhook, capsys):
    # the raise at 2026-09-21T17:13:20Z is 19:13 CEST in Stockholm (summer time)
    from robot_wear_monitor.display_time import time_zone
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised'])
    with WearHistory(tmp_path / 'h.db') as history:
        _fleet(history)
        notify_once(history=history, config=config, now_s=NOW,
                    zone=time_zone('Europe/Stockholm'))
    [(_, _, body)] = webhook.bodies
    [alert] = body['alerts']
    assert alert['startsAt'] == '2026-09-21T17:13:20Z'  # the machine's time: UTC
    assert body['groupKey'] == f'alarm_raised/cell_1/joint_2/{RAISE_S:.6f}'  # keys: no zone
    description = alert['annotations']['description']
    assert 'Alarm latched since 2026-09-21 19:13 CEST' in description
    assert 'Last experiment: 2026-09-21 19:13 CEST (4 in all)' in description
    assert 'T17:13' not in description
    # the verb's option; a bad zone is exit 2 naming the option and the value
    capsys.readouterr()
    assert cli_main(['notify', '--history', str(tmp_path / 'h.db'), '--config',
                     str(tmp_path / 'notifications.yaml'), '--once', '--display-timezone',
                     'Europe/Sthlm']) == 2
    err = capsys.readouterr().err
    assert '--display-timezone: not an IANA time zone name' in err and 'Europe/Sthlm' in err


def test_names_from_recordings_are_encoded_in_links_and_kept_out_of_mail_headers(
        tmp_path, webhook, smtp):
    config = _config(tmp_path, webhook=webhook, smtp=smtp, events=['alarm_raised'])
    robot, joint = 'Zelle/1 \u00fc <img src=x onerror=alert(1)>', 'joint\r\nBcc: x@evil.example'
    with WearHistory(tmp_path / 'h.db') as history:
        history.append(_record(robot, joint, T0, wear=90.0, alarm=True), events=[
            AlarmEvent(robot=robot, joint=joint, stamp_s=T0, event='raised', wear=90.0)])
        [webhook_send, mail_send] = notify_once(history=history, config=config, now_s=NOW)
    assert webhook_send.delivered and mail_send.delivered
    [alert] = webhook.alerts()[0]['alerts']
    assert alert['labels']['robot'] == robot and alert['labels']['joint'] == joint
    assert alert['generatorURL'] == (
        f'{DASHBOARD}/robots/Zelle%2F1%20%C3%BC%20%3Cimg%20src%3Dx%20onerror%3Dalert%281%29%3E/'
        'joints/'
        'joint%0D%0ABcc%3A%20x%40evil.example')
    [message] = smtp.messages
    assert message['Bcc'] is None and '\\r\\n' in message['Subject']
    assert message['Subject'].startswith('[robot-wear-monitor] Zelle/1 \u00fc <img')
    assert robot in message.get_content()
    assert smtp.envelopes[0][1] == ['maintenance@example.local', 'lead@example.local']


# --------------------------------------------------------------------------- which events

def test_an_acknowledged_joint_gets_nothing_until_its_reset_starts_a_new_cycle(
        history_location, tmp_path, webhook):
    config = _config(tmp_path, webhook=webhook)
    with WearHistory(history_location) as history:
        _fleet(history)
        # the planned date lies after the passes below (a passed date re-escalates the alarm)
        history.acknowledge_alarm(robot='cell_1', joint='joint_2', user='ana', owner='ben',
                                  comment='bearing ordered', planned_maintenance='2026-12-01')
        notify_once(history=history, config=config, now_s=NOW)
        # the acknowledgement itself is notified (issue 44), the joint's alarm, forecast and
        # staleness are not
        assert _kinds(webhook) == [('cell_1', 'joint_2', 'WearAlarmAcknowledged'),
                                   ('cell_1', 'joint_3', 'WearForecastCrossing'),
                                   ('cell_2', 'joint_2', 'WearJointStale')]
        [ack] = [b for b in webhook.alerts() if b['commonLabels']['joint'] == 'joint_2'
                 and b['commonLabels']['robot'] == 'cell_1']
        assert ack['status'] == 'firing' and ack['commonLabels']['severity'] == 'info'
        assert ack['alerts'][0]['annotations']['summary'] == (
            'cell_1 joint_2: wear alarm acknowledged by ana, maintenance planned 2026-12-01')
        # stale as well: still nothing for the acknowledged joint
        assert notify_once(history=history, config=config, now_s=NOW + 30 * DAY) != []
        labels = [b['commonLabels'] for b in webhook.alerts()]
        assert [b['alertname'] for b in labels if (b['robot'], b['joint']) == (
            'cell_1', 'joint_2')] == ['WearAlarmAcknowledged']
        history.reset_alarm(robot='cell_1', joint='joint_2', user='ana',
                            reason='gearbox replaced', stamp_s=T0 + 5 * HOUR)
        # the new life: its trend again past the threshold soon -> a crossing of a new cycle
        history.append(_record('cell_1', 'joint_2', T0 + 6 * HOUR, wear=70.0, crossing=3.0))
        before = len(webhook.bodies)
        sent = notify_once(history=history, config=config, now_s=T0 + 6 * HOUR + 60)
        # the reset ends the acknowledgement's alert (resolved; the raise was never sent);
        # (judged back at T0 + 6 h, cell_1/joint_3's overdue crossing is no longer overdue)
        assert sorted((s.robot, s.joint, s.kind) for s in sent) == [
            ('cell_1', 'joint_2', 'acknowledgement_resolved'),
            ('cell_1', 'joint_2', 'forecast_crossing'),
            ('cell_1', 'joint_3', 'forecast_resolved')]
        body, ended, _ = webhook.alerts()[before:]
        assert body['groupKey'] == (
            f'forecast_crossing/cell_1/joint_2/cycle-{T0 + 5 * HOUR:.6f}')
        assert ended['status'] == 'resolved' and ended['alerts'][0]['fingerprint'] == \
            ack['alerts'][0]['fingerprint'] and ended['groupKey'] == ack['groupKey']
        assert ended['alerts'][0]['endsAt'] == iso_time(T0 + 6 * HOUR + 60)
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
        history.append(_record('r', 'j', limit + DAY))  # back: the episode resolves, once
        [back] = notify_once(history=history, config=config, now_s=limit + DAY + 60)
        assert back.kind == 'stale_resolved' and back.delivered
        assert notify_once(history=history, config=config, now_s=limit + DAY + 120) == []
        [again] = notify_once(history=history, config=config, now_s=limit + 30 * DAY)
    first, ended, second = webhook.alerts()
    assert ended['status'] == 'resolved' == ended['alerts'][0]['status']
    assert ended['groupKey'] == first['groupKey']
    assert ended['alerts'][0]['fingerprint'] == first['alerts'][0]['fingerprint']
    assert ended['commonLabels']['alertname'] == 'WearJointStale'
    assert ended['alerts'][0]['endsAt'] == iso_time(limit + DAY + 60)
    assert ended['alerts'][0]['startsAt'] == iso_time(limit + DAY + 60)
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


# --------------------------------------------------------------------------- failing channels

def _one_alarm(path):
    history = WearHistory(path)
    history.append(_record('r', 'j', T0, wear=90.0, alarm=True), events=[
        AlarmEvent(robot='r', joint='j', stamp_s=T0, event='raised', wear=90.0)])
    return history


def test_a_webhook_failing_at_first_is_retried_with_exponential_back_off(tmp_path, webhook):
    webhook.fail_first = 2
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised'])
    waits: list = []
    with _one_alarm(tmp_path / 'h.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW, sleep=waits.append)
    assert sent.delivered and sent.attempts == 3 and webhook.requests == 3
    assert waits == [0.01, 0.02] and len(webhook.bodies) == 1


@pytest.mark.parametrize('status, attempts, error', [(400, 1, 'HTTP 400 Bad Request'),
                                                     (429, 3, 'HTTP 429 Too Many Requests'),
                                                     (500, 3, 'HTTP 500 Internal Server Error')])
def test_client_errors_fail_at_once_server_errors_after_every_try(tmp_path, webhook, status,
                                                                  attempts, error):
    webhook.fail_first, webhook.fail_status = 100, status
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised'])
    with _one_alarm(tmp_path / 'h.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW, sleep=lambda s: None)
    assert not sent.delivered and (sent.attempts, sent.error) == (attempts, error)
    assert webhook.requests == attempts


def test_a_dead_webhook_and_the_total_time_bound(tmp_path):
    port = _free_port()  # nobody listens there
    config = notification_config_from_mapping(
        {'webhooks': [{'url': f'http://127.0.0.1:{port}/hook'}],
         'retry': {'attempts': 5, 'backoff_initial_s': 2.0, 'total_s': 7.0}},
        source='inline')
    waits: list = []
    with _one_alarm(tmp_path / 'h.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW, sleep=waits.append)
    # the waits 2 s and 4 s fit in 7 s, the next (8 s) would not
    assert not sent.delivered and sent.attempts == 3 and waits == [2.0, 4.0]
    assert sent.error.startswith('ConnectError') and 'gave up: 7 s in all' in sent.error


def test_a_failed_send_is_stored_and_retried_on_the_next_passes(history_location, tmp_path,
                                                                webhook):
    webhook.fail_first = 3  # every try of the first pass
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised', 'joint_stale'])
    with WearHistory(history_location) as history:
        _fleet(history)
        [failed] = notify_once(history=history, config=config, now_s=NOW, sleep=lambda s: None)
        # the channel failed: its other event waits for the next pass, unclaimed
        assert (failed.kind, failed.delivered, failed.pass_number) == ('alarm_raised', False, 1)
        assert failed.retried_later and failed.error == 'HTTP 503 Service Unavailable'
        log = {row['event_key']: row for row in history.notifications()}
        base = f'alarm_raised/cell_1/joint_2/{RAISE_S:.6f}@webhook:ops'
        assert set(log) == {base, base + '#failed1'}
        assert log[base + '#failed1']['payload']['error'] == 'HTTP 503 Service Unavailable'
        assert log[base + '#failed1']['payload']['attempts'] == 3
    with WearHistory(history_location) as history:  # the next pass, after a restart
        sent = notify_once(history=history, config=config, now_s=NOW + 60)
        assert sorted((s.kind, s.delivered, s.pass_number) for s in sent) == [
            ('alarm_raised', True, 2), ('joint_stale', True, 1)]
        assert notify_once(history=history, config=config, now_s=NOW + 120) == []
    assert _kinds(webhook) == [('cell_1', 'joint_2', 'WearAlarmRaised'),
                               ('cell_2', 'joint_2', 'WearJointStale')]


def test_a_send_failing_on_every_pass_is_given_up(tmp_path, webhook):
    webhook.fail_first = 1000
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised'])  # 2 passes of 3 tries
    with _one_alarm(tmp_path / 'h.db') as history:
        [first] = notify_once(history=history, config=config, now_s=NOW, sleep=lambda s: None)
        [second] = notify_once(history=history, config=config, now_s=NOW, sleep=lambda s: None)
        assert notify_once(history=history, config=config, now_s=NOW) == []
        keys = sorted(row['event_key'] for row in history.notifications())
    assert (first.retried_later, second.retried_later) == (True, False)
    assert second.pass_number == 2 and webhook.requests == 6
    base = f'alarm_raised/r/j/{T0:.6f}@webhook:ops'
    assert keys == [base, base + '#failed1', base + '#failed2', base + '#pass2']


def test_an_smtp_server_answering_4xx_is_retried_5xx_is_not(tmp_path, smtp):
    config = _config(tmp_path, smtp=smtp, events=['alarm_raised'])
    smtp.fail_first = 1
    with _one_alarm(tmp_path / 'h.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW, sleep=lambda s: None)
    assert sent.delivered and sent.attempts == 2 and len(smtp.messages) == 1
    smtp.calls, smtp.fail_first, smtp.fail_reply = 0, 5, '550 5.7.1 relaying denied'
    with _one_alarm(tmp_path / 'h2.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW, sleep=lambda s: None)
    assert not sent.delivered and sent.attempts == 1
    assert sent.error == 'SMTP 550 5.7.1 relaying denied' and smtp.calls == 1


# --------------------------------------------------------------------------- STARTTLS, login

@pytest.fixture
def tls_smtp(tmp_path):
    """Run an SMTP server on 127.0.0.1 that requires STARTTLS (own certificate) and a login."""
    import ssl
    openssl = shutil.which('openssl')
    assert openssl, 'the openssl command is needed for the STARTTLS test (apt-get install openssl)'
    cert, key = tmp_path / 'cert.pem', tmp_path / 'key.pem'
    subprocess.run([openssl, 'req', '-x509', '-newkey', 'rsa:2048', '-nodes', '-days', '2',
                    '-subj', '/CN=127.0.0.1', '-addext', 'subjectAltName=IP:127.0.0.1',
                    '-keyout', str(key), '-out', str(cert)], check=True, capture_output=True)
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(cert, key)
    handler = MailHandler()
    handler.logins = []

    def authenticator(server, session, envelope, mechanism, auth_data):
        login = (auth_data.login.decode(), auth_data.password.decode())
        handler.logins.append(login)
        return AuthResult(success=login == ('wear', 'correct horse 7'), handled=False)
    controller = Controller(handler, hostname='127.0.0.1', port=_free_port(),
                            tls_context=context, require_starttls=True,
                            authenticator=authenticator, auth_require_tls=True,
                            auth_required=True)
    controller.start()
    handler.port, handler.cert = controller.port, cert
    yield handler
    controller.stop()


def _tls_config(tmp_path, server, password):
    (tmp_path / 'secrets').mkdir(exist_ok=True)
    (tmp_path / 'secrets' / 'smtp-password').write_text(password + '\n')
    path = tmp_path / 'mail.yaml'
    path.write_text(yaml.safe_dump({'email': {
        'host': '127.0.0.1', 'port': server.port, 'starttls': True, 'user': 'wear',
        'password_file': 'secrets/smtp-password', 'ca_file': str(server.cert),
        'from': 'wear@example.local', 'to': 'maintenance@example.local', 'timeout_s': 5}}))
    return load_notification_config(path)


def test_email_over_starttls_with_a_login_from_the_password_file(tmp_path, tls_smtp):
    config = _tls_config(tmp_path, tls_smtp, 'correct horse 7')
    assert 'correct horse' not in repr(config)
    with _one_alarm(tmp_path / 'h.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW)
    assert sent.delivered and tls_smtp.logins == [('wear', 'correct horse 7')]
    assert tls_smtp.messages[0]['Subject'] == '[robot-wear-monitor] r j: wear alarm raised'
    config = _tls_config(tmp_path, tls_smtp, 'wrong')
    with _one_alarm(tmp_path / 'h2.db') as history:
        [sent] = notify_once(history=history, config=config, now_s=NOW)
    assert not sent.delivered and sent.attempts == 1 and sent.error.startswith('SMTP 535')


# --------------------------------------------------------------------------- configuration

def test_the_example_configuration_loads(tmp_path):
    document = load_yaml_file(REPO_ROOT / 'config' / 'notifications.example.yaml')
    (tmp_path / 'smtp-password').write_text('s3cret\n')
    config = notification_config_from_mapping(document, source='example', base=tmp_path)
    assert config.channels == ('webhook:maintenance-chat', 'email')
    assert config.events == ('alarm_raised', 'forecast_crossing', 'joint_stale')
    assert config.forecast_horizon_s == 30 * DAY and config.email.password == 's3cret'
    assert (config.email.port, config.email.starttls, config.retry.passes) == (587, True, 3)


GOOD = {'webhooks': [{'url': 'https://hooks.example/x'}],
        'email': {'host': 'mail.example', 'from': 'a@example.local', 'to': ['b@example.local']}}


@pytest.mark.parametrize('change, message', [
    ({'colour': 'red'}, "(top level): unknown key 'colour'"),
    ({'email': {**GOOD['email'], 'password': 'x'}}, "email: unknown key 'password'"),
    ({'email': {**GOOD['email'], 'port': 70000}},
     'email.port: must be >= 1 and <= 65535, got 70000'),
    ({'email': {**GOOD['email'], 'port': '25'}}, 'email.port: must be an integer'),
    ({'email': {**GOOD['email'], 'user': 'u'}}, 'email.password_file: user and password_file '
                                                'go together'),
    ({'email': {**GOOD['email'], 'user': 'u', 'password_file': 'pw', 'starttls': False}},
     'email.starttls: must be true to log in'),
    ({'email': {**GOOD['email'], 'user': 'u', 'password_file': 'missing'}},
     'email.password_file: '),
    ({'email': {**GOOD['email'], 'to': ['not an address']}},
     'email.to[0]: must be an e-mail address, got not an address'),
    ({'email': {**GOOD['email'], 'from': 'a@b\r\nBcc: c@d'}}, 'email.from: must be an e-mail'),
    ({'webhooks': [{'url': 'ftp://hooks.example/x'}]},
     'webhooks[0].url: must be an http:// or https:// URL'),
    ({'webhooks': [{'url': 'https://a.example/', 'name': 'x'},
                   {'url': 'https://b.example/', 'name': 'x'}]}, 'two webhooks named x'),
    ({'webhooks': [{'url': 'https://a.example/', 'timeout_s': 0}]},
     'webhooks[0].timeout_s: must be > 0'),
    ({'events': ['alarm_raised', 'wear_high']},
     "events[1]: must be one of alarm_raised, forecast_crossing, joint_stale, got 'wear_high'"),
    ({'forecast_horizon_days': -1}, 'forecast_horizon_days: must be >= 0 and <= 3650 days'),
    ({'retry': {'attempts': 0}}, 'retry.attempts: must be >= 1'),
    ({'retry': {'total_s': float('nan')}}, 'retry.total_s: must be > 0'),
    ({'webhooks': None, 'email': None}, 'names no channel'),
])
def test_configuration_errors_name_the_file_and_the_field(tmp_path, change, message):
    path = tmp_path / 'notify.yaml'
    path.write_text(yaml.safe_dump({**GOOD, **change}))
    with pytest.raises(NotificationConfigError) as error:
        load_notification_config(path)
    text = str(error.value)
    assert text.startswith(f'{path}: ') and message in text and '\n' not in text


def test_a_configuration_that_is_no_mapping_or_missing(tmp_path):
    path = tmp_path / 'notify.yaml'
    path.write_text('- a list\n')
    with pytest.raises(NotificationConfigError, match='must be a mapping, got list'):
        load_notification_config(path)
    with pytest.raises(NotificationConfigError, match='cannot read notification config'):
        load_notification_config(tmp_path / 'absent.yaml')


# --------------------------------------------------------------------------- command line

def test_the_notify_verb_once_and_its_exit_codes(tmp_path, webhook, capsys):
    history_path = tmp_path / 'h.db'
    with WearHistory(history_path) as history:
        _fleet(history)
    _config(tmp_path, webhook=webhook)
    args = ['notify', '--history', str(history_path), '--config',
            str(tmp_path / 'notifications.yaml'), '--once', '--now', iso_time(NOW)]
    assert cli_main(args + ['--json']) == 0
    sent = json.loads(capsys.readouterr().out)
    assert sorted((s['robot'], s['joint'], s['kind']) for s in sent) == [
        ('cell_1', 'joint_2', 'alarm_raised'), ('cell_1', 'joint_2', 'forecast_crossing'),
        ('cell_1', 'joint_3', 'forecast_crossing'), ('cell_2', 'joint_2', 'joint_stale')]
    assert all(s['delivered'] and s['channel'] == 'webhook:ops' for s in sent)
    assert cli_main(args) == 0 and capsys.readouterr().out == ''  # all sent before
    with WearHistory(history_path) as history:
        history.append(_record('cell_9', 'joint_1', T0, wear=95.0, alarm=True), events=[
            AlarmEvent(robot='cell_9', joint='joint_1', stamp_s=T0, event='raised', wear=95)])
    webhook.fail_first = webhook.requests + 3
    assert cli_main(args) == 1
    err = capsys.readouterr().err
    assert 'FAILED alarm_raised cell_9 joint_1 via webhook:ops after 3 tries: HTTP 503' in err
    assert 'tried again on the next pass (1 of 2)' in err
    # the operator's view: the history's notification log, newest first
    assert cli_main(['notify', '--history', str(history_path), '--log', '--json']) == 0
    log = json.loads(capsys.readouterr().out)
    assert [row['status'] for row in log] == ['failure', 'failed'] + ['sent'] * 4
    assert log[0]['payload']['error'] == 'HTTP 503 Service Unavailable'
    assert cli_main(['notify', '--history', str(history_path), '--log', '2']) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[0].endswith(
        'webhook:ops  alarm_raised  cell_9  joint_1  FAILED pass 1 of 2 after 3 tries: '
        'HTTP 503 Service Unavailable')
    assert lines[1].endswith('webhook:ops  alarm_raised  cell_9  joint_1  failed')
    (tmp_path / 'bad.yaml').write_text('webhooks: [{url: x}]\n')
    assert cli_main(['notify', '--history', str(history_path), '--config',
                     str(tmp_path / 'bad.yaml'), '--once']) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f'robot-wear-monitor notify: error: {tmp_path / "bad.yaml"}: webhooks[0].url: '
                   'must be an http:// or https:// URL with a host, got x')


def test_the_loop_sends_and_stops(tmp_path, webhook):
    with WearHistory(tmp_path / 'h.db') as history:
        _fleet(history)
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised'])
    stop, reports = threading.Event(), []

    def report(sent):
        reports.append(sent)
        if len(reports) == 2:
            stop.set()
    notify_forever(location=str(tmp_path / 'h.db'), config=config, interval_s=0.01, stop=stop,
                   report=report, clock=lambda: NOW)
    assert [[s.kind for s in sent] for sent in reports] == [['alarm_raised'], []]
    errors: list = []
    stop.clear()
    (tmp_path / 'not-a-history.db').write_text('garbage')

    def on_error(error):
        errors.append(str(error))
        stop.set()
    notify_forever(location=str(tmp_path / 'not-a-history.db'), config=config,
                   interval_s=0.01, stop=stop, on_error=on_error)
    assert len(errors) == 1 and 'not-a-history.db' in errors[0]


class TricklingServer:
    """A loopback HTTP server that answers one byte every ``interval_s`` seconds, for ever."""

    def __init__(self, interval_s=2.0):
        self.interval_s = interval_s
        self.listener = socket.socket()
        self.listener.bind(('127.0.0.1', 0))
        self.listener.listen(8)
        self.port = self.listener.getsockname()[1]
        self.stop = threading.Event()
        self.connections = 0
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        self.listener.settimeout(0.2)
        while not self.stop.is_set():
            try:
                conn, _ = self.listener.accept()
            except OSError:
                continue
            self.connections += 1
            threading.Thread(target=self._trickle, args=(conn,), daemon=True).start()

    def _trickle(self, conn):
        answer = b'HTTP/1.1 200 OK\r\nContent-Length: 100000\r\n\r\n' + b'x' * 100000
        with conn:
            conn.settimeout(1.0)
            try:
                conn.recv(65536)
                for byte in answer:
                    if self.stop.wait(self.interval_s):
                        return
                    conn.sendall(bytes([byte]))
            except OSError:
                return

    def close(self):
        self.stop.set()
        self.listener.close()


def test_a_trickling_webhook_cannot_stall_a_send_past_its_deadline(tmp_path, capsys):
    server = TricklingServer(interval_s=2.0)
    try:
        path = tmp_path / 'notify.yaml'
        path.write_text(yaml.safe_dump({
            'events': ['alarm_raised'],
            'webhooks': [{'url': f'http://127.0.0.1:{server.port}/hook', 'timeout_s': 5}],
            'retry': {'attempts': 4, 'backoff_initial_s': 0.5, 'total_s': 10, 'passes': 1}}))
        _one_alarm(tmp_path / 'h.db').close()
        started = time.monotonic()
        code = cli_main(['notify', '--history', str(tmp_path / 'h.db'), '--config', str(path),
                         '--once', '--now', str(NOW)])
        elapsed_s = time.monotonic() - started
    finally:
        server.close()
    assert code == 1  # not delivered
    assert elapsed_s < 30.0, elapsed_s  # the bound; the policy allows about 10 s
    assert server.connections >= 2  # retried: a stalled try is a timeout, not a refusal
    assert 'no whole answer within' in capsys.readouterr().err


def test_a_passed_crossing_date_is_notified_as_overdue_once(tmp_path, webhook):
    """Issue 44: the crossing date passes with no experiment since: one 'overdue' alert."""
    config = _config(tmp_path, webhook=webhook, events=['forecast_crossing'])
    with WearHistory(tmp_path / 'h.db') as history:
        for k in range(3):
            history.append(_record('r', 'j', T0 + k * HOUR, wear=20.0, crossing=5.0))
        [ahead] = notify_once(history=history, config=config, now_s=T0 + 2 * HOUR + 60)
        assert notify_once(history=history, config=config, now_s=T0 + 6 * HOUR) == []
        # the date (T0 + 7 h at the usual hour) passes without an experiment
        [overdue] = notify_once(history=history, config=config, now_s=T0 + 8 * HOUR)
        assert notify_once(history=history, config=config, now_s=T0 + 9 * HOUR) == []
    date = iso_time(T0 + 7 * HOUR)[:10]
    assert (ahead.kind, overdue.kind) == ('forecast_crossing', 'forecast_crossing')
    first, second = webhook.alerts()
    assert first['groupKey'] == 'forecast_crossing/r/j/cycle-0'
    assert second['groupKey'] == f'forecast_crossing/r/j/cycle-0/overdue-{date}'
    summary = second['alerts'][0]['annotations']['summary']
    assert summary.startswith(f'r j: the forecast crossing of the wear threshold is overdue '
                              f'since {date}')
    assert second['commonLabels']['state'] == 'stale'  # and no experiment for 6 intervals


def test_a_postponed_planned_date_missed_again_is_notified_again(tmp_path, webhook):
    """Issue 44: an edit moves the planned date; when that one passes too, a new alert."""
    import datetime
    config = _config(tmp_path, webhook=webhook, events=['alarm_raised'])

    def day(text: str) -> float:
        return datetime.datetime.fromisoformat(text + 'T12:00:00+00:00').timestamp()
    with WearHistory(tmp_path / 'h.db') as history:
        _fleet(history)
        history.acknowledge_alarm(robot='cell_1', joint='joint_2', user='ana', owner='ben',
                                  comment='', planned_maintenance='2026-12-01')
        notify_once(history=history, config=config, now_s=day('2026-11-30'))
        [missed] = notify_once(history=history, config=config, now_s=day('2026-12-02'))
        history.edit_acknowledgement(robot='cell_1', joint='joint_2', user='ana',
                                     planned_maintenance='2026-12-05')
        # the new date ends the re-escalation (acknowledged anew): resolved, once
        [ended] = notify_once(history=history, config=config, now_s=day('2026-12-03'))
        assert notify_once(history=history, config=config, now_s=day('2026-12-04')) == []
        [again] = notify_once(history=history, config=config, now_s=day('2026-12-06'))
    assert (missed.kind, again.kind) == ('alarm_reescalated', 'alarm_reescalated')
    assert ended.kind == 'reescalation_resolved'
    # the audit trail: each missed date once, as the notifier saw it (schema version 11)
    with WearHistory(tmp_path / 'h.db') as history:
        logged = [e for e in history.events(robot='cell_1', joint='joint_2')
                  if e.event == 'reescalated']
    assert [(e.note, e.source) for e in logged] == [
        ('the planned maintenance date 2026-12-01 has passed', 'notify'),
        ('the planned maintenance date 2026-12-05 has passed', 'notify')]
    assert ended.event_key == f'reescalation_resolved/{missed.event_key}'
    [body] = [b for b in webhook.alerts() if b['status'] == 'resolved']
    assert body['groupKey'] == missed.event_key
    assert body['alerts'][0]['endsAt'] == iso_time(day('2026-12-03'))
    assert missed.event_key.endswith('/date-2026-12-01')
    assert again.event_key.endswith('/date-2026-12-05')
    assert 'the planned maintenance date 2026-12-05 has passed' in again.summary


# --------------------------------------------------------------------------- incidents (issue 44)

def test_the_first_pass_sends_one_summary_then_events_one_by_one(history_location, tmp_path,
                                                                 webhook, smtp):
    """Issue 44: a first pass on a history sends one message per channel, not a flood."""
    config = _config(tmp_path, webhook=webhook, smtp=smtp, first_pass_summary=True)
    assert notification_config_from_mapping(
        {'webhooks': [{'url': webhook.url}]}).first_pass_summary is True  # the default
    with WearHistory(history_location) as history:
        _fleet(history)
        sent = notify_once(history=history, config=config, now_s=NOW)
        # the four events due, as one webhook POST and one e-mail
        assert len(sent) == 8 and all(s.delivered for s in sent)
        assert {s.claim_key for s in sent} == {'first-pass-summary@webhook:ops',
                                               'first-pass-summary@email'}
        [body] = webhook.alerts()
        assert len(smtp.messages) == 1
        assert body['groupKey'] == 'first-pass-summary' and body['status'] == 'firing'
        assert sorted((a['labels']['robot'], a['labels']['joint'], a['labels']['alertname'])
                      for a in body['alerts']) == EXPECTED
        keys = {a['labels']['alertname'] + a['labels']['joint']: a['fingerprint']
                for a in body['alerts']}
        assert keys['WearAlarmRaisedjoint_2'] == hashlib.sha256(
            f'alarm_raised/cell_1/joint_2/{RAISE_S:.6f}'.encode()).hexdigest()[:16]
        assert body['commonAnnotations']['summary'].startswith('4 events due at the first pass')
        [message] = smtp.messages
        assert message['Subject'] == '[robot-wear-monitor] first pass: 4 events due'
        text = message.get_content()
        assert all(s.summary in text for s in sent)
        assert notify_once(history=history, config=config, now_s=NOW + 60) == []
        # later events one by one, and the summary's alerts resolve one by one
        history.reset_alarm(robot='cell_1', joint='joint_2', user='ana', reason='new gearbox')
        later = notify_once(history=history, config=config, now_s=NOW + 120)
    assert sorted((s.kind, s.channel) for s in later) == [
        ('alarm_resolved', 'email'), ('alarm_resolved', 'webhook:ops'),
        ('forecast_resolved', 'email'), ('forecast_resolved', 'webhook:ops')]
    ends = {b['commonLabels']['alertname']: b for b in webhook.alerts()[1:]}
    assert ends['WearAlarmRaised']['alerts'][0]['fingerprint'] == keys['WearAlarmRaisedjoint_2']
    assert ends['WearForecastCrossing']['alerts'][0]['fingerprint'] == \
        keys['WearForecastCrossingjoint_2']
    assert all(b['status'] == 'resolved' for b in ends.values())


def test_a_failed_first_pass_summary_is_sent_again_as_a_summary(tmp_path, webhook):
    webhook.fail_first = 3  # every try of the first pass
    config = _config(tmp_path, webhook=webhook, first_pass_summary=True)
    with WearHistory(tmp_path / 'h.db') as history:
        _fleet(history)
        failed = notify_once(history=history, config=config, now_s=NOW)
        assert len(failed) == 4 and not any(s.delivered for s in failed)
        assert history.notifications() == []  # every claim released
        again = notify_once(history=history, config=config, now_s=NOW + 60)
    assert len(again) == 4 and all(s.delivered for s in again)
    [body] = webhook.alerts()
    assert body['groupKey'] == 'first-pass-summary' and len(body['alerts']) == 4


def test_a_crossing_no_longer_due_and_a_reset_resolve_their_alerts_once(tmp_path, webhook):
    """Issue 44: every alert kind ends when its cause does; a reset ends all of a joint's."""
    config = _config(tmp_path, webhook=webhook)
    with WearHistory(tmp_path / 'h.db') as history:
        for k in range(3):
            history.append(_record('r', 'j', T0 + k * HOUR, wear=20.0, crossing=5.0))
        [ahead] = notify_once(history=history, config=config, now_s=T0 + 2 * HOUR + 60)
        assert ahead.kind == 'forecast_crossing'
        # a better estimate: the crossing now 2000 experiments (83 days) away, outside 30
        history.append(_record('r', 'j', T0 + 3 * HOUR, wear=15.0, crossing=2000.0))
        [ended] = notify_once(history=history, config=config, now_s=T0 + 3 * HOUR + 60)
        assert ended.kind == 'forecast_resolved'
        assert notify_once(history=history, config=config, now_s=T0 + 3 * HOUR + 120) == []
        # stale, then a reset (no alarm): the stale alert and nothing else ends
        [stale] = notify_once(history=history, config=config, now_s=T0 + 7 * HOUR)
        history.reset_alarm(robot='r', joint='j', user='ana', reason='preventive',
                            stamp_s=T0 + 7 * HOUR + 10)
        ends = notify_once(history=history, config=config, now_s=T0 + 7 * HOUR + 60)
    assert stale.kind == 'joint_stale'
    assert [s.kind for s in ends] == ['stale_resolved']
    first, end, stale_body, stale_end = webhook.alerts()
    assert (first['status'], end['status']) == ('firing', 'resolved')
    assert end['groupKey'] == first['groupKey'] == 'forecast_crossing/r/j/cycle-0'
    assert end['alerts'][0]['fingerprint'] == first['alerts'][0]['fingerprint']
    assert end['alerts'][0]['labels']['alertname'] == 'WearForecastCrossing'
    assert end['alerts'][0]['endsAt'] == iso_time(T0 + 3 * HOUR + 60)
    assert end['alerts'][0]['annotations']['summary'] == (
        'r j: resolved: the forecast crossing is no longer due')
    assert stale_end['groupKey'] == stale_body['groupKey'] and stale_end['status'] == 'resolved'
