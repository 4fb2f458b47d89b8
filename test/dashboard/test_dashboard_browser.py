"""
The dashboard as a person uses it: a real headless Chromium (Selenium) against uvicorn.

The server runs in a thread on 127.0.0.1 with a free port, over a history with known values
(fleet_history.py).  Debian's ``chromium`` and ``chromium-driver`` (``.ci/run`` installs them):
where they are missing these tests skip, except in CI (``CI`` set), where they fail.
"""

from dataclasses import replace
import os
import re
import socket
import threading
import time

import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.history import AlarmEvent, open_history
from wear_testing.fleet_history import (EXPERIMENTS, make_fleet, ORDER, PASSWORDS, record,
                                        wear_of, XSS_ROBOT)

CHROMEDRIVER = '/usr/bin/chromedriver'
CHROMIUM = '/usr/bin/chromium'
#: The longest wait for a page or an element [s]: generous, since a wait ends when it is met
#: (on 2 cores at load 22-26 a page took over 20 s to load).
WAIT_S = 90.0


def _need_chromium() -> None:
    missing = [p for p in (CHROMEDRIVER, CHROMIUM) if not os.path.exists(p)]
    if not missing:
        return
    message = (f'{", ".join(missing)} missing: apt-get install chromium chromium-driver '
               '(.ci/run does it)')
    if os.environ.get('CI'):
        pytest.fail(message)
    pytest.skip(message)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return sock.getsockname()[1]


@pytest.fixture()
def history(tmp_path) -> str:
    return make_fleet(str(tmp_path / 'fleet.sqlite3'))


