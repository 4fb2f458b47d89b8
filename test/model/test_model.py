"""Friction model (5), (7), (8): structure, gradients, covariance, and the paper's statements."""

import dataclasses
import warnings

import numpy as np
import pytest
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import load_parameter_set

PARAMS = load_parameter_set()
MODEL = PARAMS.model
GRID_27 = np.array([2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1])


def test_complete_model_is_nominal_plus_wear_and_wear_free_at_zero():
    v = np.linspace(1.0, 290.0, 50)
    nominal = fm.nominal_friction(v, 0.3, 42.0, MODEL)
    assert np.allclose(fm.wear_friction(v, 0.0, MODEL), 0.0)
    assert np.allclose(fm.friction(v, 0.3, 42.0, 0.0, MODEL), nominal)
    total = fm.friction(v, 0.3, 42.0, 35.0, MODEL)
    assert np.allclose(total - nominal, fm.wear_friction(v, 35.0, MODEL))


def test_nominal_model_by_hand_at_one_point():
    """Eq. (5) written out term by term at v = 35.1, tl = 0.5, T = 40."""
    v, tl, t = 35.1, 0.5, 40.0
    m = MODEL
    expected = (m.f_c0 + m.f_c_load * tl
                + m.f_s_load * tl * np.exp(-abs(v / m.phi_s_load) ** m.alpha)
                + (m.f_s0 + m.f_s_temp * t)
                * np.exp(-abs(v / (m.phi_s0 + m.phi_s_temp * t)) ** m.alpha)
                + (m.f_v0 + m.f_v_temp * np.exp(-t / m.t_v0)) * v)
    assert fm.nominal_friction(v, tl, t, MODEL) == pytest.approx(expected, rel=1e-14)
    wear = m.f_s_wear * 35 * np.exp(-abs(v / (m.phi_s_wear * 35)) ** m.alpha) + m.f_v_wear * 35 * v
    assert fm.wear_friction(v, 35.0, MODEL) == pytest.approx(wear, rel=1e-14)


def test_broadcasting_over_speeds_and_operating_points():
    v = GRID_27[None, :]
    temperature = np.array([30.0, 40.0, 50.0])[:, None]
    wear = np.array([0.0, 35.0, 70.0])[:, None]
    value = fm.friction(v, 0.5, temperature, wear, MODEL)
    assert value.shape == (3, 12)
    for row in range(3):
        assert np.allclose(value[row], fm.friction(GRID_27, 0.5, temperature[row, 0],
                                                   wear[row, 0], MODEL))


@pytest.mark.parametrize('temperature,wear,load', [(30.0, 0.5, 0.2), (40.0, 35.0, 0.5),
                                                   (50.0, 90.0, 0.8), (33.0, 5.0, 0.0)])
def test_gradients_against_central_differences(temperature, wear, load):
    v = np.concatenate([GRID_27, [1.0, 50.0, 280.0]])
    grads = fm.friction_with_gradients(v, load, temperature, wear, MODEL)
    assert np.allclose(grads.friction, fm.friction(v, load, temperature, wear, MODEL),
                       rtol=1e-13, atol=1e-15)
    h = 1e-5

    def diff(dt=0.0, dw=0.0, dl=0.0):
        plus = fm.friction(v, load + dl, temperature + dt, wear + dw, MODEL)
        minus = fm.friction(v, load - dl, temperature - dt, wear - dw, MODEL)
        return (plus - minus) / (2 * h)

    assert np.allclose(grads.d_temperature, diff(dt=h), rtol=1e-6, atol=1e-10)
    assert np.allclose(grads.d_wear, diff(dw=h), rtol=1e-6, atol=1e-10)
    assert np.allclose(grads.d_load, diff(dl=h), rtol=1e-6, atol=1e-10)


