"""
What a set identified from a robot's own levels takes from those levels besides the model.

``identify`` writes a set that must monitor the robot it was fitted on, as written:

* :func:`operating_range`: the speed bounds and design separation of the levels (motor side);
* :func:`pooled_load_prior`: the load estimate N(mu_tl, sigma_tl) of eq. (14) from the levels' load
  column, and its configurations (:func:`load_clusters`: e.g. with and without a payload);
* :func:`scaled_wear_model`: a wear model (7) borrowed from a reference joint, scaled to this
  joint's friction and speed range (no wear test of this joint exists).

Units: speeds motor side [rad/s]; friction and load in the levels' own units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.model.friction import nominal_friction, wear_friction
from robot_wear_monitor.model.params import FrictionModel, ParameterSet


#: Speeds equal within this relative step are one speed (as ``distinct_count`` counts them).
SPEED_RESOLUTION = 0.02
#: A load cluster holds at least this fraction of the levels.
MIN_CLUSTER_FRACTION = 0.1
#: Two load clusters are separate when the gap between them exceeds this many times the
#: larger cluster's standard deviation.
CLUSTER_GAP_STDS = 4.0


def distinct_speeds(speed: FloatArray) -> FloatArray:
    """Return the distinct speeds (mean of each group equal within 2 %), ascending."""
    v = np.asarray(speed, dtype=float)
    keys = np.round(np.log(v) / SPEED_RESOLUTION)
    return np.sort(np.array([float(v[keys == k].mean()) for k in np.unique(keys)]))


def operating_range(speed: FloatArray) -> tuple[float, float, float]:
    """
    Return (lowest speed, highest speed, smallest separation) of levels [rad/s, motor side].

    The separation is the smallest step between adjacent distinct speeds (the design then
    chooses among speeds as far apart as the levels' own); 0 for one speed.
    """
    speeds = distinct_speeds(speed)
    separation = float(np.min(np.diff(speeds))) if speeds.size > 1 else 0.0
    return float(speeds[0]), float(speeds[-1]), separation


@dataclass(frozen=True)
class LoadCluster:
    """
    One configuration of the load column (e.g. with a payload).

    :ivar mean: mean load [load unit].
    :ivar std: standard deviation of the load [load unit].
    :ivar low: smallest load.
    :ivar high: largest load.
    :ivar n_levels: levels in the cluster.

    """

    mean: float
    std: float
    low: float
    high: float
    n_levels: int

    def to_dict(self) -> dict:
        """Return a JSON-ready dict."""
        return {'mean': self.mean, 'std': self.std, 'low': self.low, 'high': self.high,
                'n_levels': self.n_levels}


def _cluster(values: FloatArray) -> LoadCluster:
    return LoadCluster(mean=float(values.mean()),
                       std=float(values.std(ddof=1)) if values.size > 1 else 0.0,
                       low=float(values.min()), high=float(values.max()),
                       n_levels=int(values.size))


def load_clusters(load: FloatArray) -> tuple[LoadCluster, ...]:
    """
    Return the load column's configurations: one cluster, or two split at the widest gap.

    Two clusters when the widest gap between sorted loads leaves at least
    :data:`MIN_CLUSTER_FRACTION` of the levels on each side and exceeds
    :data:`CLUSTER_GAP_STDS` times the larger side's standard deviation (a payload on and
    off); otherwise the whole column is one configuration.
    """
    values = np.sort(np.asarray(load, dtype=float))
    if values.size < 4:
        return (_cluster(values),)
    gaps = np.diff(values)
    i = int(np.argmax(gaps))
    low, high = values[:i + 1], values[i + 1:]
    smallest = MIN_CLUSTER_FRACTION * values.size
    if low.size >= smallest and high.size >= smallest and low.size > 1 and high.size > 1:
        spread = max(float(low.std(ddof=1)), float(high.std(ddof=1)))
        if gaps[i] > CLUSTER_GAP_STDS * spread:
            return (_cluster(low), _cluster(high))
    return (_cluster(values),)


def pooled_load_prior(load: FloatArray) -> LoadCluster:
    """Return the pooled load prior of the column: its mean and standard deviation."""
    return _cluster(np.asarray(load, dtype=float))


@dataclass(frozen=True)
class WearScaling:
    """
    How a borrowed wear model (7) was scaled to this joint.

    :ivar amplitude: k, the ratio of this joint's mean nominal friction to the reference's
        over the mapped speed ranges (F_s,w and F_v,w x k; F_v,w also / s).
    :ivar speed: s, this joint's highest level speed over the reference's design speed_max
        (phi_s,w x s).
    :ivar reference: the reference set's name.
    :ivar assumption: the assumption in words, as written in the set.

    """

    amplitude: float
    speed: float
    reference: str
    assumption: str

    def to_dict(self) -> dict:
        """Return a JSON-ready dict."""
        return {'amplitude': self.amplitude, 'speed': self.speed, 'reference': self.reference,
                'assumption': self.assumption}


def scaled_wear_model(*, reference: ParameterSet, model: FrictionModel, speed_min: float,
                      speed_max: float, temperature_degc: float, load_mean: float,
                      friction_unit: str, map_speeds: bool = False
                      ) -> tuple[dict[str, float], WearScaling]:
    """
    Return the reference's wear model (7) scaled to this joint, and the scaling.

    The assumption: wear changes this joint's friction by the same fraction of its nominal
    friction as on the reference joint, at the same motor speed.  The amplitude is scaled by
    k = mean tau_f0 of this joint over [speed_min, speed_max] (at ``temperature_degc`` and
    ``load_mean``) / mean tau_f0 of the reference over the same speeds (at its design
    temperature and load mean): tilde tau(v, w) = k x the reference's tilde tau(v, w), i.e.
    F_s,w' = k F_s,w and F_v,w' = k F_v,w, phi_s,w unchanged.  ``map_speeds`` (studied in
    docs/identify.md, not the default) also maps the reference's design speed range onto this
    joint's, s = speed_max / reference.speed_max_rad_s: tilde tau(v, w) = k x the reference's
    tilde tau(v / s, w), phi_s,w' = s phi_s,w and F_v,w' = k F_v,w / s.

    :return: ({'f_s_wear', 'f_v_wear', 'phi_s_wear'}, :class:`WearScaling`).

    """
    ref = reference.model
    s = speed_max / reference.speed_max_rad_s if map_speeds else 1.0
    v = np.linspace(speed_min, speed_max, 50)
    here = nominal_friction(v, load_mean, temperature_degc, model)
    there = nominal_friction(v / s, reference.load_mean, reference.design_temperature_degc, ref)
    k = float(np.mean(here) / np.mean(there))
    values = {'f_s_wear': k * ref.f_s_wear, 'f_v_wear': k * ref.f_v_wear / s,
              'phi_s_wear': s * ref.phi_s_wear}
    w = reference.wear_threshold
    fraction = float(wear_friction(v[0] / s, w, ref) / there[0])
    where = (f'at the same place in its speed range (speeds x {s:.4g})' if map_speeds else
             'at the same motor speed')
    assumption = (f'the wear model (7) of {reference.name} scaled to this joint, assuming wear '
                  f'changes its friction by the same fraction of its nominal friction as on '
                  f'{reference.name}, {where}: friction x {k:.4g} ({friction_unit} per '
                  f'{reference.friction_unit} unit); at w = {w:g} the wear adds '
                  f'{100 * fraction:.3g} % of the nominal friction at '
                  f'{float(v[0]):.4g} rad/s')
    return values, WearScaling(amplitude=k, speed=s, reference=reference.name,
                               assumption=assumption)
