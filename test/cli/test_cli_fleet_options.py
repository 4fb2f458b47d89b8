"""
The options of fleet, notify and dashboard are made from their declared settings.

Each option of :data:`robot_wear_monitor.cli.fleet_options.DECLARED_OPTIONS` has the declared
default, says the unit and the default in its help, refuses a value outside the declared range
with one line naming the option (exit 2), and means the same in every verb that takes it.
docs/command-line.md states the same defaults, units and ranges (and the gear ratio's and
torque scale's defaults are the node configuration's and the raw-run settings').
"""

import argparse
import re

import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.cli import options
from robot_wear_monitor.cli.fleet_options import DECLARED_OPTIONS
from robot_wear_monitor.experiment.segmentation_settings import NODE_SCALES, RAW_RUN_SETTINGS
from robot_wear_monitor.setting_fields import setting_of
from wear_testing import docs_settings


def _options_of(verb):
    parser = cli.build_parser([verb])
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {flag: action for action in sub.choices[verb]._actions
            for flag in action.option_strings}


@pytest.mark.parametrize('verb', sorted(DECLARED_OPTIONS))
def test_each_option_has_the_declared_default_unit_and_text(verb):
    made = _options_of(verb)
    for flag, owner, name in DECLARED_OPTIONS[verb]:
        declared, action = setting_of(owner, name), made[flag]
        assert action.default == declared.default, (verb, flag)
        assert declared.description in action.help, (verb, flag)
        if declared.unit not in ('', '-'):
            assert f'[{declared.unit}]' in action.help, (verb, flag)
        shown = f'{declared.default:g}' if isinstance(declared.default, float) \
            else str(declared.default)
        assert f'(default: {shown})' in action.help, (verb, flag)


def test_one_meaning_per_setting_across_the_verbs():
    """``notify --interval-s`` and ``dashboard --notify-interval-s`` are one setting."""
    made = {}
    for verb, declared in DECLARED_OPTIONS.items():
        for flag, owner, name in declared:
            made.setdefault((owner, name), []).append((verb, flag))
    interval = [uses for (owner, name), uses in made.items() if name == 'interval_s']
    assert interval == [[('notify', '--interval-s'), ('dashboard', '--notify-interval-s')]]
    notify, dashboard = _options_of('notify'), _options_of('dashboard')
    for text in ('1', '86400', '7.5'):
        assert notify['--interval-s'].type(text) == dashboard['--notify-interval-s'].type(text)


@pytest.mark.parametrize('argv, message', [
    (['notify', '--history', 'h.db', '--interval-s', '0'],
     'argument --interval-s: must be >= 1 and <= 86400 s, got 0 s'),
    (['dashboard', '--history', 'h.db', '--notify-interval-s', '0.5'],
     'argument --notify-interval-s: must be >= 1 and <= 86400 s, got 0.5 s'),
    (['dashboard', '--history', 'h.db', '--port', '70000'],
     'argument --port: must be >= 1 and <= 65535, got 70000'),
    (['dashboard', '--history', 'h.db', '--header-timeout-s', 'nan'],
     'argument --header-timeout-s: expected a finite number (must be >= 0.5 and <= 600) s, '
     'got nan s'),
    (['dashboard', '--history', 'h.db', '--host', ' '],
     "argument --host: must not be empty, got ' '"),
    (['fleet', '--history', 'h.db', '--forecast-horizon-days', '-1'],
     'argument --forecast-horizon-days: must be >= 0 and <= 3650 days, got -1 days'),
    (['fleet', '--history', 'h.db', '--reescalation-margin', '0'],
     'argument --reescalation-margin: must be > 0 and <= 100 wear units, got 0 wear units'),
])
def test_a_value_out_of_the_declared_range_is_one_line_naming_the_option(argv, message,
                                                                         capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count('\n') == 1, err


def _row(rows, flag):
    return next(row for row in rows if f'`{flag} ' in row[0] + ' ' or f'`{flag}`' in row[0])


def test_the_command_line_page_states_the_declared_defaults_units_and_ranges():
    rows = docs_settings.table(docs_settings.DOCS / 'command-line.md', '| option | meaning |')
    compared = 0
    for verb in ('fleet', 'notify'):
        for flag, owner, name in DECLARED_OPTIONS[verb]:
            declared = setting_of(owner, name)
            flags_cell, meaning = _row(rows, flag)
            flags = re.findall(r'`(--[a-z-]+)', flags_cell)
            # a row of several options: the k-th "(default ...)" is the k-th option's
            parts = re.findall(r'\[[^\]]+\] \(default [^)]*\)', meaning)
            part = parts[flags.index(flag)] if len(parts) == len(flags) else parts[0]
            assert docs_settings.same_default(declared, docs_settings.stated_default(part)), \
                (flag, part)
            assert f'[{declared.unit}]' in part, (flag, declared.unit)
            [stated] = docs_settings.stated_ranges(part)
            docs_settings.check_range(declared, stated)
            compared += 1
    assert compared == 3
    gear, scale = _row(rows, '--gear-ratio')[1], _row(rows, '--torque-scale')[1]
    assert f'{NODE_SCALES["gear_ratio"]:g} in the packaged one' in gear
    assert f'a level table {RAW_RUN_SETTINGS["gear_ratio"]:g} (the raw-run settings)' in gear
    assert (f'{NODE_SCALES["torque_scale"]:g} in the packaged config; '
            f'{RAW_RUN_SETTINGS["torque_scale"]:g} for a raw run') in scale
    # the example error of the page is the option's own
    example = re.search(r'`argument --gear-ratio: (must be [^`]+), got 1e300`',
                        (docs_settings.DOCS / 'command-line.md').read_text())
    with pytest.raises(argparse.ArgumentTypeError, match=re.escape(example.group(1))):
        options.GEAR_RATIO('1e300')
