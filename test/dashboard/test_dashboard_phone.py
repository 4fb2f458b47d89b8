"""
The logs, the users and the charts on a phone (390x844) and on a laptop (1366x900), in Chromium.

Issue 44, build item 5: the alarm log, a joint's log and the users page are tables on a wide
screen and a card per row on a narrow one (the same HTML; dashboard.css's phone layout, up to
760 px), no page and no table box scrolls sideways, and the joint page's chart titles stand
clear of Plotly's mode bar, the axis titles and the legends.  The server, the history and the
browser are those of :mod:`test_dashboard_browser` (fleet_history.py's fleet), after a week's
events: a long acknowledgement whose planned date has passed (re-escalated), then a reset.
"""

import time

import pytest
from robot_wear_monitor.dashboard.pages import joint_url
from robot_wear_monitor.history import open_history
import test_dashboard_browser as browser_tests

# the shared fixtures (a module-level name is what pytest looks fixtures up by)
history = browser_tests.history
server = browser_tests.server
browser = browser_tests.browser
_by = browser_tests._by
_wait = browser_tests._wait

SIZES = ((1366, 900), (390, 844))
#: An admin and a user whose name is one long token (an e-mail address, 58 characters).
ADMIN = ('ada', 'admin-pass-333')
LONG_USER = 'maintenance.planner.line3.nightshift@plant-example.invalid'
WORK_ORDER = 'WO-2026-0009876543-LINE3-GEARBOX-REPLACEMENT-NIGHT-SHIFT'
RESET_REASON = ('gearbox replaced during the planned stop of line 3, serial '
                'GB-2026-11-000417-REPLACEMENT-UNIT, old unit sent back for inspection')


def _a_week(history: str, base: str, driver) -> None:
    """
    Live a week of press_line/joint_2: acknowledged (long note, passed date), re-escalated, reset.

    The re-escalation is logged by whoever sees it first: here the fleet page, opened by the
    admin (who stays logged in); then the joint is reset with a long reason.
    """
    with open_history(history) as stored:
        stored.add_user(name=ADMIN[0], role='admin', password=ADMIN[1])
        stored.add_user(name=LONG_USER, role='maintainer', password='long-pass-4444')
        stored.acknowledge_alarm(joint='joint_2', robot='press_line', user='mia',
                                 owner='Maintenance team D (night shift, line 3)',
                                 comment=browser_tests.LONG_NOTE,
                                 planned_maintenance='2020-01-01', work_order=WORK_ORDER)
    driver.get(base + '/login')
    driver.find_element(_by('ID'), 'username').send_keys(ADMIN[0])
    driver.find_element(_by('ID'), 'password').send_keys(ADMIN[1])
    driver.find_element(_by('ID'), 'login-button').click()
    _wait(driver, lambda d: d.find_elements(_by('ID'), 'fleet-rows'), 'the fleet page')

    def logged(_):
        with open_history(history, init=False) as stored:
            return 'reescalated' in [e.event for e in stored.events(joint='joint_2',
                                                                    robot='press_line')]
    _wait(driver, logged, 'the re-escalation in the alarm log')
    with open_history(history) as stored:
        stored.reset_alarm(joint='joint_2', robot='press_line', user='mia',
                           reason=RESET_REASON, work_order='WO-2026-0001234567')


def _resize(driver, width: int, height: int) -> None:
    driver.set_window_size(width, height)
    _wait(driver, lambda d: d.execute_script('return window.innerWidth;') <= width,
          f'a window {width} px wide')


#: What a page measures of itself: its scroll width against its viewport (without the
#: scroll bar), each .scroll box's, and per row of its table the row's display and box, its
#: cells' labels (the ::before content), displays and boxes.
MEASURE = """
const table = document.querySelector(arguments[0]);
const box = (n) => { const r = n.getBoundingClientRect(); return [r.left, r.right, r.height]; };
return {
  scroll: document.scrollingElement.scrollWidth,
  viewport: document.documentElement.clientWidth,
  boxes: Array.from(document.querySelectorAll('.scroll')).map((n) =>
    [n.scrollWidth, n.clientWidth]),
  head: getComputedStyle(table.tHead).display,
  rows: Array.from(table.tBodies[0].rows).map((tr) => ({
    event: tr.className, display: getComputedStyle(tr).display, box: box(tr),
    cells: Array.from(tr.cells).map((td) => ({cls: td.className, label: td.dataset.label,
      before: getComputedStyle(td, '::before').content, display: getComputedStyle(td).display,
      box: box(td), text: td.textContent}))})),
};
"""


def _measure(driver, base: str, url: str, table: str, ready) -> dict:
    driver.get(base + url)
    _wait(driver, ready, url)
    return driver.execute_script(MEASURE, table)


def _joint_log_drawn(driver) -> bool:
    return driver.execute_script(
        "const gd = document.getElementById('wear-chart'); return !!(gd && gd.data);")


