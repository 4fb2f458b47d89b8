"""Added terms (the ``added_terms`` section): loading, validation, values and gradients."""

import dataclasses

import numpy as np
import pytest
from robot_wear_monitor.model import friction as fm
from robot_wear_monitor.model.params import (default_parameter_file, load_parameter_set,
                                             parameter_set_yaml_text, ParameterError)
import yaml

PARAMS = load_parameter_set()

SECTION = {
    'defaults': {'position': 0.3, 'pose': 'standard', 'load': 0.5, 'temperature': 40.0},
    'terms': [
        {'name': 'smooth in temperature', 'factors': [
            {'variable': 'temperature', 'basis': 'spline', 'lower': 30.0, 'upper': 50.0,
             'knots': [0.1, 0.4, 0.7, 0.9]}], 'coefficients': [2e-3, 5e-3, -4e-3]},
        {'name': 'Stribeck amplitude varies with load', 'factors': [
            {'variable': 'speed', 'basis': 'stribeck', 'stribeck_speed': 20.0, 'alpha': 1.4},
            {'variable': 'load', 'basis': 'polynomial', 'lower': 0.0, 'upper': 1.0,
             'degree': 2, 'constant': True}], 'coefficients': [1e-3, 4e-3, 6e-3]},
        {'name': 'ripple in position', 'factors': [
            {'variable': 'position', 'basis': 'periodic', 'period': 0.7}],
         'coefficients': [2e-3, -1e-3]},
        {'name': 'offset per pose', 'factors': [
            {'variable': 'pose', 'basis': 'categories', 'levels': ['new', 'standard']}],
         'coefficients': [0.0, 3e-3]},
        {'name': 'speed x wear', 'factors': [
            {'variable': 'speed', 'basis': 'log_polynomial', 'log_lower': 0.0,
             'log_upper': 6.0, 'degree': 3},
            {'variable': 'wear', 'basis': 'identity'}],
         'coefficients': [1e-5, 2e-5, -1e-5, 3e-6]},
    ]}


def write_set(tmp_path, section=SECTION, name='extended.yaml'):
    document = yaml.safe_load(default_parameter_file().read_text())
    document['added_terms'] = section
    path = tmp_path / name
    path.write_text(yaml.safe_dump(document))
    return path


def test_every_packaged_file_loads_without_the_section():
    assert PARAMS.model.extension is None


def test_extended_set_adds_its_terms_to_nominal_and_wear_parts(tmp_path):
    params = load_parameter_set(write_set(tmp_path))
    ext = params.model.extension
    assert ext.offline_variables == ('position', 'pose')
    v = np.array([2.1, 15.3, 82.2, 236.2])
    t, load, w = 41.0, 0.6, 20.0
    base = fm.friction(v, load, t, w, PARAMS.model)
    extended = fm.friction(v, load, t, w, params.model)
    added = (extended - base)
    nominal_added = fm.nominal_friction(v, load, t, params.model) - fm.nominal_friction(
        v, load, t, PARAMS.model)
    wear_added = fm.wear_friction(v, w, params.model) - fm.wear_friction(v, w, PARAMS.model)
    np.testing.assert_allclose(added, nominal_added + wear_added, rtol=1e-12)
    # the position ripple at its default 0.3 and the pose offset at 'standard'
    ripple = 2e-3 * np.sin(2 * np.pi * 0.3 / 0.7) - 1e-3 * np.cos(2 * np.pi * 0.3 / 0.7)
    z = (t - 30.0) / 20.0
    knots = [0.1, 0.4, 0.7, 0.9]
    spline = [z - 0.5] + [max(z - k, 0) ** 3 - max(z - 0.7, 0) ** 3 * (0.9 - k) / 0.2
                          + max(z - 0.9, 0) ** 3 * (0.7 - k) / 0.2 for k in knots[:2]]
    smooth = float(np.dot(spline, [2e-3, 5e-3, -4e-3]))
    amplitude = 1e-3 + 4e-3 * (load - 0.5) + 6e-3 * (load - 0.5) ** 2
    stribeck = np.exp(-np.abs(v / 20.0) ** 1.4) * amplitude
    np.testing.assert_allclose(nominal_added, smooth + stribeck + ripple + 3e-3, rtol=1e-10)
    assert np.all(np.abs(wear_added) > 0)


