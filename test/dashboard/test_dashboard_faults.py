"""
The real server through faults: huge and wide bodies, half-sent requests, a PostgreSQL restart.

The dashboard runs as an operator runs it (``robot-wear-monitor dashboard`` in a process of its
own, uvicorn) on a PostgreSQL history.  A viewer's 50 MB body is answered 413 within seconds
without the server's memory growing by its size; a body of 300,000 keys is refused while
another request is answered at once; a connection that never finishes its request headers is
closed within 20 s; past ``--limit-concurrency`` new requests get 503; two Content-Length
headers are refused (different) or one (identical) before the app, as the docs say; after
PostgreSQL restarts ``/api/fleet`` answers 200 again within 10 s, on its own.
"""

import os
from pathlib import Path
import socket
import subprocess
import sys
import threading
import time

import httpx
import pytest
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import make_fleet
from wear_testing.postgres_server import find_postgresql_binaries, PostgresServer

REPO = Path(__file__).resolve().parents[2]
ACK = '/api/robots/press_line/joints/joint_2/acknowledge'


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return int(probe.getsockname()[1])


class Dashboard:
    """``robot-wear-monitor dashboard`` in a process of its own, on a free port."""

    def __init__(self, history: str, *extra: str) -> None:
        self.port = _free_port()
        self.url = f'http://127.0.0.1:{self.port}'
        env = {**os.environ, 'PYTHONPATH': str(REPO)}
        self.process = subprocess.Popen(
            [sys.executable, '-m', 'robot_wear_monitor.cli', 'dashboard', '--history', history,
             '--port', str(self.port), *extra], env=env, stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 60
        while True:
            assert self.process.poll() is None, self.process.communicate()[1]
            try:
                httpx.get(self.url + '/login', timeout=2)
                return
            except httpx.TransportError:
                assert time.monotonic() < deadline, 'the dashboard did not answer'
                time.sleep(0.2)

    def peak_rss_kb(self) -> int:
        """Return the process's peak resident memory (VmHWM) [kB]."""
        status = Path(f'/proc/{self.process.pid}/status').read_text()
        return int(next(line.split()[1] for line in status.splitlines()
                        if line.startswith('VmHWM:')))

    def stop(self) -> str:
        self.process.terminate()
        try:
            return self.process.communicate(timeout=30)[1]
        except subprocess.TimeoutExpired:
            self.process.kill()
            return self.process.communicate()[1]


def _token(history: str, user: str) -> str:
    with open_history(history, init=False) as stored:
        return stored.add_token(user=user, label='faults')[1]


def _send_body(port: int, head: bytes, chunks, answers: dict) -> None:
    """Send ``head`` and the ``chunks`` (stop when the server hangs up); keep its answer."""
    with socket.create_connection(('127.0.0.1', port), timeout=20) as sock:
        sent_at = time.monotonic()
        sock.sendall(head)
        received = b''

        def read() -> None:
            nonlocal received
            try:
                while True:
                    data = sock.recv(65536)
                    if not data:
                        return
                    received += data
            except OSError:
                return
        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        sent = 0
        try:
            for chunk in chunks:
                if received:
                    break
                sock.sendall(chunk)
                sent += len(chunk)
        except OSError:
            pass  # the server hung up: what it answered is read below
        reader.join(timeout=20)
        answers.update(status=received.split(b'\r\n', 1)[0], sent=sent,
                       seconds=answers.get('answered_at', time.monotonic()) - sent_at,
                       text=received)


@pytest.fixture()
def dashboard(postgresql_url):
    history = make_fleet(postgresql_url)
    server = Dashboard(history, '--limit-concurrency', '40', '--header-timeout-s', '5')
    yield server, history
    server.stop()


def test_a_viewers_50_mb_body_is_refused_at_once_without_the_memory(dashboard):
    server, history = dashboard
    token = _token(history, 'vic')
    before = server.peak_rss_kb()
    megabyte = b'{"owner":"' + b'x' * (1 << 20)
    for declared in (True, False):  # with a Content-Length, and chunked (counted as it comes)
        head = (f'POST {ACK} HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {token}\r\n'
                'Content-Type: application/json\r\n').encode()
        if declared:
            head += f'Content-Length: {50 << 20}\r\n\r\n'.encode()
            chunks = (megabyte for _ in range(50))
        else:
            head += b'Transfer-Encoding: chunked\r\n\r\n'
            chunks = (b'%x\r\n' % len(megabyte) + megabyte + b'\r\n' for _ in range(50))
        answers: dict = {}
        started = time.monotonic()
        _send_body(server.port, head, chunks, answers)
        assert answers['status'].startswith(b'HTTP/1.1 413'), answers['text'][:300]
        assert time.monotonic() - started < 5.0
        assert answers['sent'] < 10 << 20  # the server hung up long before the 50 MB
    grown_mb = (server.peak_rss_kb() - before) / 1024
    assert grown_mb < 100, grown_mb
    # and the server is well: the viewer reads the fleet
    fleet = httpx.get(server.url + '/api/fleet', headers={'Authorization': f'Bearer {token}'},
                      timeout=5)
    assert fleet.status_code == 200


def test_300000_keys_are_refused_while_another_request_is_answered(dashboard):
    server, history = dashboard
    token = _token(history, 'mia')
    body = ('{' + ','.join(f'"k{i}":0' for i in range(300000)) + '}').encode()
    head = (f'POST {ACK} HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {token}\r\n'
            'Content-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n').encode()
    pieces = [body[i:i + 16384] for i in range(0, len(body), 16384)]
    chunks = [b'%x\r\n' % len(p) + p + b'\r\n' for p in pieces] + [b'0\r\n\r\n']
    answers: dict = {}
    started = time.monotonic()
    sender = threading.Thread(target=_send_body, args=(server.port, head, chunks, answers))
    sender.start()
    other = httpx.get(server.url + '/login', timeout=5)
    other_s = time.monotonic() - started
    sender.join(timeout=30)
    assert other.status_code == 200 and other_s < 1.0, other_s
    assert answers['status'].split()[1] in (b'413', b'422'), answers['text'][:300]
    assert time.monotonic() - started < 3.0
    # the same keys with a Content-Length: refused before a byte of the body is read
    declared = head.replace(b'Transfer-Encoding: chunked',
                            f'Content-Length: {len(body)}'.encode())
    answers = {}
    started = time.monotonic()
    _send_body(server.port, declared, [body], answers)
    assert answers['status'].startswith(b'HTTP/1.1 413')
    assert time.monotonic() - started < 3.0


def _raw(port: int, request: bytes) -> bytes:
    with socket.create_connection(('127.0.0.1', port), timeout=20) as sock:
        sock.sendall(request)
        return sock.recv(65536)


def test_two_content_lengths_as_the_docs_say(dashboard):
    # two different values: refused by h11 before the app (400); two identical ones are one
    server, _ = dashboard
    head = (b'POST /login HTTP/1.1\r\nHost: x\r\nConnection: close\r\n'
            b'Content-Type: application/x-www-form-urlencoded\r\n')
    body = b'username=mia'
    different = _raw(server.port, head + b'Content-Length: 12\r\nContent-Length: 13\r\n\r\n'
                     + body)
    assert different.startswith(b'HTTP/1.1 400'), different[:200]
    same = _raw(server.port, head + b'Content-Length: 12\r\nContent-Length: 12\r\n\r\n'
                + body)
    assert same.startswith(b'HTTP/1.1 403'), same[:200]  # read as one: the CSRF check speaks
    kinds = _raw(server.port, head + b'Content-Type: text/plain\r\nContent-Length: 12\r\n\r\n'
                 + body)
    assert kinds.startswith(b'HTTP/1.1 400'), kinds[:200]


def test_a_half_sent_request_is_closed_and_the_concurrency_is_bounded(dashboard):
    server, _ = dashboard
    started = time.monotonic()
    with socket.create_connection(('127.0.0.1', server.port), timeout=30) as half:
        half.sendall(b'GET /login HTTP/1.1\r\nHost: x\r\nX-Slow: ')  # and nothing more
        assert half.recv(1024) == b''  # closed by the server
    closed_s = time.monotonic() - started
    assert 4.0 <= closed_s < 20.0, closed_s  # --header-timeout-s 5
    # a connection that sends nothing at all is closed too
    with socket.create_connection(('127.0.0.1', server.port), timeout=30) as silent:
        assert silent.recv(1024) == b''
    # past --limit-concurrency (40), new requests get 503 while the idle ones hold on
    idle = [socket.create_connection(('127.0.0.1', server.port)) for _ in range(45)]
    try:
        time.sleep(0.5)
        assert httpx.get(server.url + '/login', timeout=5).status_code == 503
    finally:
        for sock in idle:
            sock.close()
    deadline = time.monotonic() + 10
    while httpx.get(server.url + '/login', timeout=5).status_code != 200:
        assert time.monotonic() < deadline, 'the dashboard did not come back'
        time.sleep(0.2)


def test_the_dashboard_answers_again_after_postgresql_restarts(tmp_path):
    binaries = find_postgresql_binaries()
    if binaries is None:
        pytest.skip('no PostgreSQL server binaries')
    database = PostgresServer(binaries)
    try:
        database.start()
        history = make_fleet(database.create_database())
        token = _token(history, 'vic')
        server = Dashboard(history)
        headers = {'Authorization': f'Bearer {token}'}
        try:
            for _ in range(3):  # several pooled connections in use
                assert httpx.get(server.url + '/api/fleet', headers=headers,
                                 timeout=5).status_code == 200
            database.restart()
            restarted = time.monotonic()
            statuses = []
            while True:
                status = httpx.get(server.url + '/api/fleet', headers=headers,
                                   timeout=10).status_code
                statuses.append(status)
                if status == 200:
                    break
                assert status == 503, statuses  # not a 500, not a 401: the history is away
                assert time.monotonic() - restarted < 10.0, statuses
                time.sleep(0.2)
            assert time.monotonic() - restarted < 10.0
            for _ in range(5):  # and it stays up
                assert httpx.get(server.url + '/api/fleet', headers=headers,
                                 timeout=5).status_code == 200
            # the right password logs in (a 503 while it was away never counted)
            login = httpx.get(server.url + '/login', timeout=5)
            assert login.status_code == 200
        finally:
            log = server.stop()
        assert 'Traceback' not in log, log[-3000:]
    finally:
        database.stop()
