"""
A small fleet history with known values for the dashboard's tests, and logging in.

Five joints written as HistoryRecords directly (so every number is known), whose order worst
first is known from the fleet rule (alarm, then the soonest crossing, then the highest upper
bound of w): ``ORDER``.  One robot's name is an HTML injection.
"""

import math
import re
import time

from robot_wear_monitor.history import AlarmEvent, HistoryRecord, open_history

HOUR_S = 3600.0
EXPERIMENTS = 6
XSS_ROBOT = '<img src=x onerror=alert(1)>'
PASSWORDS = {'mia': 'maintainer-pass-1', 'vic': 'viewer-pass-22'}
#: (robot, joint): (final w, half width of the interval, crossing [experiments], p-value)
PLAN = {
    ('press_line', 'joint_2'): (41.0, 8.0, 0.0, 0.4),
    ('welder_7', 'joint_3'): (30.0, 7.0, 4.0, 0.3),
    (XSS_ROBOT, 'joint_1'): (26.0, 9.0, 12.0, 0.5),
    ('welder_7', 'joint_5'): (18.0, 12.0, math.nan, 0.002),
    ('press_line', 'joint_1'): (6.0, 5.0, math.nan, 0.6),
}
#: The fleet's order worst first: the alarm, then crossing in 4 and 12, then the upper bounds.
ORDER = [('press_line', 'joint_2'), ('welder_7', 'joint_3'), (XSS_ROBOT, 'joint_1'),
         ('welder_7', 'joint_5'), ('press_line', 'joint_1')]


def wear_of(final: float, k: int) -> float:
    """Return the w of experiment ``k`` (0-based) of a joint whose last w is ``final``."""
    return round(final * (k + 1) / EXPERIMENTS, 3)


def record(robot: str, joint: str, k: int, *, now_s: float) -> HistoryRecord:
    """Return experiment ``k`` of the plan's joint, the last one an hour before ``now_s``."""
    final, half, crossing, p_value = PLAN[(robot, joint)]
    wear = wear_of(final, k)
    last = k == EXPERIMENTS - 1
    return HistoryRecord(
        joint=joint, robot=robot, stamp_s=now_s - (EXPERIMENTS - k) * HOUR_S,
        speeds_rad_s=(12.0, 28.5, 41.7), frictions=(0.08, 0.09, 0.1),
        temperature_degc=38.0 + k, temperature_std_degc=2.0, wear=wear, wear_std=3.0,
        chi2=1.0, dof=1, p_value=p_value if last else 0.5, temperature_at_bound=False,
        wear_at_bound=False, alarm_active=bool(last and final > 35.0), alarm_evidence=0.0,
        status_level=0, parameter_set='abb_irb6620_joint2', wear_low=max(0.0, wear - half),
        wear_high=wear + half, trend_wear=wear, trend_low=max(0.0, wear - half),
        trend_high=wear + half, crossing_experiments=crossing if last else math.nan)


def make_fleet(path: str, *, now_s: float | None = None) -> str:
    """Write the plan's fleet into a new history at ``path``, with two users; return path."""
    now_s = time.time() if now_s is None else now_s
    with open_history(path) as history:
        for (robot, joint) in PLAN:
            for k in range(EXPERIMENTS):
                rec = record(robot, joint, k, now_s=now_s)
                events = ()
                if rec.alarm_active:
                    events = (AlarmEvent(joint=joint, robot=robot, stamp_s=rec.stamp_s,
                                         event='raised', wear=rec.wear, note='w-hat >= 35'),)
                history.append(rec, events=events)
        history.add_user(name='mia', role='maintainer', password=PASSWORDS['mia'])
        history.add_user(name='vic', role='viewer', password=PASSWORDS['vic'])
    return path


def csrf_of(html: str) -> str:
    """Return the CSRF token of a page's forms."""
    found = re.search(r'name="csrf_token" value="([^"]+)"', html)
    assert found, 'no CSRF token in the page'
    return found.group(1)


def login(client, name: str, password: str | None = None):
    """Log ``name`` in with the test client; return the response (303 on success)."""
    token = csrf_of(client.get('/login').text)
    return client.post('/login', data={'username': name, 'csrf_token': token, 'next': '/',
                                       'password': PASSWORDS.get(name, '') if password is None
                                       else password}, follow_redirects=False)
