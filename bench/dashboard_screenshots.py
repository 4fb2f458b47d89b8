"""
The README's dashboard screenshots, from a simulated fleet, in a real headless Chromium.

    python3 bench/dashboard_screenshots.py [--out docs/figures] [--keep DIR] [--width PX]
                                           [--history DIR/history.sqlite3]

Simulates six robots whose joint 2 wears to 10 ... 60 over 30 hourly experiments (the README's
fleet commands; one robot's recording ends 12 hours ago, so it is stale), replays them into one
history (``replay --manifest``), acknowledges one alarm as a maintainer would, starts the
dashboard (uvicorn in a thread on 127.0.0.1) and takes ``dashboard_fleet.png`` (the fleet page)
and ``dashboard_joint.png`` (the joint page of the soonest forecast crossing) with
headless Chromium (``/usr/bin/chromium``, ``/usr/bin/chromedriver``), both at ``--width``
pixels (1366 by default: the most common laptop screen).  Retake them whenever a page changes.
"""

import argparse
from pathlib import Path
import socket
import subprocess
import sys
import tempfile
import threading
import time

REPO = Path(__file__).resolve().parents[1]
FLEET = (  # robot, final w, seed, hours between the recording's end and now
    ('press_line_1', 10, 1, 0), ('press_line_2', 25, 2, 0), ('welder_3', 30, 3, 0),
    ('welder_4', 45, 4, 0), ('palletiser_5', 60, 5, 0), ('palletiser_6', 20, 6, 12))
EXPERIMENTS = 30
PASSWORD = 'screenshot-pass-1'


def _cli(*args: str) -> None:
    subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', *args], check=True,
                   stdout=subprocess.DEVNULL, cwd=REPO)


def make_history(folder: Path) -> Path:
    """Simulate the fleet, replay it into ``folder/history.sqlite3``; return the history."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = ['robot,bag']
    now = int(time.time())
    for robot, wear, seed, ago_h in FLEET:
        bag = folder / f'bag_{robot}'
        start = now - (EXPERIMENTS + ago_h) * 3600
        _cli('simulate', '--out', str(bag), '--experiments', str(EXPERIMENTS), '--wear-final',
             str(wear), '--seed', str(seed), '--start-time', str(start), '--overwrite')
        lines.append(f'{robot},{bag.name}')
    (folder / 'manifest.csv').write_text('\n'.join(lines) + '\n')
    history = folder / 'history.sqlite3'
    _cli('replay', '--manifest', str(folder / 'manifest.csv'), '--history', str(history),
         '--workers', '2')
    from robot_wear_monitor.history import open_history
    with open_history(history) as stored:
        stored.add_user(name='maria', role='maintainer', password=PASSWORD)
        latched = [row for row in stored.fleet() if row.alarm]
        if len(latched) > 1:  # the second worst: acknowledged, maintenance planned
            row = latched[1]
            stored.acknowledge_alarm(joint=row.joint, robot=row.robot, user='maria',
                                     owner='maintenance team B', comment='gearbox ordered',
                                     planned_maintenance=time.strftime(
                                         '%Y-%m-%d', time.gmtime(time.time() + 5 * 86400)))
    return history


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return sock.getsockname()[1]


#: The width of the screenshots [px].
WIDTH = 1366


def take_screenshots(history: Path, out: Path, *, width: int = WIDTH) -> list[Path]:
    """Serve ``history``, log in with headless Chromium and save the two pages as PNG."""
    from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
    from robot_wear_monitor.dashboard.pages import joint_url
    from robot_wear_monitor.history import open_history
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
    import uvicorn

    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(create_app(DashboardSettings(history=str(history))),
                                           host='127.0.0.1', port=port, log_level='warning'))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)
    options = webdriver.ChromeOptions()
    options.binary_location = '/usr/bin/chromium'
    for argument in ('--headless=new', '--no-sandbox', '--disable-dev-shm-usage',
                     f'--window-size={width},900', '--hide-scrollbars',
                     '--force-device-scale-factor=1'):
        options.add_argument(argument)
    driver = webdriver.Chrome(service=Service('/usr/bin/chromedriver'), options=options)
    base = f'http://127.0.0.1:{port}'
    out.mkdir(parents=True, exist_ok=True)
    written = []
    try:
        driver.get(base + '/login')
        driver.find_element(By.ID, 'username').send_keys('maria')
        driver.find_element(By.ID, 'password').send_keys(PASSWORD)
        driver.find_element(By.ID, 'login-button').click()
        WebDriverWait(driver, 20).until(lambda d: d.find_elements(By.ID, 'fleet-rows'))
        driver.set_window_size(width, 1400)  # the whole page: every row of the fleet
        time.sleep(0.5)
        written.append(out / 'dashboard_fleet.png')
        driver.find_element(By.TAG_NAME, 'body').screenshot(str(written[-1]))
        with open_history(history, init=False) as stored:  # the soonest forecast crossing
            worst = next(r for r in stored.fleet() if not r.alarm
                         and 0 < r.crossing_experiments < float('inf'))
        driver.set_window_size(width, 1750)
        driver.get(base + joint_url(worst.robot, worst.joint))
        WebDriverWait(driver, 20).until(lambda d: d.execute_script(
            "return !!(document.getElementById('friction-chart').data);"))
        time.sleep(0.5)
        written.append(out / 'dashboard_joint.png')
        driver.save_screenshot(str(written[-1]))
    finally:
        driver.quit()
        server.should_exit = True
        thread.join(timeout=20)
    return written


def main() -> int:
    """Make the history and the screenshots."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--out', type=Path, default=REPO / 'docs' / 'figures')
    parser.add_argument('--keep', type=Path, help='keep the bags and the history here')
    parser.add_argument('--width', type=int, default=WIDTH, help=f'pixels (default {WIDTH})')
    parser.add_argument('--history', type=Path,
                        help='a history made before (--keep DIR: DIR/history.sqlite3) instead '
                             'of simulating the fleet again')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.keep or Path(scratch)
        started = time.monotonic()
        history = args.history or make_history(folder)
        print(f'fleet ready in {time.monotonic() - started:.0f} s: {history}')
        for path in take_screenshots(history, args.out, width=args.width):
            print(f'written {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
