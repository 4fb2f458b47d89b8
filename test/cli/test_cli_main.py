"""The ``cli`` package: one module per verb, the entry points, one-line errors."""

import atexit
import gc
from pathlib import Path
import subprocess
import sys

from robot_wear_monitor import cli
from wear_testing.paths import REPO_ROOT

VERBS = ('design', 'plan', 'estimate', 'study', 'simulate', 'segment', 'replay', 'demo',
         'examples', 'audit', 'history', 'fleet', 'acknowledge', 'new-life', 'live', 'play',
         'call', 'identify', 'notify', 'dashboard')


def test_every_verb_is_a_module_with_help_add_arguments_and_main():
    assert tuple(sorted(cli.VERBS)) == tuple(sorted(VERBS))
    for name in cli.VERBS:
        module = cli.verb_module(name)
        assert module.__name__ == f'robot_wear_monitor.cli.{name.replace("-", "_")}'
        assert callable(module.add_arguments) and callable(module.main) and module.HELP


def test_no_module_of_the_cli_package_is_over_600_lines():
    folder = Path(cli.__file__).parent
    sizes = {p.name: len(p.read_text().splitlines()) for p in folder.glob('*.py')}
    modules = {f'{v.replace("-", "_")}.py' for v in VERBS}
    assert set(sizes) >= modules | {'options.py', '__main__.py'}
    assert max(sizes.values()) <= 600, sizes


def test_python_m_runs_the_command_line():
    run = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', '--help'],
                         cwd=REPO_ROOT, capture_output=True, text=True, timeout=60,
                         check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith('usage: robot-wear-monitor')
    for verb in VERBS:
        assert verb in run.stdout


def test_ros_args_are_only_for_live_play_and_call(capsys):
    try:
        cli.main(['design', '--n', '2', '--ros-args', '-p', 'x:=1'])
    except SystemExit as error:
        assert error.code == 2
    else:
        raise AssertionError('--ros-args accepted by design')
    assert '--ros-args is only for live, play and call, not design' in capsys.readouterr().err


def test_the_command_line_loads_numpy_after_setting_one_openblas_thread():
    # OpenBLAS starts (spinning) worker threads when it loads unless OPENBLAS_NUM_THREADS says
    # one: the command line must not import numpy before use_single_blas_thread sets it
    code = ('import os, sys\n'
            'os.environ.pop("OPENBLAS_NUM_THREADS", None)\n'
            'from robot_wear_monitor import cli\n'
            'assert "numpy" not in sys.modules, "numpy imported with the cli package"\n'
            'from robot_wear_monitor.blas_threads import use_single_blas_thread\n'
            'use_single_blas_thread()\n'
            'assert os.environ["OPENBLAS_NUM_THREADS"] == "1"\n')
    run = subprocess.run([sys.executable, '-c', code], cwd=REPO_ROOT, capture_output=True,
                         text=True, timeout=60, check=False)
    assert run.returncode == 0, run.stderr


def test_a_command_freezes_the_objects_at_exit_once(monkeypatch):
    hooks = []
    monkeypatch.setattr(atexit, 'register', hooks.append)
    monkeypatch.setattr(atexit, 'unregister', lambda f: hooks.remove(f) if f in hooks else None)
    assert cli.main(['design', '--n', '2']) == 0
    assert cli.main(['design', '--n', '2']) == 0
    assert hooks == [gc.freeze]


def test_a_command_leaves_the_collector_as_it_found_it():
    from robot_wear_monitor.cli.options import loading_modules
    assert gc.isenabled() and gc.get_freeze_count() == 0
    with loading_modules():
        assert not gc.isenabled()
        kept = [[]]
    assert gc.isenabled() and gc.get_freeze_count() > 0 and kept
    gc.unfreeze()
    gc.disable()
    try:
        with loading_modules():
            pass
        assert not gc.isenabled()  # paused before: still paused
    finally:
        gc.unfreeze()
        gc.enable()
    assert cli.main(['design', '--n', '2']) == 0
    assert gc.isenabled() and gc.get_freeze_count() == 0
