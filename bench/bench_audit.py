"""
Audit time on 500 and on 20 000 friction levels; optionally FDR and power (prints only).

Levels: the generator of the audit tests (``test/audit/effect_generator.py``: experiments of the
12 speeds of eq. (27) at one temperature, load and set of undeclared columns each, level error
N(0, 4.23e-3)), with the periodic position effect at the noise std, model (5) audited.

``--power`` also measures, over ``--seeds`` random tables of 504 levels each (42 experiments):

* the false-discovery rate on clean data (share of tables where any effect is added);
* the detection power per effect kind and size (RMS of the effect in units of the noise std):
  share of tables where the effect's variables are named, and no decoy.

Usage: ``python3 bench/bench_audit.py [--power] [--seeds 20]``.
"""

import argparse
from pathlib import Path
import sys
import time


sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))  # wear_testing
from robot_wear_monitor.audit.data import table_from_columns  # noqa: E402
from robot_wear_monitor.audit.run import run_audit  # noqa: E402
from wear_testing.effect_generator import DECOYS, EFFECTS, levels, SIGMA, with_effect  # noqa: E402

SIZES = (0.25, 0.5, 1.0)


def timing() -> None:
    """Print the audit time (no estimates) on about 500 and 20 000 levels."""
    effect = EFFECTS['periodic in position'][0]
    for n_experiments in (42, 1667):
        columns = with_effect(levels(seed=0, n_experiments=n_experiments), effect, 1.0)
        table = table_from_columns(columns, model='nominal')
        start = time.perf_counter()
        result = run_audit(table=table, model='nominal', estimate=False)
        seconds = time.perf_counter() - start
        print(f'audit of model (5) on {table.n_rows:6d} levels: {seconds:6.2f} s '
              f'({len(result.candidates)} candidate columns, effects: '
              f'{", ".join(e.name for e in result.effects) or "none"}; held-out RMS '
              f'{result.rms_after / SIGMA:.3f} x noise std)')


def power(seeds: int) -> None:
    """Print the measured false-discovery rate and the detection-power table."""
    false = 0
    for seed in range(seeds):
        columns = levels(seed=5000 + seed)
        columns.pop('clean')
        result = run_audit(table=table_from_columns(columns, model='nominal'),
                           model='nominal', estimate=False)
        false += bool(result.effects)
    print(f'clean data: {false} of {seeds} tables with a discovery '
          f'(false-discovery rate {false / seeds:.1%})')
    print('| effect kind | ' + ' | '.join(f'{s:g} sigma' for s in SIZES) + ' |')
    print('|---|' + '---|' * len(SIZES))
    for kind, (effect, expected) in EFFECTS.items():
        model = 'complete' if 'wear' in expected else 'nominal'
        cells = []
        for size in SIZES:
            found = 0
            for seed in range(seeds):
                columns = with_effect(levels(seed=7000 + seed, wear=model == 'complete'),
                                      effect, size)
                result = run_audit(table=table_from_columns(columns, model=model),
                                   model=model, estimate=False)
                named = {v for e in result.effects for v in e.variables}
                found += expected <= named and not named & set(DECOYS)
            cells.append(f'{found / seeds:.0%}')
        print(f'| {kind} | ' + ' | '.join(cells) + ' |', flush=True)


def main() -> None:
    """Run the timing, and the FDR/power measurement with ``--power``."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--power', action='store_true', help='also measure FDR and power')
    parser.add_argument('--seeds', type=int, default=20, help='tables per cell (default 20)')
    args = parser.parse_args()
    timing()
    if args.power:
        power(args.seeds)


if __name__ == '__main__':
    main()
