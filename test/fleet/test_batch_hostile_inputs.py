"""
A manifest and bag folders other people made: bounded reading, names checked where they enter.

A manifest that is a link to ``/dev/zero`` is refused as it is read (exit 2, quickly, with
little memory), invalid UTF-8 and a field over the csv limit are exit 2 naming the file and
line, robot names follow ``--robot``'s rule, and a bag folder named with an escape sequence
and a newline cannot forge a line of the batch's output.
"""

import subprocess
import sys
import time

import pytest
from robot_wear_monitor.cli import main
from wear_testing.paths import console_script


def _run(*args, timeout=60):
    return subprocess.run([console_script('robot-wear-monitor'), *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, check=False)


def test_a_manifest_linked_to_dev_zero_is_refused_quickly_with_little_memory(tmp_path):
    manifest = tmp_path / 'manifest.csv'
    manifest.symlink_to('/dev/zero')
    # the peak resident size of this process image (VmHWM; ru_maxrss would include the
    # parent's size at the fork, the whole test session's)
    code = ('import sys\n'
            'from robot_wear_monitor.cli import main\n'
            'code = main(sys.argv[1:])\n'
            'status = open("/proc/self/status").read().split("VmHWM:")[1]\n'
            'print(int(status.split()[0]) // 1024)\n'
            'sys.exit(code)\n')
    started = time.monotonic()
    result = subprocess.run([sys.executable, '-c', code, 'replay', '--manifest', str(manifest),
                             '--history', str(tmp_path / 'h.sqlite3')],
                            capture_output=True, text=True, timeout=60, check=False)
    elapsed_s = time.monotonic() - started
    assert result.returncode == 2, result.stderr
    assert 'not a regular file' in result.stderr and 'Traceback' not in result.stderr
    peak_mb = int(result.stdout.strip().splitlines()[-1])
    assert peak_mb < 300, peak_mb
    assert elapsed_s < 30, elapsed_s  # refused as it is read, not after gigabytes


@pytest.mark.parametrize('content, expected', [
    (b'robot,bag\nr1,a\nr\xff2,b\n', 'line 3: the manifest is not UTF-8 text'),
    (b'robot,bag\nr1,' + b'x' * 200_000 + b'\n', 'line 2: field larger than field limit'),
    (b'robot,bag\nr\x1b[31m1,a\n', 'line 2: a robot name is 1-128 printable characters'),
    (b'robot,bag\n' + b'r' * 129 + b',a\n', 'line 2: a robot name is 1-128 printable'),
])
def test_a_bad_manifest_is_exit_2_naming_the_line(tmp_path, capsys, content, expected):
    manifest = tmp_path / 'manifest.csv'
    manifest.write_bytes(content)
    capsys.readouterr()
    assert main(['replay', '--manifest', str(manifest), '--history',
                 str(tmp_path / 'h.sqlite3')]) == 2
    err = capsys.readouterr().err
    assert expected in err and str(manifest) in err, err
    assert '\x1b' not in err


def test_a_manifest_over_its_limit_is_refused_as_it_is_read(tmp_path, capsys, monkeypatch):
    from robot_wear_monitor.fleet import batch
    monkeypatch.setattr(batch, 'MAX_MANIFEST_BYTES', 1000)
    manifest = tmp_path / 'manifest.csv'
    manifest.write_text('robot,bag\n' + 'r1,a\n' * 400, encoding='utf-8')
    capsys.readouterr()
    assert main(['replay', '--manifest', str(manifest), '--history',
                 str(tmp_path / 'h.sqlite3')]) == 2
    assert 'more than the limit of 1000 bytes' in capsys.readouterr().err


def test_a_hostile_bag_folder_name_cannot_forge_a_line(tmp_path):
    folder = tmp_path / 'bags'
    hostile = folder / 'x\x1b[2K\rfailed: 0\nforged'
    hostile.mkdir(parents=True)
    (hostile / 'metadata.yaml').write_text('not: [a bag', encoding='utf-8')
    result = _run('replay', folder, '--history', tmp_path / 'h.sqlite3', '--no-progress')
    assert result.returncode == 2
    output = result.stdout + result.stderr
    assert '\x1b' not in output and '\r' not in output
    assert not [line for line in output.splitlines() if line.startswith('forged')], output
    failed = [line for line in output.splitlines() if line.startswith('failed: ')]
    assert len(failed) == 1 and '\\x1b' in failed[0] and '\\n' in failed[0], output
