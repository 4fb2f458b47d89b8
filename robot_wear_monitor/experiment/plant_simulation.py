"""
A plant's arm simulated: every joint's friction experiments, and wear that continues.

:func:`simulate_joints` runs the accelerated wear scenario of
:mod:`robot_wear_monitor.experiment.simulation` on several joints of the simulated 6-axis arm,
each with its own wear (its own final wear and random draws: its own friction levels,
temperature and load), one joint after another within each experiment interval (joint ``i`` of
``J`` starts ``i / J`` of an interval after the first), into one stream of JointState samples.
A joint's wear can start where an earlier recording ended (``start_wear``, or the truth file of
that recording: :func:`continuation`), so consecutive recordings of one robot replay into a
history whose wear continues.
"""

from __future__ import annotations

from dataclasses import asdict, replace
import json
import math
import os
from typing import Mapping, Optional, Sequence

import numpy as np

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                      DEFAULT_JOINT_NAMES, JointSimConfig,
                                                      Scenario, simulate_scenario,
                                                      truth_to_dict)
from robot_wear_monitor.input_files import MAX_JSON_BYTES, read_text_file
from robot_wear_monitor.model.params import ParameterSet
from robot_wear_monitor.text import shorten

#: Where each joint of the simulated arm rests while another is tested [rad], and its effort
#: then (effort units): the single-joint simulation's values, joint_2 at its ``phi_bar_rad``.
REST_POSITIONS_RAD = dict(zip(DEFAULT_JOINT_NAMES, (0.1, 0.2, -0.5, 0.3, 0.0, 0.7)))
REST_EFFORTS = dict(zip(DEFAULT_JOINT_NAMES, (0.5, 2.0, 4.0, 0.8, 0.2, 0.05)))
#: Each joint's share of ``--wear-final`` (joint_2 wears as the single-joint simulation).
WEAR_SHARES = dict(zip(DEFAULT_JOINT_NAMES, (0.6, 1.0, 0.8, 0.5, 0.9, 0.7)))


def joint_config(joint: str, base: JointSimConfig) -> JointSimConfig:
    """Return ``base`` testing ``joint``: the others at rest, the joint moved about its rest."""
    if joint not in base.joint_names:
        raise InputError(f'--joints: {shorten(joint, 60)!r} is not a joint of the simulated arm '
                         f'({", ".join(base.joint_names)})')
    others = [name for name in base.joint_names if name != joint]
    return replace(base, joint=joint, phi_bar_rad=REST_POSITIONS_RAD.get(joint, 0.2),
                   other_positions_rad=tuple(REST_POSITIONS_RAD.get(n, 0.0) for n in others),
                   other_efforts=tuple(REST_EFFORTS.get(n, 0.5) for n in others))


def continuation(path: str | os.PathLike) -> tuple[dict[str, float], float]:
    """
    Return (the last true wear per joint, the end [s]) of an earlier simulated recording.

    ``path``: its truth file (``<bag>.truth.json``, :func:`write_plant_truth` or
    :func:`~robot_wear_monitor.experiment.simulation.write_truth_json`).
    """
    try:
        document = json.loads(read_text_file(path, what='truth file',
                                             limit_bytes=MAX_JSON_BYTES))
        final = {str(name): float(wear) for name, wear in document['final_wear'].items()}
        end_s = float(document['end_time_s'])
    except InputError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as error:
        raise InputError(f'--continue-from {shorten(path, 200)}: not the truth file of a '
                         f'simulated recording (final_wear, end_time_s): '
                         f'{shorten(error)}') from None
    if not math.isfinite(end_s) or not all(math.isfinite(w) and w >= 0 for w in final.values()):
        raise InputError(f'--continue-from {shorten(path, 200)}: final_wear and end_time_s '
                         f'must be finite')
    return final, end_s


def continued_wear_profile(*, n_experiments: int, first: float, final: float,
                           rng: np.random.Generator, rise_experiments: float = 6.0,
                           jitter: float = 0.5) -> np.ndarray:
    """
    Return w(k) from ``first`` (exactly, at k = 0) rising to about ``final`` at k = K - 1.

    The accelerated profile's exponential rise over the last ``rise_experiments``, scaled so
    that it starts at ``first``: where an earlier recording ended.  Jitter (w units, normal)
    on k >= 1; never below 0.
    """
    k = np.arange(n_experiments, dtype=float)
    if n_experiments == 1:
        return np.array([first])
    shape = np.exp((k - (n_experiments - 1)) / rise_experiments)
    shape = (shape - shape[0]) / (1.0 - shape[0])
    noise = np.concatenate([[0.0], rng.normal(0.0, jitter, n_experiments - 1)])
    return np.maximum(first + (final - first) * shape + noise, 0.0)


