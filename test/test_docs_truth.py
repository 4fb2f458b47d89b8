"""
What the docs name exists as named: the schema version, module paths, command names, modules.

README.md and ``docs/*.md`` are read as text (nothing is run):

* every place that states the history's *current* schema version states the code's
  :data:`~robot_wear_monitor.history.migrations.SCHEMA_VERSION` (read from the code, so a new
  schema version only needs the docs edited), and no ``schema version N`` names a version the
  code does not have;
* every ``robot_wear_monitor/...py`` path (and every path of a ``.py`` file in code, from the
  repository or from the package folder) is a file of the repository, and every dotted name
  ``robot_wear_monitor.a.b`` a module or a name defined or imported at the top of its module
  (read with :mod:`ast`, so modules of optional extras need not be importable);
* every ``robot-wear-monitor VERB`` in code (backticks or a fenced block) names a verb of the
  command line (:data:`robot_wear_monitor.cli.VERBS`);
* docs/layout.md names every module of the package, in the section of its folder, and each
  import it states between folders (```a` <- `b``: ``b`` imports ``a``) is one the code has.
"""

import ast
from pathlib import Path
import re

import pytest
from robot_wear_monitor.cli import VERBS
from robot_wear_monitor.history.migrations import SCHEMA_VERSION
from test_import_graph import import_edges, module_names
from wear_testing.paths import REPO_ROOT

PACKAGE = REPO_ROOT / 'robot_wear_monitor'
DOCS = [REPO_ROOT / 'README.md', *sorted((REPO_ROOT / 'docs').glob('*.md'))]
LAYOUT = REPO_ROOT / 'docs' / 'layout.md'

#: (file, pattern): places that state the current schema version (group 1)
CURRENT_VERSION_CLAIMS = (
    ('docs/history.md', r'^# The wear history \(schema version (\d+)\)'),
    ('docs/history.md', r'-- one row: (\d+)'),
    ('docs/history.md', r'this version reads (\d+)'),
    ('docs/layout.md', r'schema version (\d+) with migrations'),
    ('docs/fleet.md', r'The history is schema version (\d+)'),
    ('docs/dashboard.md', r'\(version (\d+) now\)'),
)
#: modules the docs name as gone (each must be said to be gone where it is named)
GONE = ('robot_wear_monitor.audit.model_audit',)
#: an example of a history newer than the code: the code's version + 1
NEWER_VERSION_EXAMPLE = ('docs/history.md', r'`schema version (\d+), this version reads')


def _text(relative: str) -> str:
    return (REPO_ROOT / relative).read_text(encoding='utf-8')


def _code_spans(text: str) -> list[str]:
    """Return the fenced blocks and the inline code spans of a Markdown text."""
    fenced = re.findall(r'^```[^\n]*\n(.*?)^```', text, flags=re.M | re.S)
    rest = re.sub(r'^```[^\n]*\n.*?^```', '', text, flags=re.M | re.S)
    return fenced + re.findall(r'`([^`\n]+)`', rest)


@pytest.mark.parametrize('relative, pattern', CURRENT_VERSION_CLAIMS)
def test_the_docs_state_the_current_schema_version_of_the_code(relative, pattern):
    found = re.findall(pattern, _text(relative), flags=re.M)
    assert found, f'{relative}: no statement of the schema version ({pattern})'
    assert {int(v) for v in found} == {SCHEMA_VERSION}, (relative, found, SCHEMA_VERSION)


def test_no_doc_names_a_schema_version_the_code_does_not_have():
    relative, pattern = NEWER_VERSION_EXAMPLE
    assert [int(v) for v in re.findall(pattern, _text(relative))] == [SCHEMA_VERSION + 1]
    wrong = []
    for path in DOCS:
        text = re.sub(pattern, '', path.read_text(encoding='utf-8'))
        wrong += [(path.name, int(v)) for v in re.findall(r'schema versions? (\d+)', text)
                  if not 1 <= int(v) <= SCHEMA_VERSION]
    assert not wrong, f'schema versions the code (version {SCHEMA_VERSION}) does not have: {wrong}'


def test_every_module_path_the_docs_name_is_a_file():
    missing = []
    for path in DOCS:
        text = path.read_text(encoding='utf-8')
        for named in set(re.findall(r'robot_wear_monitor/[\w/]+\.py\b', text)):
            if not (REPO_ROOT / named).is_file():
                missing.append((path.name, named))
        # a path in code, from the repository or the package folder (`estimation/trend.py`)
        for named in set(re.findall(r'`([\w./-]+/[\w.-]+\.py)\b', text)):
            if not any((base / named).is_file() for base in (REPO_ROOT, PACKAGE)):
                missing.append((path.name, named))
    assert not missing, missing


