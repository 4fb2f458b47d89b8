"""
Benchmark: the trend alarm P(w >= 35 | data) >= p against the paper's w-hat >= 35.

Run as ``python3 bench/bench_alarm.py [--runs 100] [--seed 0] [--sweep]``.  Prints a markdown
table; no assertions.  About 40 s on 2 idle cores with the default 100 runs.

Simulated accelerated wear tests (Sec. V of the paper).  Wear is a function of the time in
nominal experiments tau = t / 3600 s; experiments are 3600 s x U(0.5, 1.5) apart (irregular), and
the test runs K = 110 experiments (the paper's 100 and 10 more, so that every crossing of 35 is
followed by >= 10 experiments).  Amplitude 100 % is w = 70 at k = 99 (scenario 0), so that the
paper's observation holds that a threshold at 35 detects scenarios 0 and 1:

* ``0 late exp``: w = 1 + 69 exp((tau - 99) / 6), small variations (sd 0.5): about 1 up to
  tau = 85, crosses 35 at tau = 94.8;
* ``1 rise 56%``: w = 2 + 37.2 / (1 + exp(-(tau - 80) / 3.5)), medium variations (sd 1.5): about
  2 up to tau = 70, a large rise to 56 % (w = 39.2), crosses 35 at tau = 87.2 and stays just
  above it;
* ``2 steep 106%``: w = 1 up to tau = 30, a slow linear increase to 30 at tau = 97, then steep,
  +22.1 per experiment, reaching 106 % (w = 74.2) at tau = 99; crosses 35 at tau = 97.2 (the
  paper's early detection happens in the 25-35 band of the slow increase);

every path capped at 100.  The "random variations" of the paper's wear profile data are
simulated as a per-experiment variation of the wear that enters the friction (sd as given,
clipped to [0, 100]): noise of the wear profile, not wear; the truth the metrics and the
coverage use is the monotone path.
Both rules are :class:`robot_wear_monitor.estimation.alarm.AlarmPolicy` (the rule the nodes latch),
judged per experiment without the latch; the paper's rule without the CUSUM evidence (h = 0).
Per experiment: temperature clip(40 + A sin(2 pi tau / P + phi) + N(0, 2^2), 30, 50) with A in
U(4, 10), P in U(20, 60) per run; load N(0.5, 0.1^2) per experiment (shared by its N levels);
friction levels = the project's model (8) (``robot_wear_monitor.model.friction.friction``) at
the Table V speeds + N(0, sigma^2) per level, sigma of the packaged parameter set.  Estimates:
``estimate_wear`` (batched); likelihood rows: ``profile_log_likelihood`` on the trend's grid.

Metrics per scenario, N and rule, over the runs (k25 / k35: first experiment with true
w >= 25 / >= 35):

* false %: runs with an alarm at some experiment k < k25 (true w < 25);
* false/exp %: alarms per experiment with k < k25, for a non-latched rule;
* delay: mean of max(0, k_alarm - k35) over the detected runs, k_alarm = first alarm at k >= k25
  (the alarm is judged as if a false one had been reset); early %: k_alarm < k35;
* miss %: runs without an alarm in k25 .. k35 + 10.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robot_wear_monitor.estimation.alarm import (  # noqa: E402
    AlarmPolicy, DEFAULT_ALARM_PROBABILITY, WEAR_HEALTHY, WEAR_THRESHOLD)
from robot_wear_monitor.estimation.estimator import estimate_wear  # noqa: E402
from robot_wear_monitor.estimation.intervals import profile_log_likelihood  # noqa: E402
from robot_wear_monitor.estimation.trend import filter_batch, TrendConfig  # noqa: E402
from robot_wear_monitor.model import friction as fm  # noqa: E402
from robot_wear_monitor.model.params import load_parameter_set  # noqa: E402

SPEEDS = {1: [35.1], 2: [35.1, 41.7], 4: [2.1, 28.5, 35.1, 41.7]}
SCENARIOS = ('0 late exp', '1 rise 56%', '2 steep 106%')
EXPERIMENTS = 110
INTERVAL_S = 3600.0
WINDOW_AFTER = 10
THRESHOLD = WEAR_THRESHOLD
HEALTHY = WEAR_HEALTHY


def wear_path(scenario: int, tau: np.ndarray) -> tuple[np.ndarray, float]:
    """Return the monotone wear path at nominal experiment times tau and its variation sd."""
    if scenario == 0:
        path, variation = 1.0 + 69.0 * np.exp((tau - 99.0) / 6.0), 0.5
    elif scenario == 1:
        path, variation = 2.0 + 37.2 / (1.0 + np.exp(-(tau - 80.0) / 3.5)), 1.5
    else:
        slow = 1.0 + 29.0 * np.clip((tau - 30.0) / 67.0, 0.0, 1.0)
        path, variation = slow + 22.1 * np.maximum(tau - 97.0, 0.0), 0.5
    return np.minimum(path, 100.0), variation


def simulate(scenario: int, runs: int, rng: np.random.Generator) -> dict:
    """Return times [s], nominal index, wear, temperature [degC] and load, each (runs, K)."""
    intervals = INTERVAL_S * rng.uniform(0.5, 1.5, (runs, EXPERIMENTS))
    intervals[:, 0] = 0.0
    times = np.cumsum(intervals, axis=1)
    tau = times / INTERVAL_S
    amplitude = rng.uniform(4.0, 10.0, (runs, 1))
    period = rng.uniform(20.0, 60.0, (runs, 1))
    phase = rng.uniform(0.0, 2 * np.pi, (runs, 1))
    temperature = np.clip(40.0 + amplitude * np.sin(2 * np.pi * tau / period + phase)
                          + rng.normal(0.0, 2.0, tau.shape), 30.0, 50.0)
    load = rng.normal(0.5, 0.1, tau.shape)
    path, variation = wear_path(scenario, tau)
    effective = np.clip(path + rng.normal(0.0, variation, tau.shape), 0.0, 100.0)
    return {'times': times, 'wear': path, 'effective_wear': effective,
            'temperature': temperature, 'load': load}


def alarm_metrics(alarm: np.ndarray, wear: np.ndarray) -> dict:
    """Return false %, false per experiment %, mean delay, early % and miss % of (runs, K)."""
    runs, k = wear.shape
    index = np.arange(k)[None, :]
    k25 = np.argmax(wear >= HEALTHY, axis=1)[:, None]
    k35 = np.argmax(wear >= THRESHOLD, axis=1)[:, None]
    before = index < k25
    false_runs = np.any(alarm & before, axis=1)
    window = (index >= k25) & (index <= k35 + WINDOW_AFTER)
    hits = alarm & window
    detected = np.any(hits, axis=1)
    first = np.where(detected, np.argmax(hits, axis=1), -1)
    delay = np.maximum(first - k35[:, 0], 0)[detected]
    early = (first < k35[:, 0]) & detected
    return {'false': 100.0 * false_runs.mean(),
            'false_exp': 100.0 * (alarm & before).sum() / max(before.sum(), 1),
            'delay': float(delay.mean()) if delay.size else float('nan'),
            'early': 100.0 * early.mean(), 'miss': 100.0 * (1.0 - detected.mean())}


def run(runs: int, seed: int, probabilities: list[float], config: TrendConfig) -> list[dict]:
    """Simulate every scenario and N; return one metrics row per scenario, N and rule."""
    params = load_parameter_set()
    rows = []
    for scenario in range(3):
        rng = np.random.default_rng([seed, scenario])
        sim = simulate(scenario, runs, rng)
        for n, speeds in SPEEDS.items():
            mean = fm.friction(np.asarray(speeds)[None, None, :], sim['load'][..., None],
                               sim['temperature'][..., None], sim['effective_wear'][..., None],
                               params.model)
            friction = (mean + rng.normal(0.0, params.sigma, mean.shape)).reshape(-1, n)
            w_hat = estimate_wear(speeds, friction, params=params).wear.reshape(runs, -1)
            ll = profile_log_likelihood(speeds, friction, params=params,
                                        wear_grid=config.wear_grid)
            trend = filter_batch(times_s=sim['times'],
                                 log_likelihood=ll.reshape(runs, EXPERIMENTS, -1),
                                 config=config)
            base = {'scenario': SCENARIOS[scenario], 'n': n}
            paper = AlarmPolicy(threshold=THRESHOLD, healthy=HEALTHY, rule='estimate')
            rows.append({**base, 'rule': 'w-hat >= 35',
                         **alarm_metrics(paper.decide(wear=w_hat), sim['wear'])})
            inside = ((trend.wear_low <= sim['wear']) & (sim['wear'] <= trend.wear_high))
            for p in probabilities:
                alarm = AlarmPolicy(threshold=THRESHOLD, healthy=HEALTHY, rule='trend',
                                    probability=p).decide(
                    probability_above_threshold=trend.probability_above_threshold)
                rows.append({**base, 'rule': f'P(w>=35) >= {p:g}',
                             'coverage': 100.0 * inside.mean(),
                             **alarm_metrics(alarm, sim['wear'])})
    return rows


def print_table(rows: list[dict]) -> None:
    """Print the metrics as a markdown table."""
    print('| scenario | N | rule | false % | false/exp % | mean delay [exp] | early % | '
          'miss % | 95 % coverage |')
    print('|---|---|---|---|---|---|---|---|---|')
    for r in rows:
        coverage = f"{r['coverage']:.1f}" if 'coverage' in r else ''
        print(f"| {r['scenario']} | {r['n']} | {r['rule']} | {r['false']:.1f} | "
              f"{r['false_exp']:.2f} | {r['delay']:.2f} | {r['early']:.1f} | {r['miss']:.1f} | "
              f'{coverage} |')
    for rule in dict.fromkeys(r['rule'] for r in rows):
        mine = [r for r in rows if r['rule'] == rule]
        print(f"| all | 1, 2, 4 | {rule} | {np.mean([r['false'] for r in mine]):.1f} | "
              f"{np.mean([r['false_exp'] for r in mine]):.2f} | "
              f"{np.mean([r['delay'] for r in mine]):.2f} | "
              f"{np.mean([r['early'] for r in mine]):.1f} | "
              f"{np.mean([r['miss'] for r in mine]):.1f} | |")


def main() -> None:
    """Run the benchmark and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--runs', type=int, default=100)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--sweep', action='store_true', help='several alarm probabilities')
    args = parser.parse_args()
    probabilities = ([0.1, 0.15, 0.2, 0.3, 0.5] if args.sweep else [DEFAULT_ALARM_PROBABILITY])
    start = time.perf_counter()
    rows = run(args.runs, args.seed, probabilities, TrendConfig())
    print(f'{args.runs} runs x {EXPERIMENTS} experiments per scenario and N\n')
    print_table(rows)
    print(f'\n{time.perf_counter() - start:.1f} s')


if __name__ == '__main__':
    main()
