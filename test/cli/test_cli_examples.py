"""``robot-wear-monitor examples``: the tour's example files copied into any folder."""

import subprocess

from robot_wear_monitor.cli.examples import copy_examples, packaged_examples
from wear_testing.paths import console_script, REPO_ROOT


def _files(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob('*') if p.is_file()}


def test_examples_copies_the_packaged_files_into_an_empty_folder_as_they_are(tmp_path):
    done = subprocess.run([console_script('robot-wear-monitor'), 'examples'], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    copied = _files(tmp_path / 'examples')
    assert copied == _files(REPO_ROOT / 'examples')  # byte for byte, arm_runs/ included
    assert {'baseline.csv', 'wear_test.csv', 'truth.yaml', 'arm_runs/run_11.csv'} <= set(copied)
    assert done.stdout.startswith(f'robot-wear-monitor examples: {len(copied)} files into '
                                  'examples/ (arm_runs, baseline.csv, truth.yaml, wear_test.csv)')
    assert not [p for p in tmp_path.iterdir() if p.name != 'examples']  # no staging left
    # a second copy refuses to touch the folder: one line, exit 2, nothing changed
    (tmp_path / 'examples' / 'baseline.csv').write_text('mine')
    again = subprocess.run([console_script('robot-wear-monitor'), 'examples'], cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
    assert again.returncode == 2
    assert again.stderr == ('robot-wear-monitor examples: error: examples: the folder exists '
                            'and is not empty (name a new one)\n')
    assert (tmp_path / 'examples' / 'baseline.csv').read_text() == 'mine'


def test_an_empty_folder_is_filled_and_a_file_is_refused(tmp_path):
    (tmp_path / 'empty').mkdir()
    files = copy_examples(dest=tmp_path / 'empty')
    assert len(files) == len(_files(packaged_examples())) >= 20
    (tmp_path / 'a_file').write_text('x')
    done = subprocess.run([console_script('robot-wear-monitor'), 'examples', 'a_file'],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and 'is a file, not a folder' in done.stderr, done.stderr
    assert (tmp_path / 'a_file').read_text() == 'x'
