"""
Steady-state friction model of a robot joint: nominal (5), wear profile (7), complete (8).

All functions broadcast their array arguments with numpy rules, so one call evaluates many speeds
and many operating points (T, w, load) at once.  Units: speed is motor side [rad/s] and must be
positive (the model describes the direction-independent friction level of eq. (3)); load torque
and friction are normalised [-]; temperature in degrees C; wear w is dimensionless (0 new,
100 failure).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.model.params import DirectionTerms, FrictionModel


@dataclass(frozen=True)
class FrictionWithGradients:
    """Friction of the complete model (8) and its partial derivatives, all of one shape."""

    friction: FloatArray
    d_temperature: FloatArray
    d_wear: FloatArray
    d_load: FloatArray


def _stribeck(speed: FloatArray, stribeck_speed: FloatArray | float, alpha: float) -> tuple:
    """Return exp(-|v/phi|^alpha) and |v/phi|^alpha (the latter for derivatives)."""
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        power = np.abs(speed / stribeck_speed) ** alpha
    return np.exp(-power), power


def _paper_load_sensitivity(speed: FloatArray, model: FrictionModel) -> FloatArray:
    decay, _ = _stribeck(speed, model.phi_s_load, model.alpha)
    return model.f_c_load + model.f_s_load * decay


def load_sensitivity(speed: ArrayLike, model: FrictionModel) -> FloatArray:
    """
    Return m(v) = d tau_f / d load of eq. (14): F_c,tl + F_s,tl exp(-|v/phi_s,tl|^alpha).

    With added terms in load, their load derivative at the extension's default load and
    temperature is added (exact for terms linear in load).
    """
    v = np.asarray(speed, dtype=float)
    m = _paper_load_sensitivity(v, model)
    if model.extension is not None:
        m = m + model.extension.load_sensitivity(v)
    return m


def nominal_friction(speed: ArrayLike, load: ArrayLike, temperature: ArrayLike,
                     model: FrictionModel) -> FloatArray:
    """
    Return the nominal (wear-free) friction level tau_f0 of eq. (5), normalised.

    :param speed: motor-side speed [rad/s], > 0.
    :param load: load torque tau_l (normalised, absolute value).
    :param temperature: joint temperature [degC].
    :param model: model coefficients.

    :return: The broadcast shape of the arguments.

    """
    v = np.asarray(speed, dtype=float)
    tl = np.asarray(load, dtype=float)
    t = np.asarray(temperature, dtype=float)
    load_term = model.f_c0 + tl * _paper_load_sensitivity(v, model)
    decay, _ = _stribeck(v, model.phi_s0 + model.phi_s_temp * t, model.alpha)
    stribeck_term = (model.f_s0 + model.f_s_temp * t) * decay
    viscous_term = (model.f_v0 + model.f_v_temp * np.exp(-t / model.t_v0)) * v
    value = load_term + stribeck_term + viscous_term
    if model.extension is not None:
        value = value + model.extension.nominal(v, tl, t)
    return value


def wear_friction(speed: ArrayLike, wear: ArrayLike, model: FrictionModel) -> FloatArray:
    """Return the wear profile tilde tau_f of eq. (7), normalised; 0 at w = 0."""
    v = np.asarray(speed, dtype=float)
    w = np.asarray(wear, dtype=float)
    decay, _ = _stribeck(v, model.phi_s_wear * w, model.alpha)
    decay = np.where(w > 0, decay, 0.0)
    value = model.f_s_wear * w * decay + model.f_v_wear * w * v
    if model.extension is not None and model.extension.wear_terms():
        value = value + model.extension.wear(v, w)
    return value


def friction(speed: ArrayLike, load: ArrayLike, temperature: ArrayLike, wear: ArrayLike,
             model: FrictionModel) -> FloatArray:
    """Return the complete friction model (8): tau_f0(v, tl, T) + tilde tau_f(v, w)."""
    return nominal_friction(speed, load, temperature, model) + wear_friction(speed, wear, model)


def friction_with_gradients(speed: ArrayLike, load: ArrayLike, temperature: ArrayLike,
                            wear: ArrayLike, model: FrictionModel) -> FrictionWithGradients:
    """Return the complete model (8) and its analytic derivatives in T [1/degC], w and load."""
    v, tl, t, w = np.broadcast_arrays(*(np.asarray(a, dtype=float)
                                        for a in (speed, load, temperature, wear)))
    m = _paper_load_sensitivity(v, model)

    stribeck_speed = model.phi_s0 + model.phi_s_temp * t
    decay_t, power_t = _stribeck(v, stribeck_speed, model.alpha)
    amplitude_t = model.f_s0 + model.f_s_temp * t
    viscous_decay = np.exp(-t / model.t_v0)
    # exp(-y) y -> 0 as y -> inf: where |v/phi|^a overflowed (a tiny Stribeck speed), the
    # products below are inf x 0 and are 0 (the order of the operations kept, bit for bit)
    with np.errstate(invalid='ignore', over='ignore'):
        d_temperature = (model.f_s_temp * decay_t
                         + amplitude_t * decay_t * model.alpha * power_t
                         * model.phi_s_temp / stribeck_speed
                         - model.f_v_temp / model.t_v0 * viscous_decay * v)
    d_temperature = np.where(np.isinf(power_t), model.f_s_temp * decay_t - model.f_v_temp
                             / model.t_v0 * viscous_decay * v, d_temperature)

    decay_w, power_w = _stribeck(v, model.phi_s_wear * w, model.alpha)
    positive = w > 0
    decay_w = np.where(positive, decay_w, 0.0)
    # d/dw [w exp(-|v/(phi w)|^a)] = exp(-x^a) (1 + a x^a); the limit at w -> 0+ is 0.
    with np.errstate(invalid='ignore', over='ignore'):
        growth = np.where(positive, decay_w * (1.0 + model.alpha * np.where(positive, power_w,
                                                                            0.0)), 0.0)
    growth = np.where(np.isinf(power_w) & positive, 0.0, growth)
    d_wear = model.f_s_wear * growth + model.f_v_wear * v

    value = (model.f_c0 + tl * m + amplitude_t * decay_t
             + (model.f_v0 + model.f_v_temp * viscous_decay) * v
             + model.f_s_wear * w * decay_w + model.f_v_wear * w * v)
    if model.extension is not None:
        added, slopes = model.extension.with_gradients(v, tl, t, w)
        value = value + added
        d_temperature = d_temperature + slopes['temperature']
        d_wear = d_wear + slopes['wear']
        m = m + slopes['load']
    return FrictionWithGradients(friction=value, d_temperature=d_temperature, d_wear=d_wear,
                                 d_load=m)


def marginal_covariance(speeds: ArrayLike, *, sigma: float, load_std: float,
                        model: FrictionModel) -> FloatArray:
    """
    Return Sigma(Phi) of eq. (14): sigma^2 I + sigma_tl^2 M M^T, shape (..., N, N).

    :param speeds: speed levels [rad/s], shape (..., N).
    :param sigma: std of the friction-level error of eq. (9b).
    :param load_std: std of the load estimate sigma_tl.
    :param model: model coefficients (for m(v)).

    """
    v = np.asarray(speeds, dtype=float)
    m = load_sensitivity(v, model)
    n = v.shape[-1]
    return sigma ** 2 * np.eye(n) + load_std ** 2 * m[..., :, None] * m[..., None, :]


def direction_friction(speed: ArrayLike,
                       direction_model: tuple[DirectionTerms, DirectionTerms]) -> FloatArray:
    """
    Return the friction of model (4) per direction of motion at signed ``speed`` [rad/s].

    ``direction_model`` is a parameter set's (positive, negative) terms; a positive speed
    takes the first, a negative one the second.  The result is the friction magnitude (the
    torque opposing the motion) in the set's unit; at speed 0 it is NaN (no direction).
    """
    v = np.asarray(speed, dtype=float)
    out = np.full(v.shape, np.nan)
    for terms, rows in zip(direction_model, (v > 0, v < 0)):
        magnitude = np.abs(v[rows])
        decay, _ = _stribeck(magnitude, terms.phi_s, terms.alpha)
        out[rows] = terms.f_c + terms.f_s * decay + terms.f_v * magnitude
    return out