def simulate_joints(*, joints: Sequence[str], n_experiments: int, speeds_rad_s: Sequence[float],
                    params: ParameterSet, seed: int, wear_final: float,
                    experiment_interval_s: float, base: JointSimConfig, start_time_s: float,
                    start_wear: Optional[Mapping[str, float]] = None) -> Scenario:
    """
    Return the experiments of ``joints``, each with its own wear, as one scenario.

    Joint ``i`` of ``J``: :func:`continued_wear_profile` from ``start_wear[joint]`` (default
    1) to ``wear_final x WEAR_SHARES[joint]`` (at least its start), seed ``seed + 1000
    i``, its experiments ``i / J`` of ``experiment_interval_s`` [s] after the first joint's.
    The scenario's ``truth`` holds every experiment by time; ``metadata['joints']`` each
    joint's (see :func:`write_plant_truth`).  Raises InputError when an experiment does not fit
    in its share of the interval.
    """
    parts = []
    count = len(joints)
    for index, joint in enumerate(joints):
        config = joint_config(joint, base)
        first = (start_wear or {}).get(joint, 1.0)
        final = max(wear_final * WEAR_SHARES.get(joint, 1.0), first)
        scenario = accelerated_wear_scenario(
            n_experiments=n_experiments, speeds_rad_s=speeds_rad_s, params=params,
            seed=seed + 1000 * index, wear_final=final,
            experiment_interval_s=experiment_interval_s, joint=config)
        rng = np.random.default_rng(seed + 1000 * index + 1)
        wear = continued_wear_profile(n_experiments=n_experiments, first=first, final=final,
                                      rng=rng)
        scenario = replace(scenario, wear=tuple(wear.tolist()),
                           start_time_s=start_time_s + index * experiment_interval_s / count)
        part = simulate_scenario(config=scenario, model=params.model, seed=seed + 1000 * index)
        longest = max(t.end_time_s - t.start_time_s for t in part.truth)
        if count > 1 and longest >= experiment_interval_s / count:
            raise InputError(f'--interval {experiment_interval_s:g} s: an experiment lasts '
                             f'{longest:.1f} s, longer than a joint share of the interval '
                             f'({experiment_interval_s / count:.1f} s of {count} joints; raise '
                             f'--interval)')
        parts.append(part)
    order = np.argsort(np.concatenate([p.time_s for p in parts]), kind='stable')
    merged = Scenario(
        joint_names=base.joint_names, joint=joints[0],
        time_s=np.concatenate([p.time_s for p in parts])[order],
        position_rad=np.concatenate([p.position_rad for p in parts])[order],
        velocity_rad_s=np.concatenate([p.velocity_rad_s for p in parts])[order],
        effort=np.concatenate([p.effort for p in parts])[order],
        truth=sorted((t for p in parts for t in p.truth), key=lambda t: t.start_time_s),
        config=parts[0].config,
        metadata={'seed': int(seed), 'joints': {
            joint: {'truth': [asdict(t) for t in p.truth], 'joint_config': asdict(p.config)}
            for joint, p in zip(joints, parts)}})
    return merged


def plant_truth(scenario: Scenario) -> dict:
    """
    Return the truth of :func:`simulate_joints`: the single joint's form, plus every joint's.

    ``joints``: per joint its experiments and configuration; ``final_wear``: each joint's last
    true wear (w); ``end_time_s``: the last sample [s] (what ``--continue-from`` reads).
    """
    document = truth_to_dict(scenario)
    joints = scenario.metadata.get('joints', {})
    document['joints'] = {name: entry['truth'] for name, entry in joints.items()}
    document['final_wear'] = {name: entry['truth'][-1]['wear'] for name, entry in joints.items()}
    document['end_time_s'] = float(scenario.time_s[-1])
    document['metadata'] = {'seed': scenario.metadata.get('seed')}
    return document
