"""
Recordings cut off by a crash: MCAP files without metadata.yaml, summary or footer.

The recording comes from the independent generator (``test/wear_testing/independent_robot.py``: its
own trajectory, noise and rosbags writer); the cut is made here by truncating the MCAP file at
several byte offsets and removing ``metadata.yaml``, which is what a killed ``ros2 bag record``
leaves behind.
"""

import json
import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest
from wear_testing import independent_robot as robot

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    recording = robot.generate_wear_test(n_experiments=8, wear_start=0.0, wear_end=60.0, seed=3)
    folder = tmp_path_factory.mktemp('unfinished')
    bag = robot.write_bag(folder / 'complete', recording)
    return recording, bag


def _replay(bag, out, summary, *extra):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(REPO_ROOT)] + [p for p in [os.environ.get('PYTHONPATH')] if p]))
    return subprocess.run(
        [sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bag), '--out', str(out),
         '--json-out', str(summary), '--no-progress', *extra],
        cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=120, check=False)


def _cut(bag, folder, fraction):
    """Copy the bag without metadata.yaml, its MCAP cut at ``fraction`` of its bytes."""
    target = folder / f'cut_{int(100 * fraction)}'
    target.mkdir()
    (source,) = sorted(Path(bag).glob('*.mcap'))
    data = source.read_bytes()
    (target / source.name).write_bytes(data[:int(len(data) * fraction)])
    return target


@pytest.mark.parametrize('fraction', [0.3, 0.6, 0.9])
def test_a_cut_recording_gives_its_complete_experiments_and_a_warning(
        recorded, tmp_path, fraction):
    recording, bag = recorded
    cut = _cut(bag, tmp_path, fraction)
    result = _replay(cut, tmp_path / 'out', tmp_path / 's.json')
    assert result.returncode == 0, result.stderr
    warning = [line for line in result.stderr.splitlines() if 'unfinished recording' in line]
    assert len(warning) == 1 and 'complete messages up to bag time' in warning[0]
    summary = json.loads((tmp_path / 's.json').read_text())
    recovery = summary['recovery']
    assert not recovery['complete'] and 0 < recovery['messages'] < len(recording)
    stop_s = recovery['last_stamp_s']
    assert f'{stop_s:.3f}' in warning[0]
    # every message before the cut was read: the recovered ones are the first ones, in order
    assert recording.stamps_s[recovery['messages'] - 1] == pytest.approx(stop_s, abs=1e-6)
    # the experiments completed before the cut are estimated, and only those: the one the cut
    # interrupts is not (what followed is lost), and a note says so when it had levels
    complete = [t for t in recording.truth if t.end_s < stop_s]
    entries = summary['experiments']
    assert len(entries) == len(complete)
    for entry, truth in zip(entries, complete):
        assert truth.start_s <= entry['stamp_s'] <= truth.end_s
        assert len(entry['speeds_rad_s']) == len(truth.speeds_rad_s)
    cut_notes = [n for n in summary['notes'] if 'in progress at the cut' in n]
    assert len(cut_notes) <= 1
    if cut_notes:
        assert f'note: {cut_notes[0]}' in result.stderr
        assert summary['joints'][0]['rejected'].get('experiment_cut') == 1
    assert (tmp_path / 'out' / 'metadata.yaml').is_file()


def test_strict_refuses_a_cut_recording(recorded, tmp_path):
    _, bag = recorded
    cut = _cut(bag, tmp_path, 0.6)
    result = _replay(cut, tmp_path / 'out', tmp_path / 's.json', '--strict')
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and 'strict' in result.stderr
    assert not (tmp_path / 'out').exists()


def test_an_mcap_file_given_directly(recorded, tmp_path):
    recording, bag = recorded
    (source,) = sorted(Path(bag).glob('*.mcap'))
    whole = _replay(source, tmp_path / 'whole', tmp_path / 'whole.json')
    assert whole.returncode == 0 and 'unfinished' not in whole.stderr, whole.stderr
    summary = json.loads((tmp_path / 'whole.json').read_text())
    assert summary['recovery']['complete'] and summary['recovery']['messages'] == len(recording)
    assert len(summary['experiments']) == len(recording.truth)
    # the same as the bag folder it came from
    folder = _replay(bag, tmp_path / 'folder', tmp_path / 'folder.json')
    assert folder.returncode == 0
    reference = json.loads((tmp_path / 'folder.json').read_text())
    assert [e['wear'] for e in summary['experiments']] == \
        pytest.approx([e['wear'] for e in reference['experiments']])
    # a cut file given directly: recovered up to the cut
    cut = tmp_path / 'cut.mcap'
    data = source.read_bytes()
    cut.write_bytes(data[:len(data) // 2])
    result = _replay(cut, tmp_path / 'out', tmp_path / 's.json')
    assert result.returncode == 0 and 'unfinished recording' in result.stderr
    shutil.rmtree(tmp_path / 'out')
