"""
The package's imports run downward: no import circle among robot_wear_monitor's modules.

The rule, checked on the source with :mod:`ast` (nothing is imported):

* A node is a module of the package: a ``.py`` file, a package being its ``__init__.py`` and
  named by the package (``robot_wear_monitor.nodes``).
* Every import statement counts wherever it stands: at the top, inside a function or a class,
  under ``if TYPE_CHECKING:``, in a ``try`` block; and so does ``importlib.import_module`` of a
  constant string.  (An import whose name is computed at run time, as the CLI's
  ``import_module(f'{__name__}.{name}')``, cannot be resolved and is not counted.)
* ``import a.b.c`` and ``from a.b.c import name`` are an edge to the module ``a.b.c``, and
  ``from a.b import c`` is an edge to the submodule ``a.b.c`` when ``c`` is one, else to the
  package ``a.b`` (its ``__init__``, whose names are taken).  Relative imports are resolved
  against the importing module's package.  The packages Python initialises on the way
  (``a`` and ``a.b`` for ``a.b.c``) are not edges: a package being initialised is already in
  ``sys.modules`` when its submodules run.  So a package's ``__init__`` that imports its own
  submodules to hand their names on depends on them, and that is no circle; a submodule that
  takes a name back from its package's ``__init__`` (``from a.b import name``, ``name`` not a
  module) closes one.
* A circle is a strongly connected component of more than one module (a module importing
  itself is ignored).  The failure lists one circle of each component, every step with the
  file and line of its import.
"""

import ast
from pathlib import Path

from wear_testing.paths import REPO_ROOT

PACKAGE = 'robot_wear_monitor'


def module_names(root: Path, package: str) -> dict[str, Path]:
    """Return the modules of ``package`` (a folder under ``root``) by dotted name."""
    modules = {}
    for path in sorted((root / package).rglob('*.py')):
        parts = list(path.relative_to(root).with_suffix('').parts)
        if parts[-1] == '__init__':
            parts.pop()
        modules['.'.join(parts)] = path
    return modules


def _is_package(modules: dict[str, Path], name: str) -> bool:
    return name in modules and modules[name].name == '__init__.py'


def _target(modules: dict[str, Path], name: str) -> str | None:
    """Return the module ``name`` or, for a name inside a module, that module; None if outside."""
    while name and name not in modules:
        name = name.rpartition('.')[0]
    return name or None


def import_edges(modules: dict[str, Path], package: str) -> dict[str, dict[str, int]]:
    """Return, per module, the modules of the package it imports and the line of the first."""
    edges: dict[str, dict[str, int]] = {name: {} for name in modules}
    for name, path in modules.items():
        own_package = name if _is_package(modules, name) else name.rpartition('.')[0]
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ''
                if node.level:
                    anchor = own_package.split('.')
                    anchor = anchor[:len(anchor) - (node.level - 1)]
                    base = '.'.join(anchor + ([base] if base else []))
                for alias in node.names:
                    sub = f'{base}.{alias.name}'
                    targets.append(sub if sub in modules else base)
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                  and node.func.attr == 'import_module' and node.args
                  and isinstance(node.args[0], ast.Constant)
                  and isinstance(node.args[0].value, str)):
                targets = [node.args[0].value]
            for target in targets:
                if target != package and not target.startswith(package + '.'):
                    continue
                module = _target(modules, target)
                if module is not None and module != name:
                    edges[name].setdefault(module, node.lineno)
    return edges


def strongly_connected(edges: dict[str, dict[str, int]]) -> list[list[str]]:
    """Return the strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []

    def visit(start: str) -> None:
        # iterative depth-first search: (node, iterator over its successors)
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            advanced = False
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = len(index)
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(edges[successor]))))
                    advanced = True
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    components.append(sorted(component))

    for name in sorted(edges):
        if name not in index:
            visit(name)
    return components


def one_circle(edges: dict[str, dict[str, int]], component: list[str]) -> list[str]:
    """Return a shortest circle through the first module of ``component``: [m0, m1, ..., m0]."""
    members = set(component)
    start = component[0]
    came_from: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for successor in sorted(edges[node]):
                if successor == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(came_from[path[-1]])
                    return [start, *reversed(path[:-1]), start]
                if successor in members and successor not in came_from:
                    came_from[successor] = node
                    following.append(successor)
        frontier = following
    raise AssertionError(f'no circle through {start}')  # a component always has one


def describe(edges: dict[str, dict[str, int]], modules: dict[str, Path], root: Path,
             components: list[list[str]]) -> str:
    """Return the failure message: each component and one circle, step by step."""
    text = []
    for component in components:
        circle = one_circle(edges, component)
        text.append(f'import circle among {len(component)} modules: {", ".join(component)}')
        text.append('  ' + ' -> '.join(circle))
        for here, there in zip(circle, circle[1:]):
            where = modules[here].relative_to(root)
            text.append(f'    {where}:{edges[here][there]}: imports {there}')
    return '\n'.join(text)


def test_no_import_circle_in_the_package():
    modules = module_names(REPO_ROOT, PACKAGE)
    edges = import_edges(modules, PACKAGE)
    components = strongly_connected(edges)
    assert not components, describe(edges, modules, REPO_ROOT, components)


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_the_rule_on_a_small_package(tmp_path):
    """A re-exporting __init__ is no circle; a function-level import back is, and is named."""
    _write(tmp_path, {
        'pkg/__init__.py': '',
        'pkg/sub/__init__.py': 'from pkg.sub.low import helper\nfrom .mid import thing\n',
        'pkg/sub/low.py': 'import os\n\n\ndef helper():\n    return os.sep\n',
        'pkg/sub/mid.py': 'from pkg.sub import low\n\nthing = low.helper\n',
        'pkg/top.py': 'from pkg.sub import thing\n',
    })
    modules = module_names(tmp_path, 'pkg')
    edges = import_edges(modules, 'pkg')
    assert edges['pkg.sub'] == {'pkg.sub.low': 1, 'pkg.sub.mid': 2}
    assert edges['pkg.sub.mid'] == {'pkg.sub.low': 1}  # a submodule, not the __init__
    assert edges['pkg.top'] == {'pkg.sub': 1}
    assert strongly_connected(edges) == []
    # a name taken back from the package's __init__, inside a function and under TYPE_CHECKING
    _write(tmp_path, {
        'pkg/sub/low.py': 'import os\n\n\ndef helper():\n    from pkg.sub import thing\n'
                          '    return os.sep, thing\n',
        'pkg/top.py': 'from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n'
                      '    from pkg.sub.mid import thing\n',
        'pkg/other.py': 'import importlib\nimportlib.import_module("pkg.top")\n',
    })
    _write(tmp_path, {'pkg/sub/mid.py': 'from ..other import x\n'})
    modules = module_names(tmp_path, 'pkg')
    edges = import_edges(modules, 'pkg')
    assert edges['pkg.sub.low'] == {'pkg.sub': 5}
    assert edges['pkg.top'] == {'pkg.sub.mid': 3}
    assert edges['pkg.other'] == {'pkg.top': 2}
    assert edges['pkg.sub.mid'] == {'pkg.other': 1}
    components = strongly_connected(edges)
    assert components == [['pkg.other', 'pkg.sub.mid', 'pkg.top'], ['pkg.sub', 'pkg.sub.low']]
    message = describe(edges, modules, tmp_path, components)
    assert 'pkg.other -> pkg.top -> pkg.sub.mid -> pkg.other' in message
    assert 'pkg/sub/low.py:5: imports pkg.sub' in message
