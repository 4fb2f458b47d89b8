"""
A claimed send is pending until settled; a notifier that died mid-send is taken over once.

The history's claims (schema version 13): a claim with a lease holds the key against every
other notifier while the lease runs and after it is settled; a claim left pending past its
lease (its notifier died between the claim and the end of its send, e.g. a dashboard worker
killed mid-pass) is taken over by the next claim, by exactly one of several notifiers at once.
On both backends (SQLite, and the tests' PostgreSQL server); the notifier's part with a real
webhook receiver on 127.0.0.1.
"""

from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
import json
import threading
import time

import pytest
from robot_wear_monitor.fleet.notifications import (claim_lease_s, CLAIM_MARGIN_S, due_events,
                                                    load_notification_config, notify_once)
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, WearHistory
import yaml

T0 = 1_790_000_000.0
NOW = T0 + 3600.0


@pytest.fixture()
def receiver():
    """Yield (URL, list of received JSON bodies) of a webhook receiver on 127.0.0.1."""
    received: list = []

    class Hook(BaseHTTPRequestHandler):

        def do_POST(self):  # noqa: N802 - http.server's name
            received.append(json.loads(self.rfile.read(int(self.headers['Content-Length']))))
            self.send_response(200)
            self.send_header('Content-Length', '0')
            self.end_headers()

        def log_message(self, *args):
            pass

    server = ThreadingHTTPServer(('127.0.0.1', 0), Hook)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f'http://127.0.0.1:{server.server_address[1]}/hook', received
    server.shutdown()
    server.server_close()


def _config(tmp_path, url):
    path = tmp_path / 'notifications.yaml'
    path.write_text(yaml.safe_dump({
        'events': ['alarm_raised'], 'first_pass_summary': False,
        'webhooks': [{'name': 'ops', 'url': url, 'timeout_s': 5}],
        'retry': {'attempts': 1, 'total_s': 30, 'passes': 1}}))
    return load_notification_config(path)


def _one_alarm(history):
    history.append(HistoryRecord(
        robot='r', joint='j', stamp_s=T0, speeds_rad_s=(2.1, 28.5), frictions=(0.1, 0.05),
        temperature_degc=40.0, temperature_std_degc=1.0, wear=90.0, wear_std=2.0, chi2=1.0,
        dof=1, p_value=0.5, temperature_at_bound=False, wear_at_bound=False, alarm_active=True,
        alarm_evidence=3.0, status_level=2, parameter_set='p', wear_low=86.0, wear_high=94.0,
        trend_wear=90.0), events=[AlarmEvent(robot='r', joint='j', stamp_s=T0, event='raised',
                                             wear=90.0)])


def _claim(history, key, lease_s):
    return history.claim_notification(event_key=key, robot='r', joint='j', kind='alarm_raised',
                                      channel='webhook:ops', payload={}, lease_s=lease_s)


def test_a_pending_claim_holds_until_its_lease_passes_and_a_settled_one_for_ever(
        history_location):
    with WearHistory(history_location) as history:
        assert _claim(history, 'a@webhook:ops', 0.3)
        assert not _claim(history, 'a@webhook:ops', 0.3)  # its lease runs
        [row] = history.notifications()
        assert row['pending_until_s'] is not None and row['pending_until_s'] > time.time()
        time.sleep(0.4)
        assert _claim(history, 'a@webhook:ops', 60.0)  # taken over: its notifier died
        assert not _claim(history, 'a@webhook:ops', 60.0)
        assert history.settle_notification(event_key='a@webhook:ops')
        assert history.notifications()[0]['pending_until_s'] is None
        assert _claim(history, 'b@webhook:ops', None)  # settled at once (a failure record)
        time.sleep(0.1)
        assert not _claim(history, 'a@webhook:ops', 0.0)  # settled claims are never taken
        assert not _claim(history, 'b@webhook:ops', 0.0)
        assert len(history.notifications()) == 2


def test_a_send_left_pending_by_a_dead_notifier_is_sent_once_after_its_lease(
        history_location, tmp_path, receiver):
    url, received = receiver
    config = _config(tmp_path, url)
    assert claim_lease_s(config) == 30 + CLAIM_MARGIN_S
    with WearHistory(history_location) as history:
        _one_alarm(history)
        [event] = due_events(history=history, config=config, now_s=NOW)
        # what a notifier killed between its claim and its send leaves behind
        assert _claim(history, f'{event.key}@webhook:ops', 0.5)
        assert notify_once(history=history, config=config, now_s=NOW) == []  # being sent
        assert received == []
        time.sleep(0.6)
    barrier = threading.Barrier(2)
    results: list = []

    def notifier() -> None:
        with WearHistory(history_location) as history:
            barrier.wait()
            results.append(notify_once(history=history, config=config, now_s=NOW + 60))
    threads = [threading.Thread(target=notifier) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(len(r) for r in results) == [0, 1]  # one of the two took it over
    [sent] = [s for r in results for s in r]
    assert sent.delivered and sent.kind == 'alarm_raised'
    assert [a['labels']['alertname'] for b in received for a in b['alerts']] == [
        'WearAlarmRaised']
    with WearHistory(history_location) as history:
        [row] = history.notifications()
        assert row['pending_until_s'] is None  # settled after the send
        assert notify_once(history=history, config=config, now_s=NOW + 120) == []
    assert len(received) == 1
