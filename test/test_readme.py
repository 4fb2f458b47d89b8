"""
The README's command chains run as written (with small data): every command block.

The runnable blocks run in one ``bash -e`` each, in order, in an empty folder (nothing of the
repository in it: the tour's first command, ``robot-wear-monitor examples``, copies the example
files from the installed package), so a later block uses what an earlier one made
(``examples/``, ``wear_bag``, the history), as a new user would.  The commands on the measured
data in ``../shared`` (a line naming ``../shared``) read only those data: they run apart, one
test each, in a folder with ``../shared`` beside it, and only they skip when ``../shared`` is
absent (the reason names the block and the command); the chain runs either way.  A block
marked ``<!-- not run: REASON -->`` (the first block, which is the CI itself; a live ROS 2
graph; a server) is reported as a skipped test with its reason
(:mod:`wear_testing.command_blocks`).  ``text`` blocks are synopses and sample output, not
commands.

Sizes are cut where a block would take minutes (:data:`SMALLER`); each cut must match, so the
README cannot drift away from what is tested.  The pages under ``docs/`` have their own test,
``test_docs_commands.py``.
"""

from __future__ import annotations

import pytest
from wear_testing.command_blocks import (chain_script, command_blocks, cut, ROOT, run_script,
                                         SHARED, shared_commands, unmarked_ros2_lines,
                                         workspace)

README = ROOT / 'README.md'
#: (README text, what runs instead): the same command on less data.
SMALLER = (
    ('robot-wear-monitor simulate --out wear_bag --experiments 30 ',
     'robot-wear-monitor simulate --out wear_bag --experiments 8 '),
)
BLOCKS = command_blocks(README)
NOT_RUN = [block for block in BLOCKS if block.not_run is not None]
SHARED_COMMANDS = shared_commands(BLOCKS)


def test_the_first_block_is_the_two_commands_and_is_not_run():
    first = BLOCKS[0]
    assert first.not_run and '# the tests' in first.text and 'demo' in first.text


def test_every_size_cut_matches_the_readme():
    text = ''.join(block.text for block in BLOCKS)
    for before, _ in SMALLER:
        assert before in text, f'the README no longer has {before!r}: update SMALLER'


def test_every_ros2_command_is_in_a_block_marked_not_run():
    assert unmarked_ros2_lines(BLOCKS) == [], 'mark these blocks <!-- not run: REASON -->'


def test_the_first_command_of_the_tour_copies_the_examples():
    tour = [block for block in BLOCKS if block.not_run is None]
    assert tour[0].text.strip() == 'robot-wear-monitor examples'


def test_the_readme_command_chains_run_as_written_in_an_empty_folder(tmp_path):
    work, env = workspace(tmp_path, examples=False)
    assert not any(work.iterdir())
    ran = 0
    for block in BLOCKS:
        script = cut(chain_script(block), SMALLER)
        if block.not_run is None and script.strip():
            run_script(script, work=work, env=env, name=block.name)
            ran += 1
    assert ran >= 5
    assert (work / 'examples' / 'baseline.csv').is_file() and (work / 'my_joint.yaml').is_file()


@pytest.mark.parametrize('block', NOT_RUN, ids=[block.name for block in NOT_RUN])
def test_blocks_marked_not_run(block):
    pytest.skip(f'{block.name} not run: {block.not_run}')


@pytest.mark.parametrize('block, command', SHARED_COMMANDS,
                         ids=[f'{b.name}-{c.split()[1]}' for b, c in SHARED_COMMANDS])
def test_the_readme_commands_on_the_measured_data_run_as_written(tmp_path, block, command):
    if not SHARED.is_dir():
        pytest.skip(f'{SHARED} is absent: {block.name} not run: {command}')
    work, env = workspace(tmp_path, shared=True)
    run_script(cut(command, SMALLER) + '\n', work=work, env=env, name=block.name)
