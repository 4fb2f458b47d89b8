"""
Test data that behaves like a real arm: a 6-axis arm's joint logged at 2 Hz over heat-up sessions.

Written from physics, independent of ``robot_wear_monitor`` (it imports nothing from the
package, in particular not ``model``): the joint's friction is measured as **motor current
[A]**, not as a normalised torque, and it does not follow the paper's model (5) exactly.

The joint (joint side unless said otherwise; motor speed = ``GEAR_RATIO`` x joint speed):

* friction current ``f(v, T, L, q) = C0 + C_LOAD L + S0 exp(-(v/VS)^A) + S_LOAD L
  exp(-(v/VS_LOAD)^A) + KV exp(-KV_TEMP (T - 25)) v + P sin(2 pi q / P_WAVELENGTH) + offset``:
  a Coulomb part rising with the load current L, a Stribeck dip, a viscous part that falls
  ``KV_TEMP`` = 2 %/degC with the joint temperature T, a position-dependent ripple (gear mesh)
  and a per-session offset; about 1-2 A at the logged speeds;
* the load column is the gravity current ``L = G |cos(q)|`` [A], G without or with a payload:
  two clusters, 0.7-1.1 A and 3.2-5.0 A over the position window;
* a heat-up session: the temperature rises from the room temperature towards the warm
  temperature with a time constant, as elapsed time does; the controller reports it in whole
  degrees;
* the trajectory: for each of the 13 joint speeds 0.35-1.05 rad/s (random order per sweep),
  back-and-forth passes over a 1.2 rad window (a pass holds 2-6 samples at 2 Hz), short
  reversals (samples there are not at constant speed);
* the logger samples t, q, dq, current, temperature reading and load at 2 Hz with jitter;
* current = sign(dq) f + gravity current + noise; in a reversal the current is between.

:func:`levels_from_log` forms the friction levels of eq. (3) over position bins: in each bin
of a speed visit, (mean of the forward samples - mean of the backward samples) / 2, where each
direction has at least two samples; the level's temperature is the visit's mean reading, its
load the bin's mean load.  :func:`monitoring_groups` runs short monitoring experiments (one
level per speed: the mean over the bins) during a held-out heat-up session.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Sequence

import numpy as np

#: Motor speed = GEAR_RATIO x joint speed.
GEAR_RATIO = 100.0
#: The 13 logged joint speeds [rad/s].
SPEEDS_RAD_S = tuple(float(v) for v in np.round(np.linspace(0.35, 1.05, 13), 4))
#: Logger rate [Hz].
SAMPLE_RATE_HZ = 2.0
#: Position window of the passes: centre and width [rad, joint].
CENTRE_RAD, WINDOW_RAD = 0.3, 1.2
#: Width of the position bins of eq. (3) [rad].
BIN_RAD = 0.3
#: Duration of a reversal (speed not constant) [s].
REVERSAL_S = 0.3

#: Friction current of the joint [A] and its dependences (see the module docstring).
C0 = 0.55
C_LOAD = 0.10          # A per A of load current
S0 = 0.30
VS = 0.45              # rad/s
S_LOAD = 0.03          # A per A of load current
VS_LOAD = 0.6          # rad/s
A = 1.5
KV = 0.70              # A per rad/s at 25 degC
KV_TEMP = 0.02         # the viscous part falls 2 %/degC
P = 0.04               # position ripple amplitude [A]
P_WAVELENGTH = 0.9     # rad
#: Gravity current amplitude without and with the payload [A].
G_EMPTY, G_PAYLOAD = 1.12, 5.2
#: Per-session offset std [A], per-sample current noise std [A], speed noise std [rad/s].
OFFSET_STD, CURRENT_NOISE_STD, SPEED_NOISE_STD = 0.03, 0.10, 0.005
#: Wear: the friction rises by WEAR_FRACTION x f at low speed, fading with speed (for a worn
#: joint; 0 for a healthy one).
WEAR_SPEED = 0.6       # rad/s


@dataclass(frozen=True)
class Session:
    """
    One heat-up session.

    :ivar payload: with the payload (the load cluster 3.2-5.0 A) or without (0.7-1.1 A).
    :ivar room_degc: temperature at the start [degC].
    :ivar warm_degc: the temperature it heats towards [degC].
    :ivar time_constant_s: time constant of the heat-up [s].
    :ivar duration_s: length of the session [s].
    :ivar wear_fraction: relative friction increase at low speed from wear (0 = healthy).
    :ivar gravity_scale: the gravity current's amplitude x this (another pose of the other
        joints: the load column of one payload spreads over a wider range).

    """

    payload: bool
    room_degc: float = 21.0
    warm_degc: float = 44.0
    time_constant_s: float = 2400.0
    duration_s: float = 3600.0
    wear_fraction: float = 0.0
    gravity_scale: float = 1.0


def temperature_degc(session: Session, t_s: np.ndarray) -> np.ndarray:
    """Return the true joint temperature of a heat-up session at elapsed times t [degC]."""
    return session.warm_degc + (session.room_degc - session.warm_degc) * np.exp(
        -np.asarray(t_s) / session.time_constant_s)


def friction_current(v: np.ndarray, temperature: np.ndarray, load: np.ndarray, q: np.ndarray,
                     *, offset: float = 0.0, wear_fraction: float = 0.0) -> np.ndarray:
    """Return the friction current [A] at joint speed |v| [rad/s], T [degC], load [A], q [rad]."""
    v = np.abs(np.asarray(v, dtype=float))
    base = (C0 + C_LOAD * load + S0 * np.exp(-(v / VS) ** A)
            + S_LOAD * load * np.exp(-(v / VS_LOAD) ** A)
            + KV * np.exp(-KV_TEMP * (np.asarray(temperature) - 25.0)) * v)
    wear = wear_fraction * base * np.exp(-(v / WEAR_SPEED) ** A)
    return base + wear + P * np.sin(2 * math.pi * np.asarray(q) / P_WAVELENGTH) + offset


def _visit(v: float, t0: float, duration_s: float, rng: np.random.Generator) -> dict:
    """Return the true trajectory samples of one speed visit (2 Hz with jitter)."""
    pass_s = WINDOW_RAD / v
    period = 2 * (pass_s + REVERSAL_S)
    n_cycles = max(int(math.ceil(duration_s / period)), 2)
    t_local = np.arange(0.0, n_cycles * period, 1.0 / SAMPLE_RATE_HZ) + rng.uniform(0, 0.5)
    t_local = t_local[t_local < n_cycles * period]
    t_local = t_local + rng.normal(0.0, 0.01, t_local.size)
    phase = np.mod(t_local, period)
    low = CENTRE_RAD - WINDOW_RAD / 2
    q = np.empty_like(phase)
    dq = np.empty_like(phase)
    forward = phase < pass_s
    rev1 = (phase >= pass_s) & (phase < pass_s + REVERSAL_S)
    backward = (phase >= pass_s + REVERSAL_S) & (phase < 2 * pass_s + REVERSAL_S)
    rev2 = phase >= 2 * pass_s + REVERSAL_S
    q[forward] = low + v * phase[forward]
    dq[forward] = v
    x = (phase[rev1] - pass_s) / REVERSAL_S
    q[rev1] = low + WINDOW_RAD
    dq[rev1] = v * np.cos(math.pi * x)
    s = phase[backward] - pass_s - REVERSAL_S
    q[backward] = low + WINDOW_RAD - v * s
    dq[backward] = -v
    x = (phase[rev2] - 2 * pass_s - REVERSAL_S) / REVERSAL_S
    q[rev2] = low
    dq[rev2] = -v * np.cos(math.pi * x)
    return {'t_s': t0 + t_local, 'q_rad': q, 'dq_true': dq, 'speed_set': np.full(q.size, v)}


def log_session(session: Session, *, seed: int, visit_s: float = 30.0,
                speeds: Sequence[float] = SPEEDS_RAD_S, session_index: int = 0) -> dict:
    """
    Return the 2 Hz log of one heat-up session: sweeps over ``speeds`` until its end.

    Columns: ``t_s`` (elapsed), ``q_rad``, ``dq_rad_s`` (measured), ``current_a``,
    ``temperature_degc`` (whole degrees), ``load_a``, ``speed_set_rad_s``, ``visit``,
    ``sweep``, ``session``, ``payload`` (0/1), ``temperature_true_degc``.
    """
    rng = np.random.default_rng(seed)
    offset = float(rng.normal(0.0, OFFSET_STD))
    parts, t0, visit, sweep = [], 0.0, 0, 0
    while t0 < session.duration_s:
        for v in rng.permutation(np.asarray(speeds, dtype=float)):
            part = _visit(float(v), t0, visit_s, rng)
            part['visit'] = np.full(part['q_rad'].size, visit)
            part['sweep'] = np.full(part['q_rad'].size, sweep)
            parts.append(part)
            t0 = float(part['t_s'][-1]) + 2.0
            visit += 1
            if t0 >= session.duration_s:
                break
        sweep += 1
    log = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    q, dq = log['q_rad'], log.pop('dq_true')
    temperature = temperature_degc(session, log['t_s'])
    gravity = ((G_PAYLOAD if session.payload else G_EMPTY) * session.gravity_scale
               * np.abs(np.cos(q)))
    friction = friction_current(dq, temperature, gravity, q, offset=offset,
                                wear_fraction=session.wear_fraction)
    # in a reversal the friction follows the speed's sign through zero (a smooth change)
    direction = np.tanh(dq / 0.05)
    current = direction * friction + gravity + rng.normal(0.0, CURRENT_NOISE_STD, q.size)
    log.update(dq_rad_s=dq + rng.normal(0.0, SPEED_NOISE_STD, q.size), current_a=current,
               temperature_degc=np.round(temperature + 0.3), load_a=gravity,
               temperature_true_degc=temperature, speed_set_rad_s=log.pop('speed_set'),
               session=np.full(q.size, session_index),
               payload=np.full(q.size, int(session.payload)))
    return log


def levels_from_log(log: dict, *, bin_rad: float = BIN_RAD, speed_tolerance: float = 0.1,
                    min_samples: int = 2) -> dict:
    """
    Return the friction levels of eq. (3) over position bins of every speed visit of a log.

    A sample is at constant speed when its measured |dq| is within ``speed_tolerance`` of the
    visit's set-point.  In each position bin (width ``bin_rad`` from the window's low end),
    the level is (mean forward current - mean backward current) / 2 where each direction has
    at least ``min_samples`` samples.  Columns: ``experiment`` (session x 100 + sweep),
    ``speed`` [rad/s joint, the set-point], ``friction`` [A], ``temperature`` [degC, the
    visit's mean reading], ``load`` [A, the bin's mean], ``position_min_rad``,
    ``position_max_rad``, ``session``, ``payload``, ``visit``, ``temperature_true``.
    """
    out: dict[str, list] = {k: [] for k in (
        'experiment', 'speed', 'friction', 'temperature', 'load', 'position_min_rad',
        'position_max_rad', 'session', 'payload', 'visit', 'temperature_true')}
    low = CENTRE_RAD - WINDOW_RAD / 2
    n_bins = int(round(WINDOW_RAD / bin_rad))
    key = log['session'] * 100000 + log['visit']
    for k in np.unique(key):
        rows = key == k
        v_set = float(log['speed_set_rad_s'][rows][0])
        dq = log['dq_rad_s'][rows]
        steady = np.abs(np.abs(dq) - v_set) <= speed_tolerance * v_set
        q = log['q_rad'][rows]
        b = np.clip(np.floor((q - low) / bin_rad).astype(int), 0, n_bins - 1)
        current = log['current_a'][rows]
        for i in range(n_bins):
            fwd = steady & (dq > 0) & (b == i)
            bwd = steady & (dq < 0) & (b == i)
            if fwd.sum() < min_samples or bwd.sum() < min_samples:
                continue
            out['friction'].append(0.5 * (current[fwd].mean() - current[bwd].mean()))
            out['speed'].append(v_set)
            out['temperature'].append(float(log['temperature_degc'][rows].mean()))
            out['temperature_true'].append(float(log['temperature_true_degc'][rows].mean()))
            out['load'].append(float(log['load_a'][rows][fwd | bwd].mean()))
            out['position_min_rad'].append(low + i * bin_rad)
            out['position_max_rad'].append(low + (i + 1) * bin_rad)
            session = int(log['session'][rows][0])
            out['session'].append(session)
            out['payload'].append(int(log['payload'][rows][0]))
            out['visit'].append(int(log['visit'][rows][0]))
            out['experiment'].append(session * 100 + int(log['sweep'][rows][0]))
    return {k: np.asarray(v) for k, v in out.items()}


#: The identification sessions: heat-up from different room temperatures, with and without
#: the payload.
IDENTIFICATION_SESSIONS = (
    Session(payload=False, room_degc=21.0), Session(payload=True, room_degc=22.0),
    Session(payload=False, room_degc=23.5, warm_degc=42.0),
    Session(payload=True, room_degc=21.5, warm_degc=43.0),
    Session(payload=False, room_degc=26.0, warm_degc=45.0),
    Session(payload=True, room_degc=24.0, warm_degc=42.0),
)


#: Identification sessions whose load columns overlap (0.7-2.2 A without the payload, about
#: 1.9-5.0 A with it: the other joints in other poses), so that no gap in the load column
#: tells the configurations apart; the ``payload`` column does.
OVERLAPPING_SESSIONS = (
    Session(payload=False, room_degc=21.0), Session(payload=True, room_degc=22.0,
                                                    gravity_scale=0.55),
    Session(payload=False, room_degc=23.5, warm_degc=42.0, gravity_scale=1.5),
    Session(payload=True, room_degc=21.5, warm_degc=43.0, gravity_scale=0.8),
    Session(payload=False, room_degc=26.0, warm_degc=45.0, gravity_scale=1.96),
    Session(payload=True, room_degc=24.0, warm_degc=42.0, gravity_scale=0.96),
)


def identification_levels(*, seed: int = 0,
                          sessions: Sequence[Session] = IDENTIFICATION_SESSIONS) -> dict:
    """Return the levels of eq. (3) over position bins of the identification sessions."""
    tables = [levels_from_log(log_session(s, seed=seed * 1000 + i, session_index=i))
              for i, s in enumerate(sessions)]
    return {k: np.concatenate([t[k] for t in tables]) for k in tables[0]}


def monitoring_groups(session: Session, *, seed: int, every_s: float = 480.0,
                      visit_s: float = 12.0,
                      speeds: Sequence[float] = SPEEDS_RAD_S) -> list[dict]:
    """
    Return the monitoring experiments run every ``every_s`` during a held-out heat-up session.

    Each experiment visits ``speeds`` once (``visit_s`` each, in random order); its levels are
    one per speed (the mean over the position bins, eq. (3) over the window).  Every group:
    ``speeds`` [rad/s joint], ``friction`` [A], ``temperature`` [degC, the mean reading],
    ``temperature_true`` [degC], ``load`` [A, mean].
    """
    rng = np.random.default_rng(seed)
    offset = float(rng.normal(0.0, OFFSET_STD))
    groups = []
    for start in np.arange(60.0, session.duration_s, every_s):
        parts, t0 = [], float(start)
        for v in rng.permutation(np.asarray(speeds, dtype=float)):
            part = _visit(float(v), t0, visit_s, rng)
            parts.append(part)
            t0 = float(part['t_s'][-1]) + 2.0
        log = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        q, dq = log['q_rad'], log.pop('dq_true')
        temperature = temperature_degc(session, log['t_s'])
        gravity = ((G_PAYLOAD if session.payload else G_EMPTY) * session.gravity_scale
                   * np.abs(np.cos(q)))
        friction = friction_current(dq, temperature, gravity, q, offset=offset,
                                    wear_fraction=session.wear_fraction)
        current = (np.tanh(dq / 0.05) * friction + gravity
                   + rng.normal(0.0, CURRENT_NOISE_STD, q.size))
        visit = np.repeat(np.arange(len(parts)), [p['q_rad'].size for p in parts])
        log.update(dq_rad_s=dq + rng.normal(0.0, SPEED_NOISE_STD, q.size), current_a=current,
                   temperature_degc=np.round(temperature + 0.3), load_a=gravity,
                   temperature_true_degc=temperature, speed_set_rad_s=log.pop('speed_set'),
                   session=np.zeros(q.size, dtype=int), payload=np.zeros(q.size, dtype=int),
                   visit=visit, sweep=np.zeros(q.size, dtype=int))
        levels = levels_from_log(log)
        speeds_out, friction_out = [], []
        for v in np.unique(levels['speed']):
            rows = levels['speed'] == v
            speeds_out.append(float(v))
            friction_out.append(float(levels['friction'][rows].mean()))
        groups.append({'speeds': np.asarray(speeds_out), 'friction': np.asarray(friction_out),
                       'temperature': float(log['temperature_degc'].mean()),
                       'temperature_true': float(temperature.mean()),
                       'load': float(levels['load'].mean())})
    return groups


def write_csv(path, columns: dict) -> None:
    """Write columns (equal-length sequences) as a CSV with a header row."""
    names = list(columns)
    lines = [','.join(names)]
    for row in zip(*(columns[n] for n in names)):
        lines.append(','.join(f'{float(x):.6g}' for x in row))
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write('\n'.join(lines) + '\n')