def _top_level_names(module: Path) -> set[str]:
    """Return the names a module defines or imports at its top (and in top-level blocks)."""
    names: set[str] = set()
    body = list(ast.parse(module.read_text(encoding='utf-8')).body)
    while body:
        node = body.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split('.')[0] for a in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.If, ast.Try)):
            body += node.body + node.orelse + getattr(node, 'finalbody', [])
            for handler in getattr(node, 'handlers', []):
                body += handler.body
    return names


def _module_file(dotted: str) -> Path | None:
    base = REPO_ROOT.joinpath(*dotted.split('.'))
    for candidate in (base.with_suffix('.py'), base / '__init__.py'):
        if candidate.is_file():
            return candidate
    return None


def _resolves(dotted: str) -> bool:
    """Return whether ``dotted`` is a module of the package or a top-level name of one."""
    parts = dotted.split('.')
    for cut in range(len(parts), 0, -1):
        module = _module_file('.'.join(parts[:cut]))
        if module is None:
            continue
        rest = parts[cut:]
        if not rest:
            return True
        if rest[0] in _top_level_names(module):
            return True  # an attribute of that name (a class's members are not checked)
        return False
    return False


def test_every_dotted_name_the_docs_name_exists():
    missing = []
    for path in DOCS:
        text = path.read_text(encoding='utf-8')
        for named in set(re.findall(r'\brobot_wear_monitor(?:\.\w+)+', text)):
            if named in GONE:
                assert re.search(re.escape(named) + r'`? is gone', text), (path.name, named)
                assert not _resolves(named), f'{named} is said to be gone but exists'
            elif not _resolves(named):
                missing.append((path.name, named))
    assert not missing, missing


def test_every_command_the_docs_name_is_a_verb():
    unknown = []
    for path in DOCS:
        for span in _code_spans(path.read_text(encoding='utf-8')):
            for verb in re.findall(r'(?<![\w/.-])robot-wear-monitor\s+([a-z][\w-]*)', span):
                if verb not in VERBS:
                    unknown.append((path.name, verb))
    assert not unknown, f'not verbs of robot-wear-monitor ({", ".join(VERBS)}): {unknown}'


def _layout_sections() -> dict[str, str]:
    """Return layout.md's ``##`` sections by heading."""
    sections: dict[str, str] = {}
    heading = ''
    for line in LAYOUT.read_text(encoding='utf-8').splitlines():
        if line.startswith('## '):
            heading = line[3:]
            sections[heading] = ''
        elif heading:
            sections[heading] += line + '\n'
    return sections


def test_layout_names_every_module_of_the_package_in_its_folders_section():
    sections = _layout_sections()
    whole = LAYOUT.read_text(encoding='utf-8')
    unnamed = []
    for module in sorted(PACKAGE.rglob('*.py')):
        relative = module.relative_to(PACKAGE)
        if relative.name in ('__init__.py', '__main__.py'):
            continue
        if len(relative.parts) == 1:  # a top-level module: named anywhere in backticks
            if f'`{relative.name}`' not in whole:
                unnamed.append(str(relative))
            continue
        folder = f'`{relative.parts[0]}/`'
        texts = [text for heading, text in sections.items() if folder in heading]
        assert texts, f'docs/layout.md has no section for {folder}'
        inner = '/'.join(relative.parts[1:])
        names = (f'`{relative.name}`', f'`{inner}`', f'`{relative.parts[0]}/{inner}`')
        if not any(name in text for text in texts for name in names):
            unnamed.append(str(relative))
    assert not unnamed, f'docs/layout.md does not name: {unnamed}'


def _folder_imports() -> set[tuple[str, str]]:
    """Return (importer, imported) pairs of the package's folders, every import counted."""
    modules = module_names(REPO_ROOT, 'robot_wear_monitor')
    edges = import_edges(modules, 'robot_wear_monitor')

    def folder(name: str) -> str:
        parts = name.split('.')
        nested = len(parts) > 2 or (len(parts) == 2 and modules[name].name == '__init__.py')
        return parts[1] if nested else ''
    return {(folder(a), folder(b)) for a, targets in edges.items() for b in targets}


def test_the_imports_layout_states_between_folders_exist():
    text = ' '.join(LAYOUT.read_text(encoding='utf-8').split())
    stated = []
    for chain in re.findall(r'`\w+`(?: <- `\w+`)+', text):
        names = re.findall(r'`(\w+)`', chain)
        stated += list(zip(names, names[1:]))
    assert len(stated) >= 8, stated
    imports = _folder_imports()
    absent = [f'{b} imports {a}' for a, b in stated if (b, a) not in imports]
    assert not absent, f'docs/layout.md states imports the code does not have: {absent}'