def _check_table(page: dict, width: int, what: str) -> None:
    """Check a table at 1366 px, a card per row at 390 px: inside the viewport, label: value."""
    assert page['scroll'] <= page['viewport'], (what, page['scroll'], page['viewport'])
    for inner, outer in page['boxes']:  # no table wider than its box (no sideways box)
        assert inner <= outer, (what, inner, outer)
    assert page['rows'], what
    for row in page['rows']:
        left, right, _ = row['box']
        assert 0 <= left and right <= page['viewport'], (what, row['box'])
        labelled = [c for c in row['cells'] if c['label']]
        assert len(labelled) == len(row['cells']), (what, row['cells'])
        if width > 760:
            assert row['display'] == 'table-row' and page['head'] != 'none', what
            assert all(c['before'] == 'none' for c in row['cells']), what
            continue
        # a card: the row a block as wide as the table, no header; the cells shown carry
        # their label (the name, the time, where and what: the card's first line, unlabelled)
        assert row['display'] == 'block' and page['head'] == 'none', what
        assert right - left >= 0.9 * (page['viewport'] - 2 * left), (what, row['box'])
        shown = [c for c in row['cells'] if c['display'] != 'none']
        assert all(c['text'].strip() for c in shown), (what, shown)  # empty cells left out
        first_line = ('c-time', 'c-robot', 'c-joint', 'c-event', 'c-name', 'c-role')
        for cell in shown:
            if cell['cls'].split()[0] in first_line and cell['cls'] != 'c-time c-planned':
                assert cell['before'] == 'none', (what, cell)
            else:
                assert cell['before'] == f'"{cell["label"]}"', (what, cell)
        # a card of short values: about a line (or a form control) per labelled cell, one
        # for the first line (the rows in their sideways box were about 340 px tall)
        if max(len(c['text']) for c in shown) < 80:
            labelled = sum(c['before'] != 'none' for c in shown)
            assert row['box'][2] <= 44 * (labelled + 1) + 20, (what, row['event'], row['box'])


def test_logs_and_users_are_tables_at_1366_and_cards_on_a_phone(server, browser, history):
    _a_week(history, server, browser)
    joint = joint_url('press_line', 'joint_2')
    for width, height in SIZES:
        _resize(browser, width, height)
        alarms = _measure(browser, server, '/alarms', '#alarm-log',
                          lambda d: d.find_elements(_by('ID'), 'alarm-log'))
        _check_table(alarms, width, f'the alarm log at {width}')
        log = _measure(browser, server, joint, '#joint-events', _joint_log_drawn)
        _check_table(log, width, f"the joint's log at {width}")
        assert [r['event'] for r in log['rows']] == [
            'event-reset', 'event-reescalated', 'event-acknowledged', 'event-raised']
        users = _measure(browser, server, '/users', '#users',
                         lambda d: d.find_elements(_by('ID'), 'add-user-form'))
        _check_table(users, width, f'the users at {width}')
        names = [c['text'] for r in users['rows'] for c in r['cells'] if c['cls'] == 'c-name']
        assert LONG_USER in names
        # the long note wraps inside its cell and the cell inside its row
        note = next(c for c in log['rows'][2]['cells'] if c['cls'] == 'c-note')
        assert browser_tests.LONG_NOTE in note['text']
        row_left, row_right, _ = log['rows'][2]['box']
        assert row_left <= note['box'][0] and note['box'][1] <= row_right + 0.5
        if width < 760:  # on a phone the note takes the card's width, under its label
            assert note['box'][1] - note['box'][0] >= 0.85 * (row_right - row_left), note
            assert note['display'] == 'block'


def test_the_joint_log_drawn_again_by_the_page_is_the_same_cards(server, browser, history):
    """The page's script redraws its log on news: the same classes and labels as the server."""
    _a_week(history, server, browser)
    _resize(browser, 390, 844)
    joint = joint_url('press_line', 'joint_2')
    served = _measure(browser, server, joint, '#joint-events', _joint_log_drawn)
    browser.execute_script(  # as on news: the log one event shorter, rows made by the script
        'window.notReloaded = true; showEvents(pageData().data.events.slice(1));')
    drawn = browser.execute_script(MEASURE, '#joint-events')
    assert browser.execute_script('return window.notReloaded === true;')
    assert len(drawn['rows']) == len(served['rows']) - 1 == 3

    def shape(row):
        return [(c['cls'], c['label'], c['before'], c['display']) for c in row['cells']]
    assert [shape(r) for r in drawn['rows']] == [shape(r) for r in served['rows'][1:]]
    _check_table(drawn, 390, "the joint's log drawn by the script")


