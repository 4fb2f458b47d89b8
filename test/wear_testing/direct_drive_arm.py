"""
A stand-in for a direct-drive two-joint arm's measured friction levels, and raw runs.

An independent generator (numpy only: no model, segmentation or audit code of the package).

Levels (:func:`arm_levels`)
---------------------------
Two joints (``joint`` 1 and 2) of a direct-drive arm (no gear: joint speed = motor speed), each
measured at signed speeds from 0.002 to 1.6 rad/s in both directions in a run ``exp``, and a
repeat run ``exp2`` of 17 of those set-points (both directions) on another day.  Per level:
``speed`` [rad/s, signed], ``friction`` [N m, the signed torque of the level: negative at
negative speeds], ``experiment`` (``exp`` / ``exp2``), ``joint``, and the position window
``position_min_rad`` / ``position_max_rad`` the level was averaged over.

Friction magnitude of a level at speed v (|v| = s) in direction d::

    F_c[d] + F_s[d] exp(-(s / phi_s[d])^alpha[d]) + F_v[d] s        (model (4) per direction)
    + drift x centre x (s / 1.6)^2                                   (position, high speed)
    + offset  (exp2 only)                                            (session offset)
    + e                                                              (level error, std noise)

where ``centre`` is the middle of the level's window: the window sits where the trajectory
program reached the set-point speed, which varies from set-point to set-point (more at high
speed, where the run-up takes more travel) and is the same in the repeat (within 0.01 rad), so
friction that changes along the joint's travel enters the levels as a drift with the window's
position at high speed.

Raw runs (:func:`raw_run`)
--------------------------
Samples of one joint moved back and forth over a window at a list of speed set-points, logged
at ``rate_hz`` (e.g. 2 Hz, a lab's slow logger, or 200 Hz): columns ``t_s, q_rad, dq_rad_s,
tau_measured_Nm`` (the KUKA raw-run layout).  torque = gravity (``gravity_Nm`` x cos q) + sign(v)
x friction(|v|) of the joint's positive-direction terms + white noise; velocity with white
noise; the plateau is preceded by a short ramp (half of ``ramp_s`` each end).
"""

from __future__ import annotations

import numpy as np

#: Per joint, per direction: (F_c [N m], F_s [N m], phi_s [rad/s], alpha, F_v [N m s/rad]).
TERMS = {
    '1': {'positive': (0.300, 0.150, 0.010, 1.0, 0.300),
          'negative': (0.340, 0.060, 0.060, 1.5, 0.180)},
    '2': {'positive': (0.140, 0.050, 0.008, 1.2, 0.090),
          'negative': (0.120, 0.100, 0.040, 0.8, 0.160)},
}
#: Friction drift along the window at high speed [N m / rad at 1.6 rad/s], per joint.
DRIFT = {'1': 0.100, '2': 0.060}
#: Session offset of the repeat run exp2 [N m], per joint.
OFFSET = {'1': 0.010, '2': 0.006}
#: Level error std [N m], per joint.
NOISE = {'1': 0.004, '2': 0.0025}
#: The set-point speeds of ``exp`` [rad/s] (each in both directions) and those repeated.
SPEEDS = np.geomspace(0.002, 1.6, 24)
REPEATED = SPEEDS[np.round(np.linspace(0, SPEEDS.size - 1, 17)).astype(int)]


def magnitude(joint: str, direction: str, speed) -> np.ndarray:
    """Return the model (4) friction [N m] of a joint's direction at |speed| [rad/s]."""
    f_c, f_s, phi, alpha, f_v = TERMS[joint][direction]
    s = np.abs(np.asarray(speed, dtype=float))
    return f_c + f_s * np.exp(-(s / phi) ** alpha) + f_v * s


