"""
Imports stand at a module's top unless a reason is written beside them (issue 42, item 5).

An import inside a function or method of the package is a deferred import: it must carry one
comment of the fixed form ``# deferred import: REASON``, where REASON begins with one of
:data:`REASONS` (``start-up time (what it keeps out)``, ``optional extra 'NAME'``,
``import cycle with MODULE``, ``load order (...)``).  The comment stands at the end of the
import's first line, or on the line just above the run of import statements the import belongs
to (consecutive statements, nothing between them), so that one comment serves a block.

Checked on the source with :mod:`ast` (nothing is imported); a failure names file:line of every
import without its reason.  The second half checks the start-up time that most of these
reasons name: the command line's ``--help`` loads none of the heavy libraries.
"""

import ast
import re
import subprocess
import sys

from wear_testing.paths import REPO_ROOT

PACKAGE = 'robot_wear_monitor'

#: The reasons a deferred import may give, each the beginning of the text after the colon.
REASONS = ('start-up time (', "optional extra '", 'import cycle with ', 'load order (')

_COMMENT = re.compile(r'#\s*deferred import:\s*(?P<reason>.*\S)')


def _reason(line: str) -> str | None:
    """Return the reason of a ``# deferred import:`` comment in ``line``, or None."""
    match = _COMMENT.search(line)
    return match.group('reason') if match else None


def deferred_imports(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Return the import statements inside functions and methods of ``tree``, in line order."""
    found: list[ast.Import | ast.ImportFrom] = []

    def walk(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inside = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                       ast.Lambda))
            if in_function and isinstance(child, (ast.Import, ast.ImportFrom)):
                found.append(child)
            walk(child, inside)

    walk(tree, False)
    return sorted(found, key=lambda node: node.lineno)


def unexplained_imports(source: str) -> list[tuple[int, str]]:
    """
    Return (line, problem) for each deferred import of ``source`` without its reason.

    A run of imports is consecutive statements, each starting on the line after the last
    ends; the comment above the run's first serves every import of the run.
    """
    lines = source.splitlines()
    imports = deferred_imports(ast.parse(source))
    problems = []
    run_start: dict[int, int] = {}  # an import's line -> the first line of its run
    previous: ast.Import | ast.ImportFrom | None = None
    for node in imports:
        if previous is not None and node.lineno == (previous.end_lineno or 0) + 1:
            run_start[node.lineno] = run_start[previous.lineno]
        else:
            run_start[node.lineno] = node.lineno
        previous = node
    for node in imports:
        first = run_start[node.lineno]
        above = lines[first - 2].strip() if first >= 2 else ''
        reason = _reason(lines[node.lineno - 1])
        if reason is None and above.startswith('#'):
            reason = _reason(above)
        if reason is None:
            problems.append((node.lineno, 'no "# deferred import: REASON" comment beside it'))
        elif not reason.startswith(REASONS):
            problems.append((node.lineno, f'reason {reason!r} does not begin with one of '
                                          f'{", ".join(repr(r) for r in REASONS)}'))
    return problems


def test_every_deferred_import_of_the_package_says_why():
    failures = []
    for path in sorted((REPO_ROOT / PACKAGE).rglob('*.py')):
        for line, problem in unexplained_imports(path.read_text()):
            failures.append(f'{path.relative_to(REPO_ROOT)}:{line}: {problem}')
    assert not failures, ('imports inside functions without their reason (move them to the '
                          'module top, or write the reason):\n' + '\n'.join(failures))


def test_the_rule_on_a_small_source():
    source = '\n'.join([
        'import os',                                          # 1: at the top: no reason needed
        '',
        '',
        'def f():',
        '    import json',                                    # 5: no reason
        '    # deferred import: start-up time (scipy)',
        '    import scipy',                                   # 7: reason above
        '    from scipy import stats',                        # 8: same run as line 7
        '',
        '    import numpy  # deferred import: start-up time (numpy)',  # 10: reason beside it
        '    x = 1',
        '    import csv',                                     # 12: a statement between: no run
        '    # deferred import: because',
        '    import abc',                                     # 14: not a known reason
        '',
        '',
        'class C:',
        '    def m(self):',
        '        # the optional dashboard extra',
        '        import fastapi',                             # 20: an old-style comment
        '        return lambda: __import__("x")',
        '',
    ])
    assert [line for line, _ in unexplained_imports(source)] == [5, 12, 14, 20]
    assert 'does not begin with one of' in dict(unexplained_imports(source))[14]


def test_the_command_lines_help_loads_no_heavy_library():
    # what the deferred imports of the command line are for: --help, and a verb's --help,
    # build every verb's parser and load none of these
    heavy = ('numpy', 'scipy', 'matplotlib', 'rclpy', 'fastapi', 'rosbags', 'yaml', 'tqdm',
             'uvicorn', 'psycopg', 'mcap')
    code = ('import contextlib, io, sys\n'
            'from robot_wear_monitor.cli import main\n'
            'for argv in (["--help"], ["replay", "--help"], ["identify", "--help"]):\n'
            '    with contextlib.redirect_stdout(io.StringIO()):\n'
            '        assert main(argv) == 0, argv\n'
            f'loaded = sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r}))\n'
            'print(",".join(loaded))\n')
    run = subprocess.run([sys.executable, '-c', code], cwd=REPO_ROOT, capture_output=True,
                         text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == '', f'--help loaded {run.stdout.strip()}'
