"""A missing input is named for what it is: a file, a bag, and what ``../shared`` is."""

import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.errors import no_such_path_text, SHARED_DATA_HINT

RAW_RUN = 'shared/data/external/kuka_iiwa_yezhao_drake/raw_runs/joint7_vel_p3.csv.gz'


def _error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1 and 'Traceback' not in error
    return error


@pytest.mark.parametrize('argv', [
    ['segment', 'levels.csv'],
    ['segment', 'run.csv.gz'],
    ['replay', 'levels.csv', '--out', 'out_bag'],
    ['replay', 'levels.csv', 'other.csv', '--history', 'h.sqlite3'],
    ['audit', 'levels.csv'],
])
def test_a_missing_csv_is_no_such_file_not_no_such_bag(capsys, tmp_path, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    error = _error(capsys, argv)
    assert f'{argv[1]}: no such file' in error
    assert 'bag' not in error.split('no such', 1)[1]
    assert not (tmp_path / 'h.sqlite3').exists()


def test_a_missing_bag_is_still_no_such_bag(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert 'recorded_bag: no such bag' in _error(capsys, ['segment', 'recorded_bag'])


@pytest.mark.parametrize('verb', ['segment', 'audit', 'replay'])
def test_a_path_in_a_missing_shared_folder_says_what_it_is(capsys, tmp_path, monkeypatch,
                                                           verb):
    work = tmp_path / 'main'
    work.mkdir()
    monkeypatch.chdir(work)
    argv = [verb, f'../{RAW_RUN}'] + (['--out', 'out_bag'] if verb == 'replay' else [])
    error = _error(capsys, argv)
    assert 'no such file' in error
    assert 'measured data kept beside the repository' in error
    assert 'simulate --out wear_bag' in error and 'examples/' in error


def test_a_shared_folder_that_exists_gets_no_hint(tmp_path, monkeypatch):
    (tmp_path / 'shared').mkdir()
    work = tmp_path / 'main'
    work.mkdir()
    monkeypatch.chdir(work)
    text = no_such_path_text(f'../{RAW_RUN}', what='bag')
    assert text == f'../{RAW_RUN}: no such file'
    assert SHARED_DATA_HINT not in text


def test_the_path_echoed_is_cut_and_escaped():
    text = no_such_path_text('x\n' * 300, what='bag')
    assert '\n' not in text and len(text) < 500 and text.endswith(': no such bag')
