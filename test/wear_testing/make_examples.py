"""
Write the example level tables under ``examples/``.

Run: ``PYTHONPATH=test python3 -m wear_testing.make_examples``.

The tables come from the independent generator's model functions (``independent_robot.py``,
which shares no code with the package) for a joint that differs from the packaged set, with
its truth, so that ``identify`` and ``audit --model nominal`` have something to run on as the
README shows.  ``test/test_examples.py`` checks that the shipped files are what this writes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from wear_testing import independent_robot as robot

EXAMPLES = Path(__file__).resolve().parents[2] / 'examples'
#: Motor-side speeds of every experiment [rad/s]: Table V's grid and beyond.
GRID = (2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1)
#: The example joint: the paper's coefficients with a stronger load effect and wear profile.
JOINT = {**robot.PAPER_PARAMETERS, 'F_ctl': 0.05, 'F_stl': 0.2, 'phi_stl': 12.0,
         'F_sw': 1.1e-3, 'phi_sw': 2.6}
#: std of the friction-level error [normalised torque].
SIGMA = 4.23e-3
#: The critical experiment of the wear test (w = 35 there).
CRITICAL = 15


def _table(*, seed: int, wears: np.ndarray, temperature: tuple[float, float],
           loads: tuple[float, float]) -> str:
    rng = np.random.default_rng(seed)
    speeds = np.asarray(GRID)
    lines = ['experiment,speed,friction,temperature,load,true_wear']
    for k, wear in enumerate(wears):
        t, load = rng.uniform(*temperature), rng.uniform(*loads)
        friction = robot.friction_model(speeds, load, t, wear, JOINT) + rng.normal(
            0.0, SIGMA, speeds.size)
        lines += [f'{k},{v:g},{f:.6f},{t:.3f},{load:.4f},{wear:.3f}'
                  for v, f in zip(speeds, friction)]
    return '\n'.join(lines) + '\n'


def example_files() -> dict[str, str]:
    """Return the example files' names and texts (deterministic)."""
    wears = 35.0 * (np.arange(20) / CRITICAL) ** 2
    truth = ['# The truth of the example tables (test/wear_testing/make_examples.py, '
             'independent generator).',
             '# Friction model (8) = (5) + (7) with these coefficients (paper notation):']
    truth += [f'{name}: {value:g}' for name, value in JOINT.items()]
    truth += [f'sigma: {SIGMA:g}   # std of the friction-level error [normalised]',
              f'critical_experiment: {CRITICAL}   # w = 35 in wear_test.csv',
              'wear_per_experiment: [' + ', '.join(f'{w:.3f}' for w in wears) + ']']
    return {
        'baseline.csv': _table(seed=0, wears=np.zeros(30), temperature=(30.0, 50.0),
                               loads=(0.1, 0.9)),
        'wear_test.csv': _table(seed=1, wears=wears, temperature=(38.0, 42.0),
                                loads=(0.45, 0.55)),
        'truth.yaml': '\n'.join(truth) + '\n',
    }


def main() -> None:
    """Write the files under ``examples/``."""
    EXAMPLES.mkdir(exist_ok=True)
    for name, text in example_files().items():
        (EXAMPLES / name).write_text(text, encoding='utf-8')


if __name__ == '__main__':
    main()
