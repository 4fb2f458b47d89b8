"""
Every input file read with bounds as it is read, and names from recordings escaped in text.

A level table, a raw run (plain or ``.csv.gz``), a notification configuration and its password
file that are links to ``/dev/zero`` are refused at once (exit 2, small memory); invalid UTF-8
and a 200 kB field are exit 2 naming the file and the line; a gzip bomb stops at the limit of
decompressed text; a joint name with an escape sequence and a newline reaches no terminal raw.
"""

from __future__ import annotations

import csv
import gzip
import json
import os
from pathlib import Path
import subprocess
import sys
import time
import zlib

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.input_files import csv_file_rows, MAX_RAW_RUN_BYTES, TextLines
from robot_wear_monitor.recordings import tables
from robot_wear_monitor.recordings.tables import read_raw_csv, RecordingError
import yaml

ROOT = Path(__file__).resolve().parents[1]
RAW_HEADER = 't_s,q_rad,dq_rad_s,tau_measured_Nm\n'
HOSTILE_JOINT = 'j\x1b[31m\nFORGED'

# the child's own peak resident size (VmHWM; ru_maxrss would count the parent's at the fork)
_MEASURED = ('import sys\n'
             'from robot_wear_monitor.cli import main\n'
             'code = main(sys.argv[1:])\n'
             'status = open("/proc/self/status").read().split("VmHWM:")[1]\n'
             'print(int(status.split()[0]) // 1024)\n'
             'sys.exit(code)\n')


def _measured(*argv, timeout=120):
    """Return (exit code, stderr, peak MB, seconds) of the CLI in a child process."""
    started = time.monotonic()
    done = subprocess.run([sys.executable, '-c', _MEASURED, *map(str, argv)],
                          capture_output=True, text=True, timeout=timeout, check=False,
                          env={**os.environ, 'PYTHONPATH': os.pathsep.join(
                              [str(ROOT), str(ROOT / 'test'), os.environ.get('PYTHONPATH', '')])})
    elapsed_s = time.monotonic() - started
    peak_mb = int(done.stdout.strip().splitlines()[-1]) if done.stdout.strip() else -1
    return done.returncode, done.stderr, peak_mb, elapsed_s


def _notify_config(tmp_path, **email):
    path = tmp_path / 'notifications.yaml'
    path.write_text(yaml.safe_dump({'email': {
        'host': '127.0.0.1', 'port': 2525, 'starttls': False, 'from': 'wear@example.local',
        'to': 'maintenance@example.local', **email}}))
    return path


# ----------------------------------------------------------------------------- /dev/zero

@pytest.mark.parametrize('kind', ['level table', 'raw run', 'raw run gz', 'notification config',
                                  'password file'])
def test_an_input_linked_to_dev_zero_is_refused_at_once_with_little_memory(tmp_path, kind):
    zero = '/dev/zero'
    history = tmp_path / 'h.sqlite3'
    if kind == 'level table':
        (tmp_path / 'levels.csv').symlink_to(zero)
        argv = ['audit', tmp_path / 'levels.csv']
    elif kind == 'raw run':
        (tmp_path / 'run.csv').symlink_to(zero)
        argv = ['segment', tmp_path / 'run.csv']
    elif kind == 'raw run gz':
        (tmp_path / 'run.csv.gz').symlink_to(zero)
        argv = ['audit', tmp_path / 'run.csv.gz']
    elif kind == 'notification config':
        (tmp_path / 'notify.yaml').symlink_to(zero)
        argv = ['notify', '--history', history, '--config', tmp_path / 'notify.yaml', '--once']
    else:
        (tmp_path / 'password').symlink_to(zero)
        config = _notify_config(tmp_path, user='wear', password_file='password')
        argv = ['notify', '--history', history, '--config', config, '--once']
    code, err, peak_mb, elapsed_s = _measured(*argv)
    assert code == 2, err
    assert 'not a regular file' in err and 'Traceback' not in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert 0 < peak_mb < 300, peak_mb
    assert elapsed_s < 60, elapsed_s  # refused as it is opened, not after gigabytes


# ----------------------------------------------------------------------------- bad text

def _raw_run(rows=200):
    t = np.arange(rows) * 0.005
    return RAW_HEADER + ''.join(f'{x:.3f},{np.sin(x):.6f},{np.cos(x):.6f},0.1\n' for x in t)


_LEVELS = 'speed,friction,joint\n' + ''.join(f'{v},{0.1 + 0.001 * v},j1\n'
                                             for v in (2, 5, 9, 14, 20, 27, 35, 44))


