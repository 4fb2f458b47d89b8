"""
Reading YAML files other people wrote: bounded in size, no aliases, values cut in errors.

A parameter set, a node configuration or a bag's ``metadata.yaml`` is untrusted input.  YAML
aliases (``*name``) let a few hundred bytes expand to gigabytes ("billion laughs"), so they are
refused while the document is composed, before anything is expanded; a file that is not a
regular file, or holds more than :data:`MAX_YAML_BYTES`, is refused as it is read; and a
value echoed in an error is cut to :data:`ECHO_LIMIT` characters (:func:`shorten`).  Only
plain data is built (``SafeLoader``): no Python objects, no code.

The same text is not parsed twice: a replay reads the node configuration four times and the
bag's ``metadata.yaml`` three times, and even libyaml takes a millisecond for each.
The latest documents are kept by their text (:data:`RECENT_TEXTS`, :func:`functools.lru_cache`;
an error is not kept); every call returns its own copy.
"""

from __future__ import annotations

import copy
from functools import lru_cache
import os
from pathlib import Path
from typing import Any

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.input_files import read_text_file
from robot_wear_monitor.text import ECHO_LIMIT, shorten
import yaml

__all__ = ['ECHO_LIMIT', 'load_yaml_file', 'load_yaml_text', 'MAX_YAML_BYTES', 'shorten']

#: The largest YAML file read [bytes] (the packaged parameter set is 2 kB).
MAX_YAML_BYTES = 1_000_000
#: How many parsed texts :func:`load_yaml_text` keeps (the latest).
RECENT_TEXTS = 8


class _NoAliasLoader(yaml.SafeLoader):
    """SafeLoader that refuses aliases when it meets them (nothing is expanded before)."""

    def compose_node(self, parent: Any, index: Any) -> Any:  # noqa: D102 - yaml's hook
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.composer.ComposerError(
                None, None, 'YAML aliases (*name) are not accepted', event.start_mark)
        return super().compose_node(parent, index)


def load_yaml_text(text: str, *, source: str, error: type[InputError] = InputError) -> Any:
    """Return the document of YAML ``text``; raise ``error`` naming ``source`` when it is bad."""
    if len(text) > MAX_YAML_BYTES:
        raise error(f'{source}: {len(text)} characters, more than the {MAX_YAML_BYTES} a YAML '
                    'file may have here')
    try:
        document = _parsed(text)
        return copy.deepcopy(document)  # as deep as the document: within the except below
    except yaml.YAMLError as problem:
        mark = getattr(problem, 'problem_mark', None)
        where = f' (line {mark.line + 1}, column {mark.column + 1})' if mark else ''
        what = getattr(problem, 'problem', None) or str(problem).splitlines()[0]
        raise error(f'{source}: not valid YAML: {shorten(what)}{where}') from None
    except RecursionError:
        raise error(f'{source}: YAML nested too deeply') from None


#: PyYAML's binding of libyaml (the same SafeLoader rules, parsed in C), when PyYAML has it
_C_SAFE_LOADER: Any = getattr(yaml, 'CSafeLoader', None)


#: The deepest nesting of collections read with libyaml (the pure-Python loader stops near 300:
#: Python's recursion limit); libyaml composes recursively in C, where too deep a text would
#: overflow the stack and end the process.
MAX_YAML_DEPTH = 300


def _refuse_aliases(text: str) -> None:
    """
    Raise a ComposerError at the first alias of ``text`` (its events, nothing composed).

    :raises RecursionError: collections nested more than :data:`MAX_YAML_DEPTH` deep, whatever
        libyaml's own limit: libyaml's scanner reads ahead of the events, and since PyYAML
        6.0.4 its libyaml refuses deep nesting in its own words ("exceeded maximum nesting
        depth", 1,000 levels); on any error of libyaml the text is read again by
        :func:`_nesting_before_error` to tell nesting from other mistakes.
    """
    try:
        _scan_events(text, loader=_C_SAFE_LOADER)
    except yaml.YAMLError as error:
        if not isinstance(error, yaml.composer.ComposerError):  # not our refusal of an alias
            _nesting_before_error(text)
        raise


def _scan_events(text: str, *, loader: Any) -> None:
    """Raise at the first alias, or at nesting past :data:`MAX_YAML_DEPTH`, of ``text``."""
    depth = 0
    for event in yaml.parse(text, Loader=loader):
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_YAML_DEPTH:
                raise RecursionError(f'YAML collections nested more than {MAX_YAML_DEPTH} deep')
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1
        elif isinstance(event, yaml.AliasEvent):
            mark: Any = event.start_mark  # libyaml's: the line and column of yaml.error.Mark
            raise yaml.composer.ComposerError(
                None, None, 'YAML aliases (*name) are not accepted', mark)


def _nesting_before_error(text: str) -> None:
    """
    Raise RecursionError when ``text`` nests past :data:`MAX_YAML_DEPTH` before any error.

    Read by PyYAML's pure-Python parser, which has no nesting limit and does not recurse (only
    its composer does); it stops at the first error or past the depth, so a deep text costs
    :data:`MAX_YAML_DEPTH` levels, not the whole file.  Any other outcome returns: the caller
    raises libyaml's own error.
    """
    try:
        _scan_events(text, loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return


@lru_cache(maxsize=RECENT_TEXTS)
def _parsed(text: str) -> Any:
    """
    Return the document of ``text`` (shared: callers copy it).

    With libyaml (PyYAML's wheels have it) the events are scanned for aliases and for nesting
    deeper than :data:`MAX_YAML_DEPTH` first, then the document is loaded by ``CSafeLoader``:
    some ten times faster than the pure-Python loader, which is used without libyaml and
    refuses aliases as it composes (:class:`_NoAliasLoader`).
    """
    if _C_SAFE_LOADER is None:
        return yaml.load(text, Loader=_NoAliasLoader)  # noqa: S506 - a SafeLoader
    _refuse_aliases(text)
    return yaml.load(text, Loader=_C_SAFE_LOADER)  # noqa: S506 - a SafeLoader


def load_yaml_file(path: str | os.PathLike, *, what: str = 'YAML file',
                   error: type[InputError] = InputError) -> Any:
    """
    Return the document of the YAML file at ``path`` (a regular file, read with a bound).

    Raises ``error`` (an :class:`InputError` type) naming the path: missing or unreadable, over
    :data:`MAX_YAML_BYTES`, not valid YAML, or with aliases.
    """
    file = Path(path)
    text = read_text_file(file, what=what, limit_bytes=MAX_YAML_BYTES, error=error)
    return load_yaml_text(text, source=str(file), error=error)