def test_gradients_match_finite_differences(tmp_path):
    model = load_parameter_set(write_set(tmp_path)).model
    v = np.array([2.1, 8.7, 41.7, 133.5, 287.1])
    t, load, w = 37.3, 0.45, 12.0
    g = fm.friction_with_gradients(v, load, t, w, model)
    h = 1e-5
    for name, analytic, args in (
            ('temperature', g.d_temperature, lambda d: (v, load, t + d, w)),
            ('wear', g.d_wear, lambda d: (v, load, t, w + d)),
            ('load', g.d_load, lambda d: (v, load + d, t, w))):
        numeric = (fm.friction(*args(h), model) - fm.friction(*args(-h), model)) / (2 * h)
        np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-9, err_msg=name)
    np.testing.assert_allclose(g.friction, fm.friction(v, load, t, w, model), rtol=1e-12)


def test_load_sensitivity_is_the_derivative_at_the_default_load(tmp_path):
    model = load_parameter_set(write_set(tmp_path)).model
    v = np.array([5.0, 50.0])
    at_default = fm.friction_with_gradients(v, 0.5, 40.0, 0.0, model).d_load
    np.testing.assert_allclose(fm.load_sensitivity(v, model), at_default, rtol=1e-12)


def test_extended_model_is_hashable_and_equal_after_a_round_trip(tmp_path):
    params = load_parameter_set(write_set(tmp_path))
    hash(params.model)
    again = tmp_path / 'again.yaml'
    again.write_text(parameter_set_yaml_text(params, header='round trip'))
    reloaded = load_parameter_set(again)
    assert reloaded.model == params.model
    assert dataclasses.replace(reloaded, source=params.source) == params


@pytest.mark.parametrize('change, message', [
    (lambda s: s['terms'][0].update(coefficients=[1.0]),
     'added_terms.terms[0].coefficients: expected 3 numbers'),
    (lambda s: s['terms'][0]['factors'][0].update(basis='wavelet'),
     'added_terms.terms[0].factors[0].basis: expected one of'),
    (lambda s: s['terms'][0]['factors'][0].update(knots=[0.5, 0.4, 0.9]),
     'added_terms.terms[0].factors[0].knots: must increase strictly'),
    (lambda s: s['terms'][2]['factors'][0].update(period=-1.0),
     'added_terms.terms[2].factors[0].period: must be > 0'),
    (lambda s: s['defaults'].pop('position'),
     'added_terms.defaults.position: missing'),
    (lambda s: s['terms'][1]['factors'][0].update(alpha='1e-3'),
     'added_terms.terms[1].factors[0].alpha: expected a number'),
    (lambda s: s['terms'][4]['factors'].append({'variable': 'load', 'basis': 'identity'}),
     'a term in wear and temperature or load is not supported'),
    (lambda s: s.update(extra=1), 'added_terms.extra: unknown key'),
])
def test_invalid_sections_name_the_field(tmp_path, change, message):
    section = yaml.safe_load(yaml.safe_dump(SECTION))
    change(section)
    with pytest.raises(ParameterError, match='extended.yaml') as error:
        load_parameter_set(write_set(tmp_path, section))
    assert message in str(error.value)


def test_estimator_intervals_and_design_run_the_extended_model(tmp_path):
    """Without any change of theirs: levels of the extended model are estimated right by it."""
    from robot_wear_monitor.estimation.design import design_cost
    from robot_wear_monitor.estimation.estimator import estimate_wear
    from robot_wear_monitor.estimation.intervals import wear_intervals
    params = load_parameter_set(write_set(tmp_path))
    speeds = np.array([2.1, 8.7, 15.3, 28.5, 41.7, 82.2, 133.5, 236.2])
    levels = fm.friction(speeds, params.load_mean, 41.0, 30.0, params.model)
    extended = estimate_wear(speeds, levels, params=params)[0]
    paper = estimate_wear(speeds, levels, params=PARAMS)[0]
    assert abs(extended.wear - 30.0) < 0.5 and abs(extended.temperature_degc - 41.0) < 0.2
    assert abs(paper.wear - 30.0) > 2.0  # the paper's model misreads the added terms
    interval = wear_intervals(speeds, levels, params=params)[0]
    assert interval.wear_low <= 30.0 <= interval.wear_high
    cost = design_cost(speeds_rad_s=speeds[:3], params=params)
    assert np.isfinite(cost).all() and cost != design_cost(speeds_rad_s=speeds[:3],
                                                           params=PARAMS)