def _bad_utf8(text: str, line: int) -> bytes:
    lines = text.encode().split(b'\n')
    lines[line - 1] = lines[line - 1][:2] + b'\xff' + lines[line - 1][2:]
    return b'\n'.join(lines)


def _long_field(text: str, line: int) -> bytes:
    lines = text.split('\n')
    lines[line - 1] = lines[line - 1] + '1' * 200_000
    return '\n'.join(lines).encode()


@pytest.mark.parametrize('verb, name, text', [
    ('audit', 'levels.csv', _LEVELS), ('audit', 'levels.csv.gz', _LEVELS),
    ('identify', 'levels.csv', _LEVELS),
    ('segment', 'run.csv', _raw_run()), ('segment', 'run.csv.gz', _raw_run()),
    ('audit', 'run.csv.gz', _raw_run()),
])
@pytest.mark.parametrize('spoil, expected', [
    (_bad_utf8, 'is not UTF-8 text'), (_long_field, 'has at most 65536 characters')])
def test_bad_text_in_a_table_is_exit_2_naming_the_file_and_line(tmp_path, capsys, verb, name,
                                                                text, spoil, expected):
    data = spoil(text, 5)
    path = tmp_path / name
    path.write_bytes(gzip.compress(data) if name.endswith('.gz') else data)
    argv = [verb, str(path)] + (['--out', str(tmp_path / 'p.yaml')] if verb == 'identify'
                                else [])
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f'{path}: line 5: ' in err and expected in err, err
    assert 'Traceback' not in err and len(err) < 1000


def test_a_row_that_is_not_numbers_names_its_line_and_is_cut_short(tmp_path):
    lines = _raw_run(30_000).split('\n')
    lines[25_000] = '1.0,' + 'x' * 50_000 + ',0,0'  # line 25001, past the first block
    path = tmp_path / 'run.csv'
    path.write_text('\n'.join(lines))
    with pytest.raises(RecordingError) as raised:
        read_raw_csv(path)
    message = str(raised.value)
    assert message.startswith(f'{path}: line 25001: not a numeric CSV row: '), message
    assert "could not convert string 'xxx" in message and len(message) < 400


def test_a_raw_run_read_in_blocks_equals_numpys_reading_of_the_whole_file(tmp_path):
    text = _raw_run(50_000)
    path = tmp_path / 'run.csv.gz'
    half = len(text) // 2  # two gzip members, as `cat a.gz b.gz` makes
    path.write_bytes(gzip.compress(text[:half].encode()) + gzip.compress(text[half:].encode()))
    columns = read_raw_csv(path)
    expected = np.loadtxt(text.splitlines()[1:], delimiter=',', ndmin=2)
    assert len(columns) == 4 and columns[0].size == 50_000
    for i, column in enumerate(columns):
        assert np.array_equal(column, expected[:, i])


def test_text_lines_name_the_line_of_a_bad_byte_far_into_the_file(tmp_path):
    path = tmp_path / 't.csv.gz'
    body = b''.join(b'%d,\xc3\xa9\n' % i for i in range(100_000))  # UTF-8 e-acute per line
    path.write_bytes(gzip.compress(body + b'x,\xc3\n'))  # a cut character on line 100001
    with pytest.raises(InputError, match=r't\.csv\.gz: line 100001: the table is not UTF-8'):
        list(TextLines(path, what='table', limit_bytes=10 << 20))


def test_a_cut_or_foreign_gzip_file_is_refused_naming_it(tmp_path):
    cut = tmp_path / 'cut.csv.gz'
    cut.write_bytes(gzip.compress(_LEVELS.encode())[:-6])
    with pytest.raises(InputError, match='cut.csv.gz: the level table is cut'):
        list(csv_file_rows(cut, what='level table', limit_bytes=1 << 20))
    plain = tmp_path / 'plain.csv.gz'
    plain.write_text(_LEVELS)
    with pytest.raises(InputError, match='plain.csv.gz: the level table is not gzip data'):
        list(csv_file_rows(plain, what='level table', limit_bytes=1 << 20))


# ----------------------------------------------------------------------------- gzip bombs

def _bomb(path: Path, header: str, decompressed_bytes: int) -> None:
    """Write a .csv.gz of ``header`` then blank lines, ``decompressed_bytes`` in all."""
    packer = zlib.compressobj(9, zlib.DEFLATED, 16 + zlib.MAX_WBITS)
    block = b'\n' * (1 << 20)
    with open(path, 'wb') as out:
        out.write(packer.compress(header.encode()))
        for _ in range(decompressed_bytes >> 20):
            out.write(packer.compress(block))
        out.write(packer.flush())


