"""
Where a cold group's wear reading comes from: the study behind docs/identify.md.

Run: ``PYTHONPATH=.:test python -m wear_testing.real_arm_study``.  Identifies a set from the
real-arm generator's levels (:mod:`wear_testing.real_arm_logger`) and estimates (T, w) of the
monitoring groups of held-out heat-up sessions (both payload configurations, several seeds)
under variants of the load prior, the borrowed wear model and the speeds per group; prints
per variant the largest w-hat, the mean w-hat of the coldest groups, the RMS and largest
|T-hat - T|, and how many groups the plausibility gate refused.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from robot_wear_monitor.audit.data import table_from_columns
from robot_wear_monitor.audit.identification import identify
from robot_wear_monitor.audit.operating_range import scaled_wear_model
from robot_wear_monitor.estimation.estimator import estimate_wear
from robot_wear_monitor.estimation.plausibility import friction_range
from robot_wear_monitor.model.params import load_parameter_set
from wear_testing import real_arm_logger as arm

#: Four of the 13 speeds, for groups with few speeds [rad/s, joint].
FOUR_SPEEDS = (0.35, 0.5833, 0.8167, 1.05)


def identified(*, seed: int = 0):
    """Return the identification of the generator's levels (friction in A, motor speeds)."""
    levels = arm.identification_levels(seed=seed)
    columns = {k: levels[k] for k in ('experiment', 'friction', 'temperature', 'load')}
    columns['speed'] = levels['speed'] * arm.GEAR_RATIO
    table = table_from_columns(columns, source='real_arm_levels.csv')
    return identify(baseline=table, from_params=load_parameter_set(), name='real_arm',
                    friction_unit='A')


def variants(result) -> dict:
    """Return the parameter sets of the study: name -> (set for empty, set for payload)."""
    params = result.params
    reference = load_parameter_set()
    clusters = result.extra['load_configurations']

    def with_wear(p, kind):
        if kind == 'reference':
            values = {k: getattr(reference.model, k) for k in
                      ('f_s_wear', 'f_v_wear', 'phi_s_wear')}
        else:
            values, _ = scaled_wear_model(
                reference=reference, model=p.model, speed_min=p.speed_min_rad_s,
                speed_max=p.speed_max_rad_s, temperature_degc=p.design_temperature_degc,
                load_mean=p.load_mean, friction_unit='A', map_speeds=kind == 'mapped')
        return replace(p, model=replace(p.model, **values))

    def prior(p, which, config):
        if which == 'reference':
            return p.with_overrides(load_mean=reference.load_mean, load_std=reference.load_std)
        if which == 'pooled':
            return p
        c = clusters[config]
        return p.with_overrides(load_mean=c['mean'], load_std=c['std'])

    out = {}
    for wear in ('reference', 'mapped', 'scaled'):
        for which in ('reference', 'pooled', 'configuration'):
            out[(wear, which)] = tuple(with_wear(prior(params, which, i), wear) for i in (0, 1))
    return out


def study(*, seeds=(11, 12, 13, 14), speeds=arm.SPEEDS_RAD_S) -> dict:
    """Return {(wear, prior): figures} over monitoring sessions of both configurations."""
    result = identified()
    sets = variants(result)
    groups = []
    for seed in seeds:
        for payload in (False, True):
            session = arm.Session(payload=payload, room_degc=22.0 + seed % 3)
            groups += [(int(payload), i, g) for i, g in enumerate(arm.monitoring_groups(
                session, seed=seed, every_s=720.0, speeds=speeds))]
    out = {}
    for key, (empty, payload) in sets.items():
        wears, cold, errors, refused = [], [], [], 0
        for config, index, g in groups:
            p = payload if config else empty
            v = g['speeds'] * arm.GEAR_RATIO
            est = estimate_wear(v, g['friction'], params=p)[0]
            low, high = friction_range(v, params=p)
            refused += bool(np.any((g['friction'] < low) | (g['friction'] > high)))
            wears.append(est.wear)
            errors.append(est.temperature_degc - g['temperature'])
            if index == 0:
                cold.append(est.wear)
        errors_a = np.abs(errors)
        out[key] = {'w_max': float(np.max(wears)), 'w_mean': float(np.mean(wears)),
                    'w_cold': float(np.mean(cold)), 't_rms': float(np.sqrt(np.mean(
                        errors_a ** 2))), 't_max': float(errors_a.max()), 'refused': refused,
                    'groups': len(groups)}
    return out


def main() -> None:
    """Print the study's table (13 speeds and 4 speeds per group)."""
    for label, speeds in (('13 speeds', arm.SPEEDS_RAD_S), ('4 speeds', FOUR_SPEEDS)):
        print(f'groups of {label}')
        print('| wear model | load prior | max w | mean w | mean w coldest | T rms | T max | '
              'outside the friction range |')
        for (wear, prior), f in study(speeds=speeds).items():
            print(f"| {wear} | {prior} | {f['w_max']:.1f} | {f['w_mean']:.1f} | "
                  f"{f['w_cold']:.1f} | {f['t_rms']:.2f} | {f['t_max']:.2f} | "
                  f"{f['refused']}/{f['groups']} |")


if __name__ == '__main__':
    main()