def arm_levels(*, seed: int = 0, drift: dict | None = None,
               offset: dict | None = None) -> dict:
    """Return the columns of the two joints' levels (see the module text)."""
    rng = np.random.default_rng(seed)
    drift = DRIFT if drift is None else drift
    offset = OFFSET if offset is None else offset
    columns: dict = {k: [] for k in ('speed', 'friction', 'experiment', 'joint',
                                     'position_min_rad', 'position_max_rad')}
    # the window of a set-point is where the trajectory program put it: the same in the
    # repeat (within a jitter of 0.01 rad), more spread at high speed
    centres = {(joint, float(s), direction): rng.uniform(-0.3, 0.3) * (0.2 + s / SPEEDS[-1])
               for joint in TERMS for s in SPEEDS for direction in ('positive', 'negative')}
    for joint in TERMS:
        for run, speeds in (('exp', SPEEDS), ('exp2', REPEATED)):
            for s in speeds:
                for direction, sign in (('positive', 1.0), ('negative', -1.0)):
                    span = 0.05 + 0.4 * s / SPEEDS[-1]
                    centre = centres[joint, float(s), direction] + rng.normal(0.0, 0.01)
                    value = (magnitude(joint, direction, s)
                             + drift[joint] * centre * (s / SPEEDS[-1]) ** 2
                             + (offset[joint] if run == 'exp2' else 0.0)
                             + rng.normal(0.0, NOISE[joint]))
                    columns['speed'].append(sign * s)
                    columns['friction'].append(sign * value)
                    columns['experiment'].append(run)
                    columns['joint'].append(joint)
                    columns['position_min_rad'].append(centre - 0.5 * span)
                    columns['position_max_rad'].append(centre + 0.5 * span)
    return {k: np.array(v) for k, v in columns.items()}


def levels_csv(path, columns: dict) -> None:
    """Write level columns as a CSV table (header row; numbers at full precision)."""
    names = list(columns)
    rows = zip(*(columns[k] for k in names))
    path.write_text(','.join(names) + '\n' + ''.join(
        ','.join(repr(float(x)) if isinstance(x, (float, np.floating)) else str(x)
                 for x in row) + '\n' for row in rows))


def raw_run(path, *, speeds, rate_hz: float, joint: str = '1', cycles: int = 3,
            travel_rad: float = 0.6, centre_rad: float = 0.2, ramp_s: float = 0.2,
            dwell_s: float = 1.0, gravity_nm: float = 2.0, torque_noise_nm: float = 0.01,
            velocity_noise_rad_s: float = 0.002, seed: int = 0) -> dict:
    """
    Write a back-and-forth raw run (KUKA columns) and return its truth.

    Each set-point of ``speeds`` [rad/s] is run ``cycles`` times forward and backward across
    ``travel_rad`` around ``centre_rad`` (standstill ``dwell_s`` between passes); the samples
    are taken at ``rate_hz``.  Returns {'friction': friction per set-point (the positive
    direction's terms), 'speeds': the set-points}.
    """
    rng = np.random.default_rng(seed)
    # the motion on a fine time grid, then sampled at the logger's rate
    fine = 1000.0
    pieces_v = []
    for s in speeds:
        plateau = travel_rad / s - ramp_s / 2.0
        n_ramp = max(int(round(ramp_s / 2.0 * fine)), 1)
        ramp = np.linspace(0.0, s, n_ramp, endpoint=False)
        profile = np.concatenate([ramp, np.full(int(round(plateau * fine)), s), ramp[::-1]])
        still = np.zeros(int(round(dwell_s * fine)))
        for _ in range(cycles):
            pieces_v += [still, profile, still, -profile]
    v_fine = np.concatenate(pieces_v + [np.zeros(int(round(dwell_s * fine)))])
    q_fine = centre_rad - 0.5 * travel_rad + np.cumsum(v_fine) / fine
    t_fine = np.arange(v_fine.size) / fine
    t = np.arange(0.0, t_fine[-1], 1.0 / rate_hz)
    index = np.minimum(np.round(t * fine).astype(int), v_fine.size - 1)
    v, q = v_fine[index], q_fine[index]
    friction = np.where(v != 0.0, magnitude(joint, 'positive', v), 0.0)
    tau = gravity_nm * np.cos(q) + np.sign(v) * friction + rng.normal(0, torque_noise_nm, t.size)
    dq = v + rng.normal(0.0, velocity_noise_rad_s, t.size)
    rows = zip(t.tolist(), q.tolist(), dq.tolist(), tau.tolist())
    path.write_text('t_s,q_rad,dq_rad_s,tau_measured_Nm\n' + ''.join(
        f'{a!r},{b!r},{c!r},{d!r}\n' for a, b, c, d in rows))
    return {'speeds': np.asarray(speeds, dtype=float),
            'friction': magnitude(joint, 'positive', np.asarray(speeds, dtype=float))}