def test_a_gzip_bomb_raw_run_is_refused_while_it_is_read_with_little_memory(tmp_path):
    bomb = tmp_path / 'run.csv.gz'
    _bomb(bomb, RAW_HEADER, MAX_RAW_RUN_BYTES + (4 << 20))
    assert bomb.stat().st_size < MAX_RAW_RUN_BYTES // 100
    code, err, peak_mb, _ = _measured('segment', bomb)
    assert code == 2 and 'Traceback' not in err, err
    assert f'more than the limit of {MAX_RAW_RUN_BYTES} bytes decompressed' in err, err
    assert 0 < peak_mb < 300, peak_mb  # read as it decompresses: never the whole text


def test_a_gzip_bomb_level_table_stops_at_its_limit(tmp_path, capsys, monkeypatch):
    from robot_wear_monitor.audit import data
    monkeypatch.setattr(data, 'MAX_LEVEL_TABLE_BYTES', 1 << 20)
    bomb = tmp_path / 'levels.csv.gz'
    _bomb(bomb, 'speed,friction\n', 64 << 20)
    capsys.readouterr()
    assert main(['audit', str(bomb)]) == 2
    err = capsys.readouterr().err
    assert f'more than the limit of {1 << 20} bytes decompressed' in err, err


def test_too_many_rows_of_a_raw_run_are_refused_naming_the_line(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, 'MAX_RAW_RUN_SAMPLES', 1000)
    path = tmp_path / 'run.csv'
    path.write_text(_raw_run(5000))
    with pytest.raises(RecordingError, match=r'line \d+: more than the limit of 1000 samples'):
        read_raw_csv(path)


# ----------------------------------------------------------------------------- other files

def test_a_password_file_over_its_limit_or_not_text_is_refused_naming_it(tmp_path):
    from robot_wear_monitor.fleet.notify_config import (load_notification_config,
                                                        NotificationConfigError)
    (tmp_path / 'password').write_bytes(b'p' * 5000)
    config = _notify_config(tmp_path, user='wear', password_file='password')
    with pytest.raises(NotificationConfigError, match='more than the limit of 4096 bytes'):
        load_notification_config(config)
    (tmp_path / 'password').write_bytes(b'secret\xff\n')
    with pytest.raises(NotificationConfigError, match='line 1: the password file is not UTF-8'):
        load_notification_config(config)


def test_a_ca_file_linked_to_dev_zero_or_not_pem_is_refused(tmp_path):
    from robot_wear_monitor.fleet.notify_config import (load_notification_config,
                                                        NotificationConfigError)
    (tmp_path / 'ca.pem').symlink_to('/dev/zero')
    config = _notify_config(tmp_path, starttls=True, ca_file='ca.pem')
    with pytest.raises(NotificationConfigError, match='CA file is a device, pipe or socket'):
        load_notification_config(config)
    (tmp_path / 'ca.pem').unlink()
    (tmp_path / 'ca.pem').write_text('not a certificate\n')
    with pytest.raises(NotificationConfigError, match='not PEM certificates'):
        load_notification_config(config)


def test_the_dashboards_tls_files_are_read_bounded(tmp_path):
    from robot_wear_monitor.dashboard.server import check_listen
    (tmp_path / 'cert.pem').symlink_to('/dev/zero')
    (tmp_path / 'key.pem').write_text('key\n')
    with pytest.raises(InputError, match='the --tls-cert file is a device, pipe or socket'):
        check_listen(host='0.0.0.0', tls_cert=str(tmp_path / 'cert.pem'),
                     tls_key=str(tmp_path / 'key.pem'), insecure_http=False)


def test_a_bag_metadata_linked_to_dev_zero_gives_no_start_time(tmp_path):
    from robot_wear_monitor.fleet.batch import recording_start_ns
    bag = tmp_path / 'bag'
    bag.mkdir()
    (bag / 'metadata.yaml').symlink_to('/dev/zero')
    started = time.monotonic()
    assert recording_start_ns(bag) is None
    assert time.monotonic() - started < 10


# ----------------------------------------------------------------------------- names