@pytest.fixture()
def server(history):
    """Serve the dashboard of ``history`` with uvicorn in a thread; yield its base URL."""
    import uvicorn
    port = _free_port()
    app = create_app(DashboardSettings(history=history, poll_interval_ms=400))
    config = uvicorn.Config(app, host='127.0.0.1', port=port, log_level='warning')
    instance = uvicorn.Server(config)
    thread = threading.Thread(target=instance.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + WAIT_S
    while not instance.started:
        assert time.monotonic() < deadline, 'uvicorn did not start'
        assert thread.is_alive(), 'uvicorn stopped'
        time.sleep(0.05)
    yield f'http://127.0.0.1:{port}'
    instance.should_exit = True
    thread.join(timeout=WAIT_S)


def _chromium(*, javascript: bool = True):
    """Start a headless Chromium (with JavaScript off when asked); return its driver."""
    _need_chromium()
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ('--headless=new', '--no-sandbox', '--disable-dev-shm-usage',
                     '--window-size=1400,1000', '--disable-gpu'):
        options.add_argument(argument)
    if not javascript:
        options.add_experimental_option(
            'prefs', {'profile.managed_default_content_settings.javascript': 2})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.set_page_load_timeout(WAIT_S)
    return driver


@pytest.fixture()
def browser():
    driver = _chromium()
    yield driver
    driver.quit()


@pytest.fixture()
def browser_without_javascript():
    driver = _chromium(javascript=False)
    yield driver
    driver.quit()


def _wait(driver, condition, what: str):
    """
    Wait until ``condition(driver)`` is truthy; return it.

    An element found on a page that is going away (a form posted, the next page loading) or
    replaced by the page's script is stale by the time it is read: that try counts as not yet.
    """
    from selenium.common.exceptions import NoSuchElementException, StaleElementReferenceException
    from selenium.webdriver.support.ui import WebDriverWait
    return WebDriverWait(driver, WAIT_S, poll_frequency=0.1, ignored_exceptions=(
        NoSuchElementException, StaleElementReferenceException)).until(
        lambda d: condition(d), message=what)


def _submit(driver, button_id: str, flash: str, what: str) -> None:
    """
    Click a form's button and wait for the page the post leads to, with ``flash`` in its flash.

    The old page must go first (Selenium's ``staleness_of`` its root element): what is read
    afterwards is the new page's, not the one still shown while the post is under way.
    """
    from selenium.webdriver.support import expected_conditions
    old_page = driver.find_element(_by('TAG_NAME'), 'html')
    driver.find_element(_by('ID'), button_id).click()
    _wait(driver, expected_conditions.staleness_of(old_page), f'{what}: the next page')
    _wait(driver, lambda d: flash in d.find_element(_by('ID'), 'flash').text, what)


def _newest_event(driver, event: str) -> list[str]:
    """Return the cells of the joint page's newest event once it is ``event`` (script-drawn)."""
    def cells(d):
        row = d.find_elements(_by('CSS_SELECTOR'), '#joint-events tbody tr')[:1]
        texts = [td.text for td in row[0].find_elements(_by('TAG_NAME'), 'td')] if row else []
        return texts if texts[1:2] == [event] else None
    return _wait(driver, cells, f'the event {event}')


def _by(kind: str):
    from selenium.webdriver.common.by import By
    return getattr(By, kind)


def _log_in(driver, base: str, name: str) -> None:
    driver.get(base + '/')
    assert '/login' in driver.current_url  # no session: the login page
    driver.find_element(_by('ID'), 'username').send_keys(name)
    driver.find_element(_by('ID'), 'password').send_keys(PASSWORDS[name])
    driver.find_element(_by('ID'), 'login-button').click()
    _wait(driver, lambda d: d.find_elements(_by('ID'), 'fleet-rows'), 'the fleet page')


def _no_alert(driver) -> None:
    from selenium.common.exceptions import NoAlertPresentException
    with pytest.raises(NoAlertPresentException):
        driver.switch_to.alert.text


def _rows(driver) -> list[tuple[str, str]]:
    return [(tr.find_element(_by('CSS_SELECTOR'), '.c-robot').text,
             tr.find_element(_by('CSS_SELECTOR'), '.c-joint').text)
            for tr in driver.find_elements(_by('CSS_SELECTOR'), '#fleet-rows tr')]


def _wear_trace(driver) -> dict:
    script = ("const gd = document.getElementById('wear-chart');"
              'if (!gd || !gd.data) { return null; }'
              "const t = gd.data.find((d) => d.name === 'w-hat');"
              'return t ? {x: Array.from(t.x), y: Array.from(t.y)} : null;')
    return _wait(driver, lambda d: d.execute_script(script), 'the w-hat trace of the chart')


def test_fleet_worst_first_then_a_joint_with_one_point_per_experiment(server, browser):
    _log_in(browser, server, 'vic')
    assert _rows(browser) == ORDER
    counts = {n.get_attribute('data-state'): n.text
              for n in browser.find_elements(_by('CSS_SELECTOR'), '#counts .count')}
    # welder_7 joint_3 (w-hat 30 >= 28) and the XSS robot's joint_1 (a crossing near) warn
    assert counts['alarm'] == '1' and counts['warning'] == '2' and counts['ok'] == '2'
    browser.find_element(_by('LINK_TEXT'), 'joint_5').click()
    _wait(browser, lambda d: d.find_elements(_by('ID'), 'joint-name'), 'the joint page')
    assert browser.find_element(_by('ID'), 'joint-name').text == 'joint_5'
    trace = _wear_trace(browser)
    assert len(trace['x']) == EXPERIMENTS
    assert trace['y'] == pytest.approx([wear_of(18.0, k) for k in range(EXPERIMENTS)])
    # the experiment whose model check failed (p = 0.002) is marked
    failed = browser.execute_script(
        "return document.getElementById('wear-chart').data"
        ".find((d) => d.name.startsWith('model check failed')).y;")
    assert failed == pytest.approx([18.0])
    assert browser.execute_script(
        "return document.getElementById('friction-chart').data.length;") >= 2
    # the OpenAPI page works offline: Swagger UI from the app lists the API's routes
    browser.get(server + '/docs')
    paths = _wait(browser, lambda d: [n.text for n in d.find_elements(
        _by('CSS_SELECTOR'), '.opblock-summary-path')], 'the OpenAPI page')
    assert '/api/fleet' in paths and '/api/alarms' in paths


def test_maintainer_acknowledges_then_resets_with_a_reason(server, browser, history):
    _log_in(browser, server, 'mia')
    browser.get(server + joint_url('press_line', 'joint_2'))
    browser.find_element(_by('ID'), 'ack-owner').send_keys('Team B')
    browser.find_element(_by('ID'), 'ack-comment').send_keys('gearbox ordered')
    browser.find_element(_by('ID'), 'acknowledge-button').click()
    _wait(browser, lambda d: 'alarm acknowledged' in d.find_element(_by('ID'), 'flash').text,
          'the acknowledgement')
    browser.get(server + '/')
    first = browser.find_element(_by('CSS_SELECTOR'), '#fleet-rows tr')
    assert first.find_element(_by('CSS_SELECTOR'), '.c-state').text == 'acknowledged'
    assert 'acknowledged by mia' in first.find_element(_by('CSS_SELECTOR'), '.c-alarm').text
    browser.get(server + joint_url('press_line', 'joint_2'))
    browser.find_element(_by('ID'), 'reset-reason').send_keys('gearbox replaced, SN 4711')
    browser.find_element(_by('ID'), 'reset-confirm').click()
    browser.find_element(_by('ID'), 'reset-button').click()
    _wait(browser, lambda d: 'alarm reset' in d.find_element(_by('ID'), 'flash').text,
          'the reset')
    assert not browser.find_elements(_by('ID'), 'reset-form')
    browser.find_element(_by('LINK_TEXT'), 'Alarm log').click()
    newest = _wait(browser, lambda d: d.find_elements(_by('CSS_SELECTOR'), '#alarm-log tbody tr'),
                   'the alarm log')[0]
    cells = [td.text for td in newest.find_elements(_by('TAG_NAME'), 'td')]
    assert cells[1:4] == ['press_line', 'joint_2', 'reset']
    assert cells[5] == 'mia' and cells[-1] == 'reset by mia: gearbox replaced, SN 4711'
    with open_history(history, init=False) as stored:
        assert not stored.restore(joint='joint_2', robot='press_line').alarm_active
        assert (stored.alarm_log()[0].event, stored.alarm_log()[0].user) == ('reset', 'mia')


def test_triage_order_then_a_reset_reads_as_a_new_life(server, browser, history):
    with open_history(history) as stored:
        stored.acknowledge_alarm(robot='press_line', joint='joint_2', user='mia', owner='ben',
                                 comment='gear box ordered')
        last = stored.records(robot='welder_7', joint='joint_5')[-1]
        newer = replace(last, id=None, stamp_s=last.stamp_s + 60.0, wear=36.0, wear_low=31.0,
                        wear_high=41.0, alarm_active=True)
        stored.append(newer, events=[AlarmEvent(joint='joint_5', robot='welder_7',
                                                stamp_s=newer.stamp_s, event='raised',
                                                wear=36.0, note='w-hat 36 >= 35, evidence 2')])
    _log_in(browser, server, 'mia')
    # the new unacknowledged alarm above the older acknowledged one (of the higher wear)
    assert _rows(browser)[:2] == [('welder_7', 'joint_5'), ('press_line', 'joint_2')]
    states = [td.text for td in browser.find_elements(_by('CSS_SELECTOR'),
                                                      '#fleet-rows tr .c-state')]
    assert states[:2] == ['alarm', 'acknowledged']
    browser.get(server + joint_url('press_line', 'joint_2'))
    browser.find_element(_by('ID'), 'reset-reason').send_keys('gearbox replaced')
    browser.find_element(_by('ID'), 'reset-confirm').click()
    browser.find_element(_by('ID'), 'reset-button').click()
    _wait(browser, lambda d: 'alarm reset' in d.find_element(_by('ID'), 'flash').text,
          'the reset')
    line = re.compile(r'reset \d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ by mia \(gearbox replaced\): '
                      r'awaiting the first experiment')
    assert line.fullmatch(browser.find_element(_by('ID'), 'f-wear').text)
    assert browser.find_element(_by('ID'), 'f-state').text == 'new life'
    assert browser.find_element(_by('ID'), 'f-trend').text == '?'
    assert browser.find_element(_by('ID'), 'f-alarm').text == 'clear'
    assert browser.find_element(_by('ID'), 'f-experiments').text == '0'
    # the old life stays on the wear chart, greyed, under its own name; the new life is empty
    browser.get(server + joint_url('press_line', 'joint_2'))
    lives = _wait(browser, lambda d: d.execute_script(
        "const gd = document.getElementById('wear-chart');"
        'if (!gd || !gd.data) { return null; }'
        "const old = gd.data.find((t) => t.name === 'w-hat (before the reset)');"
        "const now = gd.data.find((t) => t.name === 'w-hat');"
        'return old && now ? [old.x.length, now.x.length, old.marker.color] : null;'),
        'the old life on the wear chart')
    assert lives == [EXPERIMENTS, 0, '#9aa5b1']
    browser.get(server + '/')
    _wait(browser, lambda d: d.find_elements(_by('ID'), 'fleet-rows'), 'the fleet page')
    row = browser.find_element(_by('CSS_SELECTOR'), '#fleet-rows tr[data-joint="joint_2"]'
                                                    '[data-robot="press_line"]')
    assert line.fullmatch(row.find_element(_by('CSS_SELECTOR'), '.c-wear .num').text)
    # the threshold beside it: the history's rows store none, so the set's, said to be assumed
    assert row.find_element(_by('CSS_SELECTOR'), '.c-wear .thr').text == \
        'threshold 35 (assumed)'
    assert row.find_element(_by('CSS_SELECTOR'), '.c-state').text == 'new life'
    assert _rows(browser)[-1] == ('press_line', 'joint_2')  # nothing to judge yet: last
    browser.get(server + '/alarms')
    newest = _wait(browser, lambda d: d.find_elements(_by('CSS_SELECTOR'), '#alarm-log tbody tr'),
                   'the alarm log')
    notes = [tr.find_elements(_by('TAG_NAME'), 'td')[-1].text for tr in newest[:3]]
    assert notes == ['reset by mia: gearbox replaced',
                     'acknowledged by mia, taken on by ben: gear box ordered',
                     'w-hat 36 reached the wear threshold 35 (alarm evidence 2)']


def test_viewer_cannot_reset(server, browser, history):
    _log_in(browser, server, 'vic')
    url = joint_url('press_line', 'joint_2')
    browser.get(server + url)
    assert not browser.find_elements(_by('ID'), 'reset-form')
    assert 'maintainer' in browser.find_element(_by('ID'), 'viewer-note').text
    # the form sent anyway, from the viewer's own session, with the CSRF token: refused
    status = browser.execute_async_script(
        'const done = arguments[arguments.length - 1];'
        "const body = new FormData(); body.set('reason', 'not mine to say');"
        "body.set('csrf_token', document.querySelector('input[name=csrf_token]').value);"
        "fetch(arguments[0], {method: 'POST', body: body}).then((r) => done(r.status));",
        url + '/reset')
    assert status == 403
    with open_history(history, init=False) as stored:
        assert stored.restore(joint='joint_2', robot='press_line').alarm_active


def test_a_robot_named_like_html_shows_as_text(server, browser):
    _log_in(browser, server, 'vic')
    _no_alert(browser)
    assert XSS_ROBOT in [robot for robot, _ in _rows(browser)]
    assert not browser.find_elements(_by('CSS_SELECTOR'), '#fleet-rows img')
    browser.get(server + joint_url(XSS_ROBOT, 'joint_1'))
    _wear_trace(browser)
    _no_alert(browser)
    assert browser.find_element(_by('ID'), 'robot-name').text == XSS_ROBOT
    assert not browser.find_elements(_by('CSS_SELECTOR'), 'main img')


def test_new_experiments_appear_without_a_reload(server, browser, history):
    _log_in(browser, server, 'vic')
    browser.execute_script('window.notReloaded = true;')
    row = browser.find_element(_by('CSS_SELECTOR'), '#fleet-rows tr[data-joint="joint_1"]'
                                                    '[data-robot="press_line"]')
    assert row.find_element(_by('CSS_SELECTOR'), '.c-experiments').text == str(EXPERIMENTS)
    with open_history(history) as stored:
        stored.append(record('press_line', 'joint_1', EXPERIMENTS, now_s=time.time() + 3600))
    _wait(browser, lambda d: row.find_element(_by('CSS_SELECTOR'), '.c-experiments').text
          == str(EXPERIMENTS + 1), 'the new experiment on the fleet page')
    assert browser.execute_script('return window.notReloaded === true;')  # the same page
    # a joint new to the history gets its row, in its place (crossing in 4: second)
    with open_history(history) as stored:
        stored.append(replace(record('welder_7', 'joint_3', 0, now_s=time.time()),
                              joint='joint_6', crossing_experiments=2.0, wear=31.0))
    _wait(browser, lambda d: _rows(d)[1] == ('welder_7', 'joint_6'), 'the new joint')
    new = browser.find_element(_by('CSS_SELECTOR'), '#fleet-rows tr[data-joint="joint_6"]')
    assert new.find_element(_by('CSS_SELECTOR'), '.c-joint a').get_attribute('href') == \
        server + joint_url('welder_7', 'joint_6')
    assert new.find_element(_by('CSS_SELECTOR'), '.c-wear .num').text.startswith('31.0 [')
    assert browser.execute_script('return window.notReloaded === true;')
    browser.get(server + joint_url('press_line', 'joint_1'))
    assert len(_wear_trace(browser)['x']) == EXPERIMENTS + 1
    browser.execute_script('window.notReloaded = true;')
    with open_history(history) as stored:
        stored.append(record('press_line', 'joint_1', EXPERIMENTS + 1,
                             now_s=time.time() + 7200))
    _wait(browser, lambda d: len(_wear_trace(d)['x']) == EXPERIMENTS + 2,
          'the new experiment in the chart')
    assert browser.execute_script('return window.notReloaded === true;')


def _clipped_joint(history: str) -> None:
    """Add press_line/joint_9: w-hat 58 [50, 66], past the bar's scale (0 to 52.5)."""
    now_s = time.time()
    with open_history(history) as stored:
        for k in range(EXPERIMENTS):
            rec = replace(record('press_line', 'joint_1', k, now_s=now_s), joint='joint_9')
            if k == EXPERIMENTS - 1:
                rec = replace(rec, wear=58.0, wear_low=50.0, wear_high=66.0)
            stored.append(rec)


def test_every_bar_has_its_threshold_tick_at_the_same_place(server, browser, history):
    _clipped_joint(history)
    _log_in(browser, server, 'vic')
    bars = browser.execute_script(
        "return Array.from(document.querySelectorAll('#fleet-rows tr')).map((tr) => {"
        '  const box = (s) => tr.querySelector(s).getBoundingClientRect();'
        "  return {joint: tr.dataset.robot + '/' + tr.dataset.joint, bar: box('svg.bar').x,"
        "    width: box('svg.bar').width, tick: box('.threshold').x + box('.threshold').width / 2,"
        "    mark: box('.estimate').x + box('.estimate').width / 2,"
        "    clip: tr.querySelector('.clip').getAttribute('visibility'),"
        "    text: tr.querySelector('.c-wear .num').textContent};});")
    assert len(bars) == len(ORDER) + 1
    ticks = [b['tick'] for b in bars]
    assert max(ticks) - min(ticks) < 0.5, bars  # the same x in every row
    for b in bars:  # two thirds along the bar: 35 of 0 to 52.5
        assert (b['tick'] - b['bar']) / b['width'] == pytest.approx(2 / 3, abs=0.01)
    clipped = next(b for b in bars if b['joint'] == 'press_line/joint_9')
    assert clipped['clip'] == 'visible' and clipped['text'].startswith('58.0 [50.0, 66.0]')
    assert (clipped['mark'] - clipped['bar']) / clipped['width'] == pytest.approx(1.0, abs=0.01)
    rest = [b for b in bars if b is not clipped]
    assert all(b['clip'] == 'hidden' for b in rest)
    joint_5 = next(b for b in bars if b['joint'] == 'welder_7/joint_5')  # w-hat 18
    assert (joint_5['mark'] - joint_5['bar']) / joint_5['width'] == pytest.approx(18 / 52.5,
                                                                                  abs=0.01)
    legend = browser.find_element(_by('ID'), 'arrow-legend').text
    for arrow in ('\u2191', '\u2197', '\u2192', '?'):
        assert arrow in legend


def test_the_wear_chart_marks_raised_acknowledged_reset_and_now(server, browser, history):
    with open_history(history) as stored:
        stored.acknowledge_alarm(joint='joint_2', robot='press_line', user='mia',
                                 owner='Team B', comment='gearbox ordered')
        stored.reset_alarm(joint='joint_2', robot='press_line', user='mia',
                           reason='gearbox replaced')
        events = {e.event: e.stamp_s for e in stored.events(joint='joint_2', robot='press_line')}
        raised_at = [r.stamp_s for r in stored.records(joint='joint_2', robot='press_line')
                     if r.alarm_active][0]
    assert events['raised'] == raised_at
    _log_in(browser, server, 'vic')
    browser.get(server + joint_url('press_line', 'joint_2'))
    _wear_trace(browser)
    marks = browser.execute_script(
        "const gd = document.getElementById('wear-chart');"
        'return {shapes: gd.layout.shapes.map((s) => [s.name, s.x0, s.x1]),'
        '  notes: gd.layout.annotations.map((a) => [a.text, a.x]), now: Date.now()};')
    notes = dict(marks['notes'])
    assert set(notes) == {'raised', 'acknowledged', 'reset', 'now'}
    for kind in ('raised', 'acknowledged', 'reset'):
        assert notes[kind] == pytest.approx(events[kind] * 1000.0, abs=1.0), kind
    assert abs(notes['now'] - marks['now']) < 120e3  # drawn when the page was
    assert sorted(name for name, _, _ in marks['shapes']) == [
        'marker acknowledged', 'marker now', 'marker raised', 'marker reset']
    assert all(x0 == x1 for _, x0, x1 in marks['shapes'])  # vertical lines


def test_the_forecast_says_days_and_a_date(server, browser, history):
    with open_history(history, init=False) as stored:
        last = stored.records(joint='joint_3', robot='welder_7')[-1].stamp_s
    # 4 experiments ahead, an hour apart: 0.2 days after the last, on that date (UTC)
    date = time.strftime('%Y-%m-%d', time.gmtime(last + 4 * 3600.0))
    _log_in(browser, server, 'vic')
    cell = browser.find_element(_by('CSS_SELECTOR'), '#fleet-rows tr[data-robot="welder_7"]'
                                '[data-joint="joint_3"] .c-crossing').text
    assert cell == f'in 4 experiments \u2248 0.2 days (~{date})'
    browser.get(server + joint_url('welder_7', 'joint_3'))
    crossing = browser.find_element(_by('ID'), 'f-crossing')
    assert crossing.text == cell
    # the date is one token on one line
    assert crossing.find_element(_by('CSS_SELECTOR'), '.t').value_of_css_property(
        'white-space') == 'nowrap'


def test_a_phone_wide_fleet_page_has_no_sideways_scroll(server, browser):
    _log_in(browser, server, 'mia')
    browser.set_window_size(390, 844)
    _wait(browser, lambda d: d.execute_script('return window.innerWidth;') <= 390,
          'the narrow window')
    for url in ('/', joint_url('press_line', 'joint_2'), '/alarms'):
        browser.get(server + url)
        assert browser.execute_script('return document.documentElement.scrollWidth;') <= 390, url
        logout = browser.find_element(_by('CSS_SELECTOR'), 'form.logout button')
        box = browser.execute_script('return arguments[0].getBoundingClientRect().toJSON();',
                                     logout)
        assert logout.is_displayed() and 0 <= box['left'] and box['right'] <= 390, (url, box)
    browser.get(server + '/')
    cards = browser.execute_script(
        "return Array.from(document.querySelectorAll('#fleet-rows tr')).map((tr) =>"
        ' getComputedStyle(tr).display);')
    assert cards == ['block'] * len(ORDER)  # a card per joint


def _latched(history: str) -> bool:
    with open_history(history, init=False) as stored:
        return stored.restore(joint='joint_2', robot='press_line').alarm_active


def test_a_reset_waits_for_its_confirmation_without_javascript(
        server, browser_without_javascript, history):
    browser = browser_without_javascript
    _log_in(browser, server, 'mia')
    browser.get(server + joint_url('press_line', 'joint_2'))
    # the page's own scripts are off: the chart stays empty
    assert not browser.find_elements(_by('CSS_SELECTOR'), '#wear-chart .plot-container')
    reason = browser.find_element(_by('ID'), 'reset-reason')
    reason.send_keys('gearbox replaced')
    browser.find_element(_by('ID'), 'reset-button').click()
    # the browser keeps the form while the confirmation box is not ticked: nothing was sent
    # (a sent form comes back as a new page, its reason empty)
    assert reason.get_attribute('value') == 'gearbox replaced' and _latched(history)
    assert not browser.find_elements(_by('ID'), 'flash')
    browser.find_element(_by('ID'), 'reset-confirm').click()
    browser.find_element(_by('ID'), 'reset-button').click()
    _wait(browser, lambda d: 'alarm reset' in d.find_element(_by('ID'), 'flash').text,
          'the reset')
    assert not _latched(history)


def test_an_acknowledgement_is_edited_then_withdrawn(server, browser, history):
    _log_in(browser, server, 'mia')
    browser.get(server + joint_url('press_line', 'joint_2'))
    browser.find_element(_by('ID'), 'ack-owner').send_keys('Team B')
    browser.find_element(_by('ID'), 'ack-comment').send_keys('gearbox ordered')
    browser.find_element(_by('ID'), 'ack-work-order').send_keys('WO-4711')
    _submit(browser, 'acknowledge-button', 'alarm acknowledged', 'the acknowledgement')
    # the edit form holds the acknowledgement's values
    owner = browser.find_element(_by('ID'), 'edit-owner')
    assert owner.get_attribute('value') == 'Team B'
    order = browser.find_element(_by('ID'), 'edit-work-order')
    assert order.get_attribute('value') == 'WO-4711'
    owner.clear()
    owner.send_keys('Team C')
    order.clear()
    order.send_keys('WO-4712')
    _submit(browser, 'edit-acknowledgement-button', 'acknowledgement edited', 'the edit')
    assert browser.find_element(_by('ID'), 'ack-shown-owner').text == 'Team C'
    assert browser.find_element(_by('ID'), 'ack-shown-work-order').text == 'WO-4712'
    cells = _newest_event(browser, 'acknowledgement_edited')
    assert cells[3:7] == ['mia', 'Team C', '', 'WO-4712']
    browser.find_element(_by('ID'), 'withdraw-reason').send_keys('the order was cancelled')
    _submit(browser, 'withdraw-acknowledgement-button', 'withdrawn', 'the withdrawal')
    assert browser.find_elements(_by('ID'), 'acknowledge-form')
    assert not browser.find_elements(_by('ID'), 'edit-acknowledgement-form')
    browser.get(server + '/')
    first = browser.find_element(_by('CSS_SELECTOR'), '#fleet-rows tr')
    assert first.find_element(_by('CSS_SELECTOR'), '.c-state').text == 'alarm'
    with open_history(history, init=False) as stored:
        log = stored.alarm_log(robot='press_line', joint='joint_2')
    assert [(e.event, e.user, e.owner, e.work_order) for e in log[:3]] == [
        ('acknowledgement_withdrawn', 'mia', 'Team C', 'WO-4712'),
        ('acknowledgement_edited', 'mia', 'Team C', 'WO-4712'),
        ('acknowledged', 'mia', 'Team B', 'WO-4711')]


def test_an_admin_manages_users_from_the_page_and_a_maintainer_may_not(
        server, browser, history):
    with open_history(history) as stored:
        stored.add_user(name='ada', role='admin', password='admin-pass-333')
    browser.get(server + '/login')
    browser.find_element(_by('ID'), 'username').send_keys('ada')
    browser.find_element(_by('ID'), 'password').send_keys('admin-pass-333')
    browser.find_element(_by('ID'), 'login-button').click()
    _wait(browser, lambda d: d.find_elements(_by('ID'), 'fleet-rows'), 'the fleet page')
    browser.find_element(_by('CSS_SELECTOR'), 'a[href="/users"]').click()
    _wait(browser, lambda d: d.find_elements(_by('ID'), 'add-user-form'), 'the users page')
    browser.find_element(_by('ID'), 'new-name').send_keys('neo')
    from selenium.webdriver.support.select import Select
    Select(browser.find_element(_by('ID'), 'new-role')).select_by_value('maintainer')
    browser.find_element(_by('ID'), 'new-password').send_keys('neo-pass-4444')
    browser.find_element(_by('ID'), 'add-user-button').click()
    row = _wait(browser, lambda d: d.find_elements(_by('CSS_SELECTOR'),
                                                   '#users tr[data-user="neo"]'), 'neo')[0]
    assert row.find_element(_by('CSS_SELECTOR'), '.c-role').text == 'maintainer'
    # the viewer vic made a maintainer from the page
    vic = browser.find_element(_by('CSS_SELECTOR'), '#users tr[data-user="vic"]')
    Select(vic.find_element(_by('CSS_SELECTOR'), 'select[name="role"]')).select_by_value(
        'maintainer')
    vic.find_element(_by('XPATH'), ".//button[text()='Change']").click()
    _wait(browser, lambda d: d.find_element(
        _by('CSS_SELECTOR'), '#users tr[data-user="vic"] .c-role').text == 'maintainer',
        'the role change')
    with open_history(history, init=False) as stored:
        roles = {u.name: u.role for u in stored.users()}
    assert roles['neo'] == 'maintainer' and roles['vic'] == 'maintainer'
    # a maintainer sees no Users page and is refused it by the server
    browser.delete_all_cookies()
    _log_in(browser, server, 'mia')
    assert not browser.find_elements(_by('CSS_SELECTOR'), 'a[href="/users"]')
    browser.get(server + '/users')
    assert 'only an admin may manage the users' in browser.page_source
    assert not browser.find_elements(_by('ID'), 'add-user-form')


def test_a_note_in_a_chart_is_text_not_markup(server, browser, history):
    # Plotly reads <b>, <a href> and <span style> in hover texts: the page escapes them
    note = '<b style="font-size:40px">big</b> <a href="http://example.invalid/">go</a> & co'
    with open_history(history) as stored:
        stored.acknowledge_alarm(joint='joint_2', robot='press_line', user='mia',
                                 owner='Team B', comment=note)
    _log_in(browser, server, 'vic')
    browser.get(server + joint_url('press_line', 'joint_2'))
    _wear_trace(browser)
    hovers = browser.execute_script(
        "const gd = document.getElementById('wear-chart');"
        'return gd.layout.annotations.map((a) => a.hovertext);')
    acknowledged = [h for h in hovers if 'acknowledged' in h]
    assert len(acknowledged) == 1
    assert '&lt;b style="font-size:40px"&gt;big&lt;/b&gt;' in acknowledged[0]
    assert '&lt;a href=' in acknowledged[0] and '&amp; co' in acknowledged[0]
    assert '<b' not in acknowledged[0] and '<a' not in acknowledged[0]
    # nothing of the note became a link or bold text in the chart
    assert not browser.execute_script(
        "return document.querySelector('#wear-chart a[href*=\"example.invalid\"]');")


LONG_NOTE = ('gearbox ordered from the supplier, the replacement needs the line stopped for a '
             'whole shift, so it waits for the planned stop; meanwhile the joint runs at '
             'reduced speed and the operators check its noise every morning ' * 2).strip()


def test_no_sideways_scroll_after_a_reset_a_long_acknowledgement_and_a_re_escalation(
        server, browser, history):
    """Issue 44: at 1366x900 and at 390x844 no page is wider than the window."""
    with open_history(history, init=False) as stored:
        stored.reset_alarm(joint='joint_3', robot='welder_7', user='mia',
                           reason='gearbox replaced preventively during the planned stop of '
                                  'line 3, serial GB-2026-11-000417-REPLACEMENT-UNIT',
                           work_order='WO-2026-0001234567')
        stored.acknowledge_alarm(joint='joint_2', robot='press_line', user='mia',
                                 owner='Maintenance team D (night shift, line 3)',
                                 comment=LONG_NOTE, planned_maintenance='2020-01-01',
                                 work_order='WO-2026-0009876543')
    _log_in(browser, server, 'mia')
    for width, height in ((1366, 900), (390, 844)):
        browser.set_window_size(width, height)
        _wait(browser, lambda d: d.execute_script('return window.innerWidth;') <= width,
              f'a window {width} px wide')
        for url in ('/', joint_url('press_line', 'joint_2'), joint_url('welder_7', 'joint_3'),
                    '/alarms'):
            browser.get(server + url)
            inner = browser.execute_script('return window.innerWidth;')
            scroll = browser.execute_script('return document.documentElement.scrollWidth;')
            assert scroll <= inner, (width, url, scroll)
        browser.get(server + '/')
        states = {(tr.get_attribute('data-robot'), tr.get_attribute('data-joint')):
                  tr.find_element(_by('CSS_SELECTOR'), '.c-state').text
                  for tr in browser.find_elements(_by('CSS_SELECTOR'), '#fleet-rows tr')}
        # the re-escalated acknowledged alarm is an alarm; the reset joint a new life
        assert states[('press_line', 'joint_2')] == 'alarm'
        assert states[('welder_7', 'joint_3')] == 'new life'
        count = browser.find_element(_by('CSS_SELECTOR'), '.count[data-state="alarm"]').text
        assert count == '1'
