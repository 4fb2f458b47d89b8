"""
Declared settings: each field of a configuration dataclass with its default, unit, text, check.

A component's configuration dataclass (:class:`~robot_wear_monitor.experiment.
segmentation_settings.SegmenterConfig`, :class:`~robot_wear_monitor.experiment.planning.
PlanConfig`, ...) declares each setting once, with :func:`setting`::

    @dataclass(frozen=True)
    class SegmenterConfig:
        min_samples: int = setting(20, unit='', check=at_least(3),
                                   description='fewest samples per pass ...')

        def __post_init__(self) -> None:
            check_settings(self)

Everything else is made from that declaration: the ROS parameter declarations of the nodes
(:meth:`robot_wear_monitor.monitoring.node_config.ParameterSpec.of`), the command-line options and
their help (:func:`robot_wear_monitor.cli.options.add_setting_option`), and the tables in docs/
are tested against it (``test/test_setting_fields.py``).  A check is a function of the value
that returns an error text (``'must be > 0'``) or None; the same function checks a node
parameter, an option and the dataclass, so a setting has one range wherever it is given.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, MISSING
import math
from typing import Any, Callable, Optional

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.text import shorten

#: A check: the value -> an error text (``'must be > 0'``), or None when the value is valid.
Check = Callable[[Any], Optional[str]]

#: The key of a declared setting in a dataclass field's metadata.
SETTING_KEY = 'robot_wear_monitor.setting'


@dataclass(frozen=True)
class Setting:
    """
    One declared setting: a field of a configuration dataclass.

    :ivar name: the field name (also the ROS parameter name where a node declares it).
    :ivar default: the default value (None: no default, or unset by default).
    :ivar unit: the unit as written in brackets in texts (``'rad/s'``, ``'s'``, ``'-'``);
        empty for counts, names and flags.
    :ivar description: what the setting does, one sentence, without the unit.
    :ivar check: the range check (None: any value of the type).
    :ivar kind: ``'float'``, ``'int'``, ``'str'``, ``'bool'`` or ``'other'`` (from the type).
    :ivar optional: None is a valid value (the type says ``| None``/``Optional``).

    """

    name: str
    default: Any
    unit: str
    description: str
    check: Optional[Check]
    kind: str
    optional: bool

    @property
    def text(self) -> str:
        """Return the description with the unit, as the help and the node declare it."""
        return f'{self.description} [{self.unit}]' if self.unit else self.description


def setting(default: Any = MISSING, *, description: str, unit: str = '',
            check: Optional[Check] = None) -> Any:
    """
    Return a dataclass field declared as a setting: default, unit, description, check.

    ``default`` MISSING: a required field.
    """
    metadata = {SETTING_KEY: (unit, description, check)}
    if default is MISSING:
        return field(metadata=metadata)
    return field(default=default, metadata=metadata)


def shared_setting(owner: Any, name: str, *, description: str | None = None) -> Any:
    """
    Return a field that is the declared setting ``name`` of another configuration ``owner``.

    The default, unit and check are the owner's (one owner; e.g. the plan's ``trim_s`` is the
    segmentation's); ``description`` replaces its text where the user reads it differently.
    """
    declared = setting_of(owner, name)
    return setting(declared.default, unit=declared.unit, check=declared.check,
                   description=description or declared.description)


def _kind(annotation: Any) -> tuple[str, bool]:
    text = str(annotation).replace(' ', '')
    optional = 'None' in text or 'Optional' in text
    for kind in ('bool', 'float', 'int', 'str'):
        if text.startswith((kind, f'Optional[{kind}]')) or text == f'{kind}|None':
            return kind, optional
    return 'other', optional


def declared_settings(owner: Any) -> dict[str, Setting]:
    """Return the declared settings of a configuration dataclass (or instance), by name."""
    result = {}
    for item in fields(owner):
        declared = item.metadata.get(SETTING_KEY)
        if declared is None:
            continue
        unit, description, check = declared
        kind, optional = _kind(item.type)
        default = None if item.default is MISSING else item.default
        result[item.name] = Setting(name=item.name, default=default, unit=unit,
                                    description=description, check=check, kind=kind,
                                    optional=optional)
    return result


def setting_of(owner: Any, name: str) -> Setting:
    """Return the declared setting ``name`` of ``owner`` (KeyError naming it when undeclared)."""
    try:
        return declared_settings(owner)[name]
    except KeyError:
        raise KeyError(f'{getattr(owner, "__name__", type(owner).__name__)} declares no '
                       f'setting {name!r}') from None


def problem_of(declared: Setting, value: Any) -> Optional[str]:
    """Return what is wrong with ``value`` for ``declared`` (type, then range), or None."""
    if value is None:
        return None if declared.optional else 'must be given'
    if declared.kind == 'float':
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return 'expected a finite number'
        if not math.isfinite(value):  # the range too: comparisons with NaN fail
            ranged = declared.check(value) if declared.check is not None else None
            return 'expected a finite number' + (f' ({ranged})' if ranged else '')
    elif declared.kind == 'int':
        if isinstance(value, bool) or not isinstance(value, int):
            return 'expected an integer'
    elif declared.kind == 'str':
        if not isinstance(value, str):
            return 'expected a string'
    elif declared.kind == 'bool' and not isinstance(value, bool):
        return 'expected true or false'
    return declared.check(value) if declared.check is not None else None


def check_settings(instance: Any, *, prefix: str | None = None) -> None:
    """
    Check every declared setting of a configuration dataclass instance.

    :raises InputError: ``<prefix><name>: <problem>, got <value> [<unit>]`` for the first bad
        one (``prefix`` default: ``'<Class>.'``; the value cut short and escaped, the unit
        when the setting has one).
    """
    prefix = f'{type(instance).__name__}.' if prefix is None else prefix
    for name, declared in declared_settings(instance).items():
        value = getattr(instance, name)
        problem = problem_of(declared, value)
        if problem:
            unit = f' [{declared.unit}]' if declared.unit not in ('', '-') else ''
            raise InputError(f'{prefix}{name}: {problem}, got {shorten(repr(value), 60)}'
                             f'{unit}')


# ----------------------------------------------------------------------------- checks

def positive(value: float) -> Optional[str]:
    """Check: > 0."""
    return None if value > 0 else 'must be > 0'


def non_negative(value: float) -> Optional[str]:
    """Check: >= 0."""
    return None if value >= 0 else 'must be >= 0'


def fraction(value: float) -> Optional[str]:
    """Check: in [0, 1)."""
    return None if 0 <= value < 1 else 'must be in [0, 1)'


def open_fraction(value: float) -> Optional[str]:
    """Check: in (0, 1)."""
    return None if 0 < value < 1 else 'must be in (0, 1)'


def at_least(low: float) -> Check:
    """Return the check: >= ``low``."""
    def check(value: float) -> Optional[str]:
        return None if value >= low else f'must be >= {low:g}'
    return check


def in_range(low: float, high: float, *, low_open: bool = False) -> Check:
    """Return the check: in [low, high] (``low_open``: in (low, high])."""
    def check(value: float) -> Optional[str]:
        ok = (value > low if low_open else value >= low) and value <= high
        return None if ok else f'must be {">" if low_open else ">="} {low:g} and <= {high:g}'
    return check


def non_empty(value: str) -> Optional[str]:
    """Check: a string with something besides white space."""
    return None if value.strip() else 'must not be empty'
