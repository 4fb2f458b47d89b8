"""
Benchmark: vectorised wear estimator vs a per-fit scipy loop, and the Sec. IV-C study.

Run as ``python3 bench/bench_estimation.py``.  Prints figures only (no assertions on time):

* ML estimates per second of :func:`estimate_wear` (one call, a batch of B fits, N = 3) against a
  plain loop of ``scipy.optimize.least_squares(bounds=...)`` (one fit per call, started from the
  best point of a coarse 5 x 7 grid like the paper's lsqnonlin); the loop is timed on a sample
  of fits and extrapolated; the accuracy is compared by max |w difference| and by how often
  each finds a lower cost (16);
* the wall time of the full study: 21 temperatures x 1000 runs x N = 1..4 (Table IV speeds).
"""

from __future__ import annotations

from pathlib import Path
import sys
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robot_wear_monitor.estimation.estimator import estimate_wear  # noqa: E402
from robot_wear_monitor.estimation.study import run_study  # noqa: E402
from robot_wear_monitor.model import friction as fm  # noqa: E402
from robot_wear_monitor.model.params import load_parameter_set  # noqa: E402
from scipy import optimize  # noqa: E402

TABLE_IV = {1: [38.63], 2: [35.84, 40.84], 3: [33.68, 38.68, 43.68],
            4: [31.65, 36.65, 41.65, 46.65]}


def scipy_fit(speeds, friction, whiten, params):
    """One ML fit of (16) with scipy least_squares from the best point of a coarse grid."""
    yw = whiten @ friction

    def residual(x):
        return yw - whiten @ fm.friction(speeds, params.load_mean, x[0], x[1], params.model)

    grid = [(t, w) for t in np.linspace(30, 50, 5) for w in np.linspace(0, 120, 7)]
    x0 = min(grid, key=lambda x: float(np.sum(residual(x) ** 2)))
    fit = optimize.least_squares(residual, x0, bounds=([params.temperature_min_degc, 0.0],
                                                       [params.temperature_max_degc, np.inf]),
                                 xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return fit.x, 2.0 * fit.cost


def main() -> None:
    """Run the benchmark and print the figures."""
    params = load_parameter_set()
    rng = np.random.default_rng(0)
    speeds = np.array(TABLE_IV[3])
    batch = 21000
    t_true = rng.uniform(30, 50, batch)
    loads = rng.normal(params.load_mean, params.load_std, batch)
    y = (fm.friction(speeds[None], loads[:, None], t_true[:, None], 35.0, params.model)
         + params.sigma * rng.standard_normal((batch, speeds.size)))

    start = time.perf_counter()
    est = estimate_wear(speeds, y, params=params)
    vectorised_s = time.perf_counter() - start

    cov = fm.marginal_covariance(speeds, sigma=params.sigma, load_std=params.load_std,
                                 model=params.model)
    whiten = np.linalg.inv(np.linalg.cholesky(cov))
    sample = 300
    start = time.perf_counter()
    fits = [scipy_fit(speeds, y[i], whiten, params) for i in range(sample)]
    loop_s = time.perf_counter() - start
    w_scipy = np.array([x[1] for x, _ in fits])
    c_scipy = np.array([c for _, c in fits])
    dw = np.abs(w_scipy - est.wear[:sample])
    ours_better = int(np.sum(est.chi2[:sample] < c_scipy - 1e-9))
    scipy_better = int(np.sum(c_scipy < est.chi2[:sample] - 1e-9))

    rate_vec = batch / vectorised_s
    rate_loop = sample / loop_s
    print(f'ML estimates, N = 3, B = {batch}')
    print(f'  vectorised estimate_wear     {rate_vec:10.0f} fits/s  ({vectorised_s:.2f} s)')
    print(f'  scipy least_squares loop     {rate_loop:10.0f} fits/s  ({loop_s:.2f} s for '
          f'{sample}; {batch / rate_loop:.0f} s extrapolated to {batch})')
    print(f'  speed-up                     {rate_vec / rate_loop:10.1f} x')
    same = dw[np.abs(est.chi2[:sample] - c_scipy) <= 1e-9]
    print(f'  max |w difference| where both reach the same cost: {same.max():.2e} '
          f'({same.size}/{sample} fits)')
    print(f'  max |w difference| overall: {dw.max():.2e}; lower cost (16) found by: '
          f'vectorised {ours_better}, scipy {scipy_better} of {sample}')

    print('Monte Carlo study of Sec. IV-C: 21 temperatures x 1000 runs, w = 35')
    total = 0.0
    for n, v in TABLE_IV.items():
        start = time.perf_counter()
        result = run_study(speeds_rad_s=v, temperatures_degc=np.linspace(30, 50, 21), wear=35.0,
                           runs=1000, seed=n, params=params, progress=False)
        elapsed = time.perf_counter() - start
        total += elapsed
        print(f'  N = {n}: {elapsed:5.2f} s   bias {result.bias.min():+.2f}..'
              f'{result.bias.max():+.2f}   variance {result.variance.min():.1f}..'
              f'{result.variance.max():.1f}   CRB at 40 degC {result.crb[10]:.2f}')
    print(f'  whole study (N = 1..4): {total:.2f} s')


if __name__ == '__main__':
    main()
