"""
Read the docs' option and setting tables and compare them with the declared settings.

A table row names a setting (a key or an option) and states its default, sometimes its unit
(``[s]``) and its range (``1..86400``, ``>= 1``, ``> 0 and <= 100``, ``[0, 1)``).  The helpers
here parse those texts; the tests (``test/fleet/test_notify_settings.py``,
``test/dashboard/test_dashboard_settings.py``, ``test/estimation/test_trend_settings.py``,
``test/cli/test_cli_fleet_options.py``) compare them with
:mod:`robot_wear_monitor.setting_fields` declarations, so a doc that states another default,
unit or range than the code fails.
"""

from __future__ import annotations

import math
from pathlib import Path
import re
from typing import Any, Optional

from robot_wear_monitor.setting_fields import Setting
from wear_testing.paths import REPO_ROOT

DOCS = REPO_ROOT / 'docs'


def table(path: Path, header: str) -> list[list[str]]:
    """Return the rows (lists of cells) of the markdown table whose header starts so."""
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith('|'):
            break
        rows.append([cell.strip() for cell in re.split(r'(?<!\\)\|', line.strip())[1:-1]])
    return rows


def row_of(rows: list[list[str]], name: str) -> list[str]:
    """Return the row whose first cell names ``name`` in backticks (a key or an option)."""
    pattern = re.compile(rf'`{re.escape(name)}(?:[ `])')
    found = [row for row in rows if pattern.search(row[0] + ' ')]
    assert len(found) == 1, f'{name}: {len(found)} rows name it'
    return found[0]


def number(text: str) -> Optional[float]:
    """Return the number of ``text`` (backticks stripped), or None."""
    try:
        return float(text.strip().strip('`'))
    except ValueError:
        return None


def stated_default(text: str) -> Optional[str]:
    """Return the word after ``default`` in ``text`` (``(default 60 s, 1..86400)`` -> 60)."""
    match = re.search(r'default:? `?([^`,;)\s]+)', text)
    return match.group(1) if match else None


def same_default(declared: Setting, stated: str) -> bool:
    """Return True when the stated default text is the declared default."""
    value = declared.default
    if isinstance(value, bool):
        return stated.strip('`').lower() == str(value).lower()
    if isinstance(value, (int, float)):
        return number(stated) == float(value)
    return stated.strip('`') == str(value)


def stated_ranges(text: str) -> list[tuple[float, bool, float, bool]]:
    """
    Return the ranges stated in ``text`` as (low, low closed, high, high closed).

    ``A..B`` and ``[A, B]`` are closed, ``(A, B]``/``[A, B)`` half open, ``>= A``/``> A`` have
    no upper end, ``> A and <= B`` both.
    """
    found: list[tuple[float, bool, float, bool]] = []
    num = r'(-?[0-9.]+(?:e-?[0-9]+)?)'
    for low, high in re.findall(rf'(?<![\w.]){num}\.\.{num}', text):
        found.append((float(low), True, float(high), True))
    for left, low, high, right in re.findall(rf'([\[(]){num}, {num}([\])])', text):
        found.append((float(low), left == '[', float(high), right == ']'))
    bare = r'-?[0-9.]+(?:e-?[0-9]+)?'
    for sign, low, rest in re.findall(rf'(>=?) {num}(?! *\.\.)( and <= {bare})?', text):
        high = float(rest.split()[-1]) if rest else math.inf
        found.append((float(low), sign == '>=', high, bool(rest)))
    return found


def check_range(declared: Setting, stated: tuple[float, bool, float, bool]) -> None:
    """Assert that the declared check accepts the stated range's inside and refuses outside."""
    low, low_closed, high, high_closed = stated
    check = declared.check
    assert check is not None, f'{declared.name}: a range is stated but none is declared'
    step = max(abs(low), abs(high) if math.isfinite(high) else 1.0, 1.0) * 1e-6
    if declared.kind == 'int':
        step = 1.0
    inside_low = low if low_closed else low + step
    assert check(_kind(declared, inside_low)) is None, (declared.name, 'low', stated)
    outside_low = low - step if low_closed else low
    assert check(_kind(declared, outside_low)) is not None, (declared.name, 'below', stated)
    if math.isfinite(high):
        inside_high = high if high_closed else high - step
        assert check(_kind(declared, inside_high)) is None, (declared.name, 'high', stated)
        outside_high = high + step if high_closed else high
        assert check(_kind(declared, outside_high)) is not None, (declared.name, 'above',
                                                                  stated)
    else:
        assert check(_kind(declared, 1e12)) is None, (declared.name, 'no upper end', stated)


def _kind(declared: Setting, value: float) -> Any:
    return int(value) if declared.kind == 'int' and float(value).is_integer() else value


def stated_units(text: str) -> list[str]:
    """Return the units in brackets of ``text`` (``[s]``, ``[wear units, w 0..100]`` -> ...)."""
    return [unit.split(',')[0].strip() for unit in re.findall(r'\[([^\]]+)\]', text)
            if not unit[:1].isdigit() and '..' not in unit.split(',')[0]]