#: Each chart's boxes: its title (the page's h3), its mode bar (when drawn and shown), its
#: legend, its x axis title and tick labels, its plot area (from Plotly's layout size).
CHART_BOXES = """
const box = (n) => { if (!n) { return null; } const r = n.getBoundingClientRect();
  return r.width > 0 && r.height > 0 ? [r.left, r.top, r.right, r.bottom] : null; };
const shown = (n) => n && getComputedStyle(n).display !== 'none'
  && getComputedStyle(n).visibility !== 'hidden' ? n : null;
return ['wear-chart', 'temperature-chart', 'friction-chart'].map((id) => {
  const gd = document.getElementById(id);
  const size = gd._fullLayout._size;
  const r = gd.getBoundingClientRect();
  return {id: id, chart: box(gd), title: box(document.getElementById(id + '-title')),
    modebar: box(shown(gd.querySelector('.modebar'))),
    seen: gd.querySelector('.modebar') ? getComputedStyle(gd.querySelector('.modebar')).opacity
      : null,
    legend: box(gd.querySelector('.legend')), xtitle: box(gd.querySelector('.xtitle')),
    ticks: Array.from(gd.querySelectorAll('.xtick text')).map(box).filter((b) => b),
    plot: [r.left + size.l, r.top + size.t, r.left + size.l + size.w, r.top + size.t + size.h],
    config: gd._context.displayModeBar};
});
"""


def _overlap(a, b) -> bool:
    """Whether boxes [left, top, right, bottom] overlap (a shared edge is no overlap)."""
    return a[0] < b[2] - 0.5 and b[0] < a[2] - 0.5 and a[1] < b[3] - 0.5 and b[1] < a[3] - 0.5


def _charts_drawn(driver) -> bool:
    return driver.execute_script(
        "return ['wear-chart', 'temperature-chart', 'friction-chart'].every((id) =>"
        " document.getElementById(id).querySelector('.xtitle'));")


def _check_charts(driver, width: int, what: str) -> None:
    """Check each chart: its title clear of the mode bar, its legend of its axis, in its box."""
    time.sleep(0.5)  # a responsive redraw after the load or the resize settles
    # hovering shows the mode bar where it is shown (on a laptop: over the chart's top)
    from selenium.webdriver.common.action_chains import ActionChains
    ActionChains(driver).move_to_element(driver.find_element(_by('ID'), 'wear-chart')).perform()
    viewport = driver.execute_script('return document.documentElement.clientWidth;')
    for chart in driver.execute_script(CHART_BOXES):
        where = (what, width, chart['id'])
        assert chart['title'] and chart['xtitle'] and chart['ticks'], chart
        # a legend where there is more than one trace (T-hat's chart has one: none)
        assert (chart['legend'] is not None) == (chart['id'] != 'temperature-chart'), chart
        left, top, right, bottom = chart['chart']
        assert right <= viewport, where
        # the title above the chart, the legend and the axis title inside it
        assert chart['title'][3] <= top + 0.5, where
        for part in ('legend', 'xtitle'):
            box = chart[part] or chart['xtitle']
            assert left - 0.5 <= box[0] and box[2] <= right + 0.5, (where, part, box)
            assert top - 0.5 <= box[1] and box[3] <= bottom + 0.5, (where, part, box)
        for other in [chart['xtitle'], chart['plot'], *chart['ticks']] * bool(chart['legend']):
            assert not _overlap(chart['legend'], other), (where, chart['legend'], other)
        if width <= 760:  # no mode bar on a phone: zoom and pan by touch
            assert chart['config'] is False and chart['modebar'] is None, where
        else:  # above the plot area, beside nothing the page wrote
            assert chart['config'] is not False and chart['modebar'], (where, chart)
            assert chart['modebar'][3] <= chart['plot'][1] + 0.5, (where, chart)
        if chart['modebar']:
            assert not _overlap(chart['modebar'], chart['title']), where
    # the wear chart was hovered: on a laptop its mode bar is seen, on a phone there is none
    wear = driver.execute_script(CHART_BOXES)[0]
    assert (wear['modebar'] is not None and float(wear['seen']) > 0.5) == (width > 760), wear


@pytest.mark.parametrize('width,height', SIZES)
def test_the_charts_titles_stand_clear_of_the_mode_bar_and_the_legends(
        server, browser, history, width, height):
    _a_week(history, server, browser)
    _resize(browser, width, height)
    browser.get(server + joint_url('press_line', 'joint_2'))
    _wait(browser, _charts_drawn, 'the three charts')
    _check_charts(browser, width, 'loaded')


def test_the_charts_follow_a_window_narrowed_to_a_phone(server, browser, history):
    """Drawn at 1366 px, then the window made 390 px wide: redrawn for it without a reload."""
    _a_week(history, server, browser)
    _resize(browser, *SIZES[0])
    browser.get(server + joint_url('press_line', 'joint_2'))
    _wait(browser, _charts_drawn, 'the three charts')
    _check_charts(browser, SIZES[0][0], 'loaded')
    browser.execute_script('window.notReloaded = true;')
    _resize(browser, *SIZES[1])
    _wait(browser, lambda d: d.execute_script(
        "return document.getElementById('wear-chart')._context.displayModeBar === false;"),
        'the charts redrawn for a phone')
    _check_charts(browser, SIZES[1][0], 'narrowed')
    assert browser.execute_script('return window.notReloaded === true;')
