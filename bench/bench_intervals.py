"""
Benchmark: profile-likelihood intervals and likelihood rows (estimation/intervals.py).

Run as ``python3 bench/bench_intervals.py``.  Prints figures of one run only (no assertions):

* intervals per second of :func:`wear_intervals` for a batch of 10 000 experiments at the
  paper's N = 4 design [2.1, 28.5, 35.1, 41.7] and N = 2 design [35.1, 41.7] rad/s (and N = 1 at
  35.1), both including the ML estimate (``estimate_wear``) and given it;
* rows per second of :func:`profile_log_likelihood` on the default wear grid (321 points);
* the time of the cutoff calibration (:func:`calibrate_cutoffs`), paid once per design and
  process (cached; the interval figures above exclude it).
"""

from __future__ import annotations

from pathlib import Path
import sys
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robot_wear_monitor.estimation.estimator import estimate_wear  # noqa: E402
from robot_wear_monitor.estimation.intervals import (calibrate_cutoffs,  # noqa: E402
                                                     profile_log_likelihood, wear_grid,
                                                     wear_intervals)
from robot_wear_monitor.model import friction as fm  # noqa: E402
from robot_wear_monitor.model.params import load_parameter_set  # noqa: E402

DESIGNS = {4: [2.1, 28.5, 35.1, 41.7], 2: [35.1, 41.7], 1: [35.1]}
BATCH = 10_000


def simulate(speeds: np.ndarray, params, rng: np.random.Generator) -> np.ndarray:
    """Return (BATCH, N) friction levels: w in [0, 80], T in [30, 50], load N(0.5, 0.1)."""
    wear = rng.uniform(0.0, 80.0, (BATCH, 1))
    temps = rng.uniform(30.0, 50.0, (BATCH, 1))
    load = rng.normal(0.5, 0.1, (BATCH, 1))
    y = fm.friction(speeds[None, :], load, temps, wear, params.model)
    return y + params.sigma * rng.standard_normal(y.shape)


def main() -> None:
    """Run the benchmark and print the figures."""
    params = load_parameter_set()
    rng = np.random.default_rng(0)
    grid = wear_grid(params.wear_max)
    print(f'batch of {BATCH} experiments, wear grid of {grid.size} points')
    for n_levels, speeds in DESIGNS.items():
        v = np.asarray(speeds)
        y = simulate(v, params, rng)
        start = time.perf_counter()
        calibrate_cutoffs(v, params=params)
        t_cal = time.perf_counter() - start
        start = time.perf_counter()
        est = estimate_wear(v, y, params=params)
        t_est = time.perf_counter() - start
        start = time.perf_counter()
        wear_intervals(v, y, params=params, estimates=est)
        t_int = time.perf_counter() - start
        start = time.perf_counter()
        rows = profile_log_likelihood(v, y, params=params, wear_grid=grid)
        t_rows = time.perf_counter() - start
        assert rows.shape == (BATCH, grid.size)
        print(f'N = {n_levels} {speeds}:')
        print(f'  wear_intervals incl. estimate_wear  {BATCH / (t_est + t_int):10.0f} /s')
        print(f'  wear_intervals given the estimates  {BATCH / t_int:10.0f} /s')
        print(f'  profile_log_likelihood rows         {BATCH / t_rows:10.0f} /s')
        print(f'  calibrate_cutoffs (once per design) {t_cal:10.2f} s')


if __name__ == '__main__':
    main()
