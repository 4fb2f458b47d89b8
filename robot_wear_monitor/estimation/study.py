"""
Monte Carlo study of the wear estimators, Sec. IV-C and Fig. 8 of the paper.

For every true temperature T and R runs, friction levels are simulated with the data model (9):
tau_f(v_i, tl, T, w) + e_i, with one true load tl ~ N(mu_tl, sigma_tl^2) per run (shared by the N
levels of the run) and e_i ~ N(0, sigma^2).  Each run is estimated with
:func:`.estimation.estimate_wear` (vectorised), and the bias, variance and MSE of w-hat per
temperature are reported beside the Cramer-Rao bound: [F^-1]_22 at (T, w) for N >= 2, 1/F of the
marginal likelihood for N = 1.
"""

from __future__ import annotations

from dataclasses import dataclass
import sys
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.atomic_files import save_figure
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.design import design_cost
from robot_wear_monitor.estimation.estimator import estimate_wear
from robot_wear_monitor.estimation.wear_estimates import validate_speeds
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import ParameterSet


_ROWS_PER_CALL = 4000  # estimates per call of the estimator (progress granularity)


@dataclass(frozen=True)
class StudyResult:
    """
    Bias, variance and MSE of w-hat per true temperature, with the Cramer-Rao bound.

    :ivar n: number of levels N.
    :ivar speeds_rad_s: the speed levels [rad/s], shape (N,).
    :ivar wear: the true wear level w.
    :ivar temperatures_degc: the true temperatures [degC], shape (K,).
    :ivar runs: Monte Carlo runs R per temperature.
    :ivar seed: seed of the numpy Generator.
    :ivar mean: mean of w-hat, shape (K,).
    :ivar bias: mean of w-hat minus w, shape (K,).
    :ivar variance: sample variance of w-hat (ddof = 1), shape (K,).
    :ivar mse: mean of (w-hat - w)^2, shape (K,).
    :ivar crb: Cramer-Rao bound of w, shape (K,).
    :ivar temperature_at_bound: fraction of runs with T-hat on a bound, shape (K,).
    :ivar wear_at_bound: fraction of runs with w-hat = 0, shape (K,).

    """

    n: int
    speeds_rad_s: FloatArray
    wear: float
    temperatures_degc: FloatArray
    runs: int
    seed: int
    mean: FloatArray
    bias: FloatArray
    variance: FloatArray
    mse: FloatArray
    crb: FloatArray
    temperature_at_bound: FloatArray
    wear_at_bound: FloatArray

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (lists of floats; non-finite values as None)."""
        def clean(values: ArrayLike) -> list:
            return [float(x) if np.isfinite(x) else None for x in np.asarray(values, dtype=float)]

        return {'n': self.n, 'speeds': clean(self.speeds_rad_s), 'wear': self.wear,
                'runs': self.runs, 'seed': self.seed,
                'temperatures': clean(self.temperatures_degc), 'mean': clean(self.mean),
                'bias': clean(self.bias), 'variance': clean(self.variance),
                'mse': clean(self.mse), 'crb': clean(self.crb),
                'temperature_at_bound': clean(self.temperature_at_bound),
                'wear_at_bound': clean(self.wear_at_bound)}


def simulate_friction(*, speeds_rad_s: ArrayLike, temperature_degc: float, wear: float,
                      runs: int, rng: np.random.Generator, params: ParameterSet) -> FloatArray:
    """
    Simulate R friction vectors with the data model (9), shape (R, N).

    One true load tl ~ N(load_mean, load_std^2) per run, shared by its N levels; independent
    errors N(0, sigma^2) per level.
    """
    speeds = validate_speeds(speeds_rad_s)
    loads = rng.normal(params.load_mean, params.load_std, size=runs)
    noise = params.sigma * rng.standard_normal((runs, speeds.size))
    return fm.friction(speeds[None, :], loads[:, None], temperature_degc, wear,
                       params.model) + noise


def cramer_rao_bound(*, speeds_rad_s: ArrayLike, temperatures_degc: ArrayLike, wear: float,
                     params: ParameterSet) -> FloatArray:
    """
    Return the Cramer-Rao bound of w-hat at every temperature, shape (K,).

    N >= 2: [F^-1]_22 of (22)-(23) at (T, w).  N = 1: 1/F of the marginal likelihood (17),
    which does not depend on T.
    """
    speeds = validate_speeds(speeds_rad_s)
    temps = np.atleast_1d(np.asarray(temperatures_degc, dtype=float))
    if speeds.size == 1:
        value = float(design_cost(speeds_rad_s=speeds, params=params, wear=wear))
        return np.full(temps.shape, value)
    return np.array([float(design_cost(speeds_rad_s=speeds, params=params, temperature_degc=t,
                                       wear=wear)) for t in temps])


def run_study(*, speeds_rad_s: ArrayLike, temperatures_degc: ArrayLike, wear: float,
              runs: int, seed: int, params: ParameterSet, progress: bool | None = None
              ) -> StudyResult:
    """
    Run the Monte Carlo study of Sec. IV-C for one speed set.

    :param speeds_rad_s: the N speed levels [rad/s].
    :param temperatures_degc: true temperatures [degC], shape (K,).
    :param wear: true wear level w.
    :param runs: Monte Carlo runs R per temperature (>= 2).
    :param seed: seed of the numpy Generator (the data of a temperature do not depend on N's
        chunking: all data are drawn first, temperature by temperature).
    :param params: the parameter set.
    :param progress: show a tqdm bar on stderr (default: only when stderr is a terminal).

    :raises InputError: runs < 2, no temperatures, non-finite temperatures, bad speeds.

    """
    speeds = validate_speeds(speeds_rad_s)
    temps = np.atleast_1d(np.asarray(temperatures_degc, dtype=float))
    if isinstance(runs, bool) or int(runs) != runs or runs < 2:
        raise InputError(f'runs: need an integer >= 2 Monte Carlo runs, got {runs!r}')
    if temps.size == 0 or not np.all(np.isfinite(temps)):
        raise InputError(f'temperatures: need finite temperatures, got {temps.tolist()}')
    if not np.isfinite(wear) or wear < 0:
        raise InputError(f'wear: the true wear must be finite and >= 0, got {wear}')
    runs = int(runs)
    rng = np.random.default_rng(seed)
    data = np.concatenate([simulate_friction(speeds_rad_s=speeds, temperature_degc=t, wear=wear,
                                             runs=runs, rng=rng, params=params) for t in temps])
    if progress is None:
        progress = sys.stderr.isatty()
    # deferred import: start-up time (tqdm: a study run only)
    from tqdm import tqdm
    wear_hat = np.empty(data.shape[0])
    t_bound = np.empty(data.shape[0], dtype=bool)
    w_bound = np.empty(data.shape[0], dtype=bool)
    with tqdm(total=data.shape[0], disable=not progress, file=sys.stderr, unit='fit',
              desc=f'study N={speeds.size}') as bar:
        for start in range(0, data.shape[0], _ROWS_PER_CALL):
            stop = min(start + _ROWS_PER_CALL, data.shape[0])
            batch = estimate_wear(speeds, data[start:stop], params=params)
            wear_hat[start:stop] = batch.wear
            t_bound[start:stop] = batch.temperature_at_bound
            w_bound[start:stop] = batch.wear_at_bound
            bar.update(stop - start)
    wear_grid = wear_hat.reshape(temps.size, runs)
    error = wear_grid - wear
    return StudyResult(
        n=speeds.size, speeds_rad_s=speeds, wear=float(wear), temperatures_degc=temps,
        runs=runs, seed=seed, mean=wear_grid.mean(axis=1), bias=error.mean(axis=1),
        variance=wear_grid.var(axis=1, ddof=1), mse=np.mean(error ** 2, axis=1),
        crb=cramer_rao_bound(speeds_rad_s=speeds, temperatures_degc=temps, wear=wear,
                             params=params),
        temperature_at_bound=t_bound.reshape(temps.size, runs).mean(axis=1),
        wear_at_bound=w_bound.reshape(temps.size, runs).mean(axis=1))


def plot_study(results: Sequence[StudyResult], *, path: str) -> None:
    """
    Draw bias and variance of w-hat against T, one line per N, like Fig. 8; save to path.

    The Cramer-Rao bound of every N is drawn dashed in the variance panel.
    """
    # deferred import: start-up time (matplotlib: only when a figure is drawn)
    import matplotlib
    matplotlib.use('Agg')
    # deferred import: start-up time (matplotlib: only when a figure is drawn)
    import matplotlib.pyplot as plt

    fig, (ax_bias, ax_var) = plt.subplots(1, 2, figsize=(10, 4))
    for result in results:
        label = f'N = {result.n}'
        line, = ax_bias.plot(result.temperatures_degc, result.bias, marker='.', label=label)
        ax_var.plot(result.temperatures_degc, result.variance, marker='.', color=line.get_color(),
                    label=label)
        ax_var.plot(result.temperatures_degc, result.crb, linestyle='--', color=line.get_color(),
                    label=f'CRB, N = {result.n}')
    ax_bias.axhline(0.0, color='0.6', linewidth=0.8)
    ax_bias.set(xlabel='true temperature T [degC]', ylabel='bias of w-hat',
                title=f'(a) bias, w = {results[0].wear:g}' if results else '(a) bias')
    ax_var.set(xlabel='true temperature T [degC]', ylabel='variance of w-hat',
               title='(b) variance (dashed: Cramer-Rao bound)')
    ax_bias.legend()
    ax_var.legend(fontsize='small', ncol=2)
    fig.tight_layout()
    try:
        save_figure(fig, path, dpi=120)
    finally:
        plt.close(fig)
