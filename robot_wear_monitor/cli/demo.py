"""``robot-wear-monitor demo``: simulate an accelerated wear test, replay it, write a report."""

from __future__ import annotations

import argparse
import sys

from robot_wear_monitor.cli.options import add_progress, progress_wanted
from robot_wear_monitor.errors import InputError

HELP = 'simulate an accelerated wear test, replay it and write a report'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``demo``."""
    parser.add_argument('--out', metavar='DIR', default='wear_demo',
                        help='report folder (default ./wear_demo)')
    parser.add_argument('--experiments', type=int, default=100,
                        help='number of simulated experiments (default 100)')
    parser.add_argument('--seed', type=int, default=0, help='random seed (default 0)')
    add_progress(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``demo``: the report folder ``--out``, its description on stdout."""
    # deferred import: start-up time (numpy, rosbags: not for --help)
    from robot_wear_monitor.reporting.demo import describe, run_demo
    if args.experiments < 1:
        raise InputError(f'--experiments must be >= 1, got {args.experiments}')
    summary = run_demo(out_dir=args.out, n_experiments=args.experiments, seed=args.seed,
                       progress=progress_wanted(args),
                       log=lambda text: print(text, file=sys.stderr))
    print(describe(summary, args.out))
    return 0
