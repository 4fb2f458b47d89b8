"""
The command blocks of every page under ``docs/`` run as written (with small data).

Each page is a chain of its own: its runnable blocks run in order, one ``bash -e`` each, in a
fresh folder of the page's own that holds the repository's ``examples/`` (so a page's later
block uses what its earlier ones made, and no page depends on another).  The rules are the
README's (``test_readme.py``, :mod:`wear_testing.command_blocks`): a command line naming
``../shared`` runs apart and skips, saying so, when ``../shared`` is absent; a block marked
``<!-- not run: REASON -->`` is reported as a skipped test with its reason; a ``ros2`` line
outside such a block fails; ``text`` blocks are synopses and output.  Sizes are cut where a
block would take long (:data:`SMALLER`, per page); each cut must match its page.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from wear_testing.command_blocks import (chain_script, command_blocks, cut, ROOT, run_script,
                                         SHARED, shared_commands, unmarked_ros2_lines,
                                         workspace)

PAGES = sorted((ROOT / 'docs').glob('*.md'))
BLOCKS = {page.name: command_blocks(page) for page in PAGES}
CHAINS = [name for name, blocks in BLOCKS.items()
          if any(block.not_run is None and chain_script(block).strip() for block in blocks)]
NOT_RUN = [block for blocks in BLOCKS.values() for block in blocks if block.not_run is not None]
SHARED_COMMANDS = [pair for blocks in BLOCKS.values() for pair in shared_commands(blocks)]
#: page -> (text, what runs instead): the same command on less data.
SMALLER = {
    'estimation.md': (('--runs 1000 ', '--runs 200 '),),
    'segmentation.md': (('robot-wear-monitor simulate --out wear_bag ',
                         'robot-wear-monitor simulate --out wear_bag --experiments 8 '),),
    'fleet.md': (('--experiments 30 ', '--experiments 6 '),),
    'dashboard.md': (('--experiments 30 ', '--experiments 6 '),),
}


def test_every_size_cut_matches_its_page():
    for page, cuts in SMALLER.items():
        text = ''.join(block.text for block in BLOCKS[page])
        for before, _ in cuts:
            assert before in text, f'docs/{page} no longer has {before!r}: update SMALLER'


def test_every_ros2_command_is_in_a_block_marked_not_run():
    lines = [line for blocks in BLOCKS.values() for line in unmarked_ros2_lines(blocks)]
    assert lines == [], 'mark these blocks <!-- not run: REASON -->'


def test_the_pages_have_command_chains():
    assert {'estimation.md', 'segmentation.md', 'replay.md', 'fleet.md', 'audit.md'} <= set(CHAINS)


@pytest.mark.parametrize('page', CHAINS)
def test_the_page_command_chain_runs_as_written(tmp_path, page):
    work, env = workspace(tmp_path)
    for block in BLOCKS[page]:
        script = cut(chain_script(block), SMALLER.get(page, ()))
        if block.not_run is None and script.strip():
            run_script(script, work=work, env=env, name=block.name)


@pytest.mark.parametrize('block', NOT_RUN, ids=[block.name for block in NOT_RUN])
def test_blocks_marked_not_run(block):
    pytest.skip(f'{block.name} not run: {block.not_run}')


@pytest.mark.parametrize('block, command', SHARED_COMMANDS,
                         ids=[f'{b.name}-{c.split()[1]}' for b, c in SHARED_COMMANDS])
def test_the_commands_on_the_measured_data_run_as_written(tmp_path, block, command):
    if not SHARED.is_dir():
        pytest.skip(f'{SHARED} is absent: {block.name} not run: {command}')
    work, env = workspace(tmp_path, shared=True)
    run_script(cut(command, SMALLER.get(Path(block.page).name, ())) + '\n', work=work, env=env,
               name=block.name)