def test_wear_gradient_at_zero_wear_is_the_one_sided_limit():
    v = GRID_27
    grads = fm.friction_with_gradients(v, 0.5, 40.0, 0.0, MODEL)
    h = 1e-6
    one_sided = (fm.friction(v, 0.5, 40.0, h, MODEL) - fm.friction(v, 0.5, 40.0, 0.0, MODEL)) / h
    assert np.all(np.isfinite(grads.d_wear))
    assert np.allclose(grads.d_wear, one_sided, rtol=1e-4, atol=1e-9)


def test_a_stribeck_speed_so_small_that_the_power_overflows_gives_finite_gradients():
    """
    A parameter file's phi_s,w of 6.6e-303 (found by the fuzz test): |v/phi|^a overflows.

    exp(-y) y -> 0 as y -> inf, so the gradients are the limits (finite, no warning), and away
    from the overflow they equal those of the packaged model computed the usual way.
    """
    tiny = dataclasses.replace(MODEL, phi_s_wear=6.550927493014958e-303, phi_s0=1e-300)
    v = GRID_27
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        grads = fm.friction_with_gradients(v, 0.5, 40.0, 35.0, tiny)
    assert np.all(np.isfinite(grads.d_wear)) and np.all(np.isfinite(grads.d_temperature))
    # the Stribeck terms have died out: only the viscous parts remain
    assert np.allclose(grads.d_wear, tiny.f_v_wear * v)
    usual = fm.friction_with_gradients(v, 0.5, 40.0, 35.0, MODEL)
    assert not np.allclose(usual.d_wear, MODEL.f_v_wear * v)


def test_paper_fig6_wear_information_dominates_between_30_and_50_rad_s():
    """Sec. IV-B: at [T, w] = [40, 35], |f'_w| > 2 |f'_T| 'for the speed region of 30-50'."""
    v = np.linspace(31.0, 45.0, 29)
    grads = fm.friction_with_gradients(v, 0.5, 40.0, 35.0, MODEL)
    ratio = np.abs(grads.d_wear) / np.abs(grads.d_temperature)
    assert np.all(ratio > 2.0)
    # ...and not at high speed, where temperature dominates (Fig. 6a).
    fast = fm.friction_with_gradients(np.array([133.5, 236.2]), 0.5, 40.0, 35.0, MODEL)
    assert np.all(np.abs(fast.d_temperature) > np.abs(fast.d_wear))


def test_paper_fig5_wear_effect_concentrated_below_150_rad_s():
    """Sec. II-D: the wear effects are concentrated in the speed range 0-150 rad/s."""
    v = np.linspace(1.0, 290.0, 600)
    profile = fm.wear_friction(v, 100.0, MODEL)
    peak = np.max(np.abs(profile))
    assert v[np.argmax(profile)] < 150.0
    assert np.all(np.abs(profile[v > 250.0]) < 0.25 * peak)


def test_marginal_covariance_equals_the_load_induced_covariance():
    """Eq. (14): friction with a Gaussian load has covariance sigma^2 I + sigma_tl^2 M M^T."""
    speeds = np.array([2.1, 28.5, 35.1, 41.7])
    covariance = fm.marginal_covariance(speeds, sigma=PARAMS.sigma, load_std=PARAMS.load_std,
                                        model=MODEL)
    rng = np.random.default_rng(3)
    loads = rng.normal(PARAMS.load_mean, PARAMS.load_std, size=200_000)
    samples = (fm.friction(speeds[None, :], loads[:, None], 40.0, 35.0, MODEL)
               + rng.normal(0.0, PARAMS.sigma, size=(loads.size, speeds.size)))
    empirical = np.cov(samples, rowvar=False)
    assert np.allclose(empirical, covariance, rtol=0.03, atol=2e-6)
    assert np.all(np.linalg.eigvalsh(covariance) > 0)
    batch = fm.marginal_covariance(np.stack([speeds, speeds + 1.0]), sigma=PARAMS.sigma,
                                   load_std=PARAMS.load_std, model=MODEL)
    assert batch.shape == (2, 4, 4)
    assert np.allclose(batch[0], covariance)
