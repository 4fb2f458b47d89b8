"""
The login rate limit counted in the history (schema version 13): the same rule on every worker.

Each test runs on both backends (SQLite, and the tests' PostgreSQL server).  Several
connections at once (as the workers of ``dashboard --workers N`` are) let exactly
``max_failures`` attempts of one address pass; the two keys (an address, a name from an
address) are counted apart; a good login takes its attempt back; the counts expire with
their window and are swept.
"""

import threading
import time

from robot_wear_monitor.history import WearHistory


def test_attempts_at_once_on_several_connections_pass_at_most_max_failures(history_location):
    with WearHistory(history_location):
        pass  # made once, before the connections race
    barrier = threading.Barrier(12)
    waits: list = []

    def worker(k: int) -> None:
        with WearHistory(history_location) as history:
            limits = history.login_failures(max_failures=5, window_s=600.0)
            barrier.wait()
            waits.append(limits.begin_attempt(user=f'name{k % 3}', address='10.0.0.9'))
    threads = [threading.Thread(target=worker, args=(k,)) for k in range(12)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(waits) == 12
    assert sum(w == 0.0 for w in waits) == 5  # the address's limit, whoever counted
    assert all(595.0 < w <= 600.0 for w in waits if w > 0.0)


def test_the_keys_apart_a_good_login_taken_back_and_the_window(history_location):
    with WearHistory(history_location) as history:
        limits = history.login_failures(max_failures=2, window_s=600.0)
        for _ in range(2):
            assert limits.begin_attempt(user='ana', address='10.0.0.1') == 0.0
        assert limits.retry_after_s(user='bob', address='10.0.0.1') > 0.0  # the address
        assert limits.retry_after_s(user='ana', address='10.0.0.2') == 0.0  # not the name
        limits.not_counted(user='ana', address='10.0.0.1')  # the history could not say
        assert limits.retry_after_s(user='bob', address='10.0.0.1') == 0.0
        assert limits.begin_attempt(user='ana', address='10.0.0.1') == 0.0
        limits.succeeded(user='ana', address='10.0.0.1')  # the pair forgotten, the try back
        assert limits.retry_after_s(user='ana', address='10.0.0.1') == 0.0
        with WearHistory(history_location) as other:  # another worker's connection
            again = other.login_failures(max_failures=2, window_s=600.0)
            assert again.retry_after_s(user='bob', address='10.0.0.1') == 0.0
            again.failed(user='dan', address='10.0.0.1')
            assert limits.retry_after_s(user='eve', address='10.0.0.1') > 0.0  # 1 + 1
        # the window: counts expire, and a write sweeps them (one window per history)
        short = history.login_failures(max_failures=1, window_s=0.3)
        short.failed(user='cy', address='10.0.0.3')
        assert short.retry_after_s(user='cy', address='10.0.0.3') > 0.0
        time.sleep(0.4)
        assert short.retry_after_s(user='cy', address='10.0.0.3') == 0.0
        assert short.begin_attempt(user='cy', address='10.0.0.4') == 0.0
        assert len(history._backend.execute('SELECT id FROM login_failures')) == 2  # swept