@pytest.fixture(scope='module')
def hostile_bag(tmp_path_factory):
    from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                          DEFAULT_JOINT_NAMES, JointSimConfig,
                                                          simulate_scenario)
    from robot_wear_monitor.recordings.bags import write_joint_state_bag
    names = tuple(HOSTILE_JOINT if n == 'joint_2' else n for n in DEFAULT_JOINT_NAMES)
    config = accelerated_wear_scenario(n_experiments=3, seed=2, joint=JointSimConfig(
        joint=HOSTILE_JOINT, joint_names=names))
    scenario = simulate_scenario(config=config)
    bag = tmp_path_factory.mktemp('names') / 'bag'
    write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort)
    return bag


def _no_raw_control(output: str) -> None:
    # (a CSV's rows end in CR LF, which a terminal turns into CR CR LF: a lone CR would move
    # the cursor back over a line)
    lines = output.replace('\r\r\n', '\n').replace('\r\n', '\n')
    assert '\x1b' not in output and '\r' not in lines, output
    assert not [line for line in output.splitlines() if line.startswith('FORGED')], output


def _on_a_terminal(*argv) -> str:
    """Return what the CLI writes (stdout and stderr) to a terminal: a pseudo-terminal."""
    import pty
    main_fd, child_fd = pty.openpty()
    child = subprocess.Popen([sys.executable, '-m', 'robot_wear_monitor.cli', *map(str, argv)],
                             stdout=child_fd, stderr=child_fd, stdin=subprocess.DEVNULL,
                             env={**os.environ, 'PYTHONPATH': os.pathsep.join(
                                 [str(ROOT), str(ROOT / 'test'),
                                  os.environ.get('PYTHONPATH', '')])})
    os.close(child_fd)
    chunks = []
    while True:
        try:
            chunk = os.read(main_fd, 1 << 16)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(main_fd)
    assert child.wait(timeout=120) in (0, 2)
    return b''.join(chunks).decode('utf-8', 'replace')


def test_a_hostile_joint_name_from_a_recording_reaches_no_terminal_raw(tmp_path, capsys,
                                                                       hostile_bag):
    history = tmp_path / 'h.sqlite3'
    levels = tmp_path / 'levels.csv'
    runs = [['segment', str(hostile_bag), '--joint', HOSTILE_JOINT, '--out', str(levels)],
            ['segment', str(hostile_bag)],  # joint_2 is not there: the error lists the names
            ['replay', str(hostile_bag), '--joint', HOSTILE_JOINT, '--history', str(history),
             '--no-progress'],
            ['history', str(history)],
            ['fleet', '--history', str(history)]]
    outputs = []
    for argv in runs:
        capsys.readouterr()
        code = main(argv)
        out, err = capsys.readouterr()
        assert code in (0, 2), (argv, err)
        _no_raw_control(out + err)
        outputs.append(out + err)
    shown = 'j\\x1b[31m\\nFORGED'
    assert shown in outputs[0]  # the report line of the joint
    assert 'joints seen: ' in outputs[1] and shown in outputs[1]
    assert shown in outputs[3] and shown in outputs[4]  # the history and the fleet table
    # a CSV on a terminal escapes the name; in a file it is the text as recorded (quoted)
    for argv in (['segment', hostile_bag, '--joint', HOSTILE_JOINT],
                 ['fleet', '--history', history, '--csv'],
                 ['history', history, '--alarms', '--csv']):
        output = _on_a_terminal(*argv)
        _no_raw_control(output)
        assert shown in output, output
    with levels.open(newline='') as table:
        assert {row['joint'] for row in csv.DictReader(table)} == {HOSTILE_JOINT}


def test_hostile_names_in_a_level_table_reach_no_terminal_raw(tmp_path, capsys):
    rows = list(csv.reader((ROOT / 'examples' / 'baseline.csv').open()))
    table = tmp_path / 'levels.csv'
    with table.open('w', newline='') as out:
        writer = csv.writer(out)
        writer.writerow(rows[0] + ['joint', 'note\x1b[1m\nX'])
        for i, row in enumerate(rows[1:]):
            writer.writerow(row + [HOSTILE_JOINT if i % 2 else 'joint_1', 'p\x1b[2Kq'])
    shown = 'j\\x1b[31m\\nFORGED'
    for argv, expected in ((['audit', str(table)], shown),
                           (['audit', str(table), '--json'], json.dumps(shown)[1:-1])):
        capsys.readouterr()
        assert main(argv) == 0
        out, err = capsys.readouterr()
        _no_raw_control(out + err)
        assert expected in out  # the group is reported, escaped
