"""The ``robot-wear-monitor`` command line: the only place that parses argv.

Each subcommand has an ``_add_<name>_arguments(parser)`` and a ``_cmd_<name>(args) -> int``; the
work itself is done by keyword-only functions of the core modules.  A user mistake raises
:class:`~robot_wear_monitor.errors.InputError`, which ``main`` prints as one line on stderr with
exit code 2 (never a traceback).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Callable, Sequence

from . import __version__
from .errors import InputError
from .params import load_parameter_set, ParameterSet

PROG = 'robot-wear-monitor'


# --------------------------------------------------------------------------- shared helpers

def parse_float_list(text: str) -> list[float]:
    """Parse '2.1,8.7,15.3' into floats (argparse type); reject empty items, NaN and inf."""
    items = [item.strip() for item in text.split(',')]
    values = []
    for item in items:
        try:
            value = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(f'not a number: {item!r} in {text!r}') from None
        if value != value or value in (float('inf'), float('-inf')):
            raise argparse.ArgumentTypeError(f'not a finite number: {item!r} in {text!r}')
        values.append(value)
    return values


def parse_range(text: str) -> list[float]:
    """Parse 'start:stop:step' (inclusive stop) or a comma list into floats (argparse type)."""
    if ':' not in text:
        return parse_float_list(text)
    parts = text.split(':')
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f'expected start:stop:step, got {text!r}')
    start, stop, step = parse_float_list(','.join(parts))
    if step <= 0 or stop < start:
        raise argparse.ArgumentTypeError(f'expected start <= stop and step > 0, got {text!r}')
    count = int(round((stop - start) / step)) + 1
    return [start + i * step for i in range(count)]


def _params_from(args: argparse.Namespace) -> ParameterSet:
    return load_parameter_set(getattr(args, 'params', None))


def _print_json(payload: object) -> None:
    json.dump(payload, sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write('\n')


def _add_params_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--params', metavar='FILE',
                        help='parameter-set YAML (default: the packaged IRB 6620 joint 2 set)')


# --------------------------------------------------------------------------- design / estimate /
# study (core: design.py, estimation.py, study.py)

def _add_design_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--n', type=int, required=True, help='number of speed levels N (>= 1)')
    parser.add_argument('--grid', type=parse_float_list, metavar='V1,V2,...',
                        help='choose the best N speeds from this grid [rad/s] (Table V); '
                             'default: continuous optimum within the design bounds (Table IV)')
    parser.add_argument('--temperature', type=float, metavar='DEGC',
                        help='design temperature [degC] (default: from the parameter set)')
    parser.add_argument('--wear', type=float, metavar='W',
                        help='design wear level (default: from the parameter set)')
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _cmd_design(args: argparse.Namespace) -> int:
    raise InputError('design: not implemented yet')


def _add_estimate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--speeds', type=parse_float_list, required=True, metavar='V1,V2,...',
                        help='motor-side speed levels [rad/s]')
    parser.add_argument('--friction', type=parse_float_list, required=True, metavar='F1,F2,...',
                        help='friction levels (normalised torque), one per speed')
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _cmd_estimate(args: argparse.Namespace) -> int:
    raise InputError('estimate: not implemented yet')


def _add_study_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--n', type=int, required=True, help='number of speed levels N (>= 1)')
    parser.add_argument('--speeds', type=parse_float_list, metavar='V1,V2,...',
                        help='speed levels [rad/s] (default: the optimal design for N)')
    parser.add_argument('--temperatures', type=parse_range, default=parse_range('30:50:1'),
                        metavar='START:STOP:STEP', help='true temperatures [degC] (default 30:50:1)')
    parser.add_argument('--wear', type=float, default=35.0, help='true wear level (default 35)')
    parser.add_argument('--runs', type=int, default=1000, help='Monte Carlo runs per temperature')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    _add_params_argument(parser)
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--plot', metavar='PNG', help='draw bias and variance like Fig. 8')


def _cmd_study(args: argparse.Namespace) -> int:
    raise InputError('study: not implemented yet')


# --------------------------------------------------------------------------- simulate
# (simulation.py, bags.py)

def _add_simulate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', required=True, metavar='BAG', help='output bag directory')


def _cmd_simulate(args: argparse.Namespace) -> int:
    raise InputError('simulate: not implemented yet')


# --------------------------------------------------------------------------- replay / demo
# (replay.py, service.py, report.py)

def _add_replay_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', metavar='BAG', help='recorded ROS 2 bag (MCAP or sqlite3)')
    parser.add_argument('--out', required=True, metavar='OUT_BAG', help='output bag directory')


def _cmd_replay(args: argparse.Namespace) -> int:
    raise InputError('replay: not implemented yet')


def _add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', metavar='DIR', default='wear_demo',
                        help='report folder (default ./wear_demo)')


def _cmd_demo(args: argparse.Namespace) -> int:
    raise InputError('demo: not implemented yet')


# --------------------------------------------------------------------------- audit (audit.py)

def _add_audit_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('data', metavar='DATA', help='friction-level CSV, bag or raw runs')


def _cmd_audit(args: argparse.Namespace) -> int:
    raise InputError('audit: not implemented yet')


# --------------------------------------------------------------------------- entry point

_COMMANDS: dict[str, tuple[str, Callable, Callable]] = {
    'design': ('optimal speed levels for N friction levels, eqs. (22)-(25)',
               _add_design_arguments, _cmd_design),
    'estimate': ('estimate temperature and wear from friction levels, eqs. (16)-(19)',
                 _add_estimate_arguments, _cmd_estimate),
    'study': ('Monte Carlo bias/variance study of the wear estimator (Sec. IV-C, Fig. 8)',
              _add_study_arguments, _cmd_study),
    'simulate': ('simulate friction experiments of a wearing joint into a ROS 2 bag',
                 _add_simulate_arguments, _cmd_simulate),
    'replay': ('replay a recorded bag through the monitoring service',
               _add_replay_arguments, _cmd_replay),
    'demo': ('simulate an accelerated wear test, replay it and write a report',
             _add_demo_arguments, _cmd_demo),
    'audit': ('find and model what the friction model misses in measured friction levels',
              _add_audit_arguments, _cmd_audit),
}


def build_parser() -> argparse.ArgumentParser:
    """Return the argparse parser of ``robot-wear-monitor`` with all its subcommands."""
    parser = argparse.ArgumentParser(
        prog=PROG, description='Wear monitoring of a robot joint from constant-speed friction '
                               'data (Bittencourt & Axelsson).')
    parser.add_argument('--version', action='version', version=f'%(prog)s {__version__}')
    subparsers = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for name, (help_text, add_arguments, handler) in _COMMANDS.items():
        sub = subparsers.add_parser(name, help=help_text, description=help_text)
        add_arguments(sub)
        sub.set_defaults(handler=handler)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code (0 success, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)  # argparse exits with 2 and a usage line on bad syntax
    try:
        return int(args.handler(args) or 0)
    except InputError as error:
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        print(f'{PROG} {args.command}: error: {message}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'{PROG} {args.command}: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
