"""Parameter sets: the packaged default and the validation of bad files."""

from pathlib import Path
import re

import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import (default_parameter_file, load_parameter_set,
                                             ParameterError)
import yaml


def _default_document() -> dict:
    return yaml.safe_load(default_parameter_file().read_text())


def _write(tmp_path: Path, document, name='params.yaml') -> Path:
    path = tmp_path / name
    path.write_text(document if isinstance(document, str) else yaml.safe_dump(document))
    return path


def _parameters_md_table(seed_dir: Path) -> dict[str, float]:
    """Read the symbol/value rows of ../shared/seed/PARAMETERS.md."""
    values = {}
    for line in (seed_dir / 'PARAMETERS.md').read_text().splitlines():
        match = re.match(r'\|\s*([A-Za-z_,\.0-9]+)\s*\|\s*([-0-9.e]+)[^|]*\|', line)
        if match:
            values[match.group(1)] = float(match.group(2))
    return values


def test_default_set_matches_the_checked_parameters():
    """The packaged set holds the values that reproduce Tables IV and V (PARAMETERS.md)."""
    params = load_parameter_set()
    model = params.model
    expected = {
        'f_c0': 3.11e-2, 'f_c_load': 2.34e-2, 'f_s0': -2.50e-2, 'f_s_load': 1.26e-1,
        'f_s_temp': 1.60e-3, 'f_v0': 1.30e-4, 'f_v_temp': 1.32e-3, 'phi_s0': -24.81,
        'phi_s_load': 9.22, 'phi_s_temp': 0.98, 't_v0': 20.71, 'alpha': 1.36,
        'f_s_wear': 9.02e-4, 'f_v_wear': -5.15e-7, 'phi_s_wear': 2.19,
    }
    for name, value in expected.items():
        assert getattr(model, name) == pytest.approx(value, rel=1e-12), name
    assert params.sigma == pytest.approx((4.23e-3 ** 2 + 3.82e-3 ** 2) ** 0.5, rel=2e-3)
    assert (params.load_mean, params.load_std) == (0.5, 0.1)
    assert (params.temperature_min_degc, params.temperature_max_degc) == (30.0, 50.0)
    assert (params.speed_min_rad_s, params.speed_max_rad_s,
            params.speed_separation_rad_s) == (1.0, 280.0, 5.0)
    assert params.wear_threshold == 35.0


def test_default_set_agrees_with_shared_parameters_md():
    """Cross-check against ../shared/seed/PARAMETERS.md itself when it is present."""
    seed_dir = Path(__file__).resolve().parents[3] / 'shared' / 'seed'
    if not (seed_dir / 'PARAMETERS.md').exists():
        pytest.skip(f'{seed_dir}/PARAMETERS.md is absent (../shared not beside the clone)')
    table = _parameters_md_table(seed_dir)
    model = load_parameter_set().model
    pairs = {'F_c,0': model.f_c0, 'F_c,tl': model.f_c_load, 'F_s,0': model.f_s0,
             'F_s,tl': model.f_s_load, 'F_s,T': model.f_s_temp, 'F_v,0': model.f_v0,
             'F_v,T': model.f_v_temp, 'phi_s,0': model.phi_s0, 'phi_s,tl': model.phi_s_load,
             'phi_s,T': model.phi_s_temp, 'T_V0': model.t_v0, 'alpha': model.alpha,
             'F_s,w': model.f_s_wear, 'F_v,w': model.f_v_wear, 'phi_s,w': model.phi_s_wear}
    assert 'alpha' in table and table['alpha'] == 1.36
    for symbol, value in pairs.items():
        assert symbol in table, symbol
        assert value == pytest.approx(table[symbol], rel=1e-9), symbol


def _mutated(section, key, value):
    document = _default_document()
    if value is _DELETE:
        del document[section][key]
    else:
        document[section][key] = value
    return document


_DELETE = object()


@pytest.mark.parametrize('section,key,value,message', [
    ('noise', 'sigma', 0.0, 'noise.sigma: must be >= 1e-09'),
    ('noise', 'sigma', -1e-3, 'noise.sigma: must be >= 1e-09'),
    ('noise', 'sigma', _DELETE, 'missing key noise.sigma'),
    ('noise', 'sigma', 'small', "noise.sigma: expected a number, got str 'small'"),
    ('noise', 'sigma', '5e-3', 'write 1.0e-3'),
    ('noise', 'sigma', True, 'noise.sigma: expected a number, got bool'),
    ('noise', 'sigma', float('nan'), 'noise.sigma: must be finite'),
    ('load', 'std', -0.1, 'load.std: must be >= 0'),
    ('load', 'std', 1e4, 'load.std: must be <= 1e+06 x noise.sigma'),
    ('estimation', 'temperature_min_degc', 50.0,
     'estimation.temperature_min_degc: must be < estimation.temperature_max_degc'),
    ('estimation', 'temperature_max_degc', float('inf'), 'must be finite'),
    ('design', 'speed_min_rad_s', 0.0, 'design.speed_min_rad_s: must be > 0'),
    ('design', 'speed_max_rad_s', 0.5, 'must be < design.speed_max_rad_s'),
    ('alarm', 'wear_warning', 40.0, 'alarm.wear_warning: must be between 0'),
    ('nominal_model', 'alpha', 0.0, 'nominal_model.alpha: must be > 0'),
    ('nominal_model', 'alpha', 147.0, 'nominal_model.alpha: must be > 0 and <= 10'),
    ('estimation', 'wear_max', 1.5, 'estimation.wear_max: must be >= 10 and >= alarm'),
    ('estimation', 'wear_max', 30.0, 'estimation.wear_max: must be >= 10 and >= alarm'),
    ('estimation', 'wear_max', 1e300, 'estimation.wear_max: must be within +-1e+06'),
    ('noise', 'sigma', 1e-300, 'noise.sigma: must be >= 1e-09'),
    ('load', 'mean', 10**400, 'load.mean: must be finite'),
    ('estimation', 'temperature_max_degc', 5000.0, 'must be between -273.15 and 1000 degC'),
    ('wear_model', 'phi_s_wear', 0.0, 'wear_model.phi_s_wear: must be > 0'),
    ('wear_model', 'f_s_wear', [1, 2], 'wear_model.f_s_wear: expected a number, got list'),
    ('noise', 'sigmaa', 1.0, 'unknown key noise.sigmaa'),
])
def test_invalid_values_name_file_and_field(tmp_path, section, key, value, message):
    path = _write(tmp_path, _mutated(section, key, value))
    with pytest.raises(ParameterError) as info:
        load_parameter_set(path)
    text = str(info.value)
    assert message in text
    assert str(path) in text
    assert '\n' not in text


@pytest.mark.parametrize('content,message', [
    ('[1, 2, 3]\n', 'expected a mapping at the top level, got list'),
    ('name: x\nnoise: [\n', 'not valid YAML'),
    ('', 'expected a mapping at the top level, got NoneType'),
])
def test_malformed_documents(tmp_path, content, message):
    path = _write(tmp_path, content)
    with pytest.raises(ParameterError, match=re.escape(message)):
        load_parameter_set(path)


def test_missing_section_and_unknown_section(tmp_path):
    document = _default_document()
    del document['wear_model']
    with pytest.raises(ParameterError, match="missing section 'wear_model'"):
        load_parameter_set(_write(tmp_path, document))
    document = _default_document()
    document['extra'] = {'a': 1}
    with pytest.raises(ParameterError, match="unknown section 'extra'"):
        load_parameter_set(_write(tmp_path, document, 'b.yaml'))


def test_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match='cannot read parameter file'):
        load_parameter_set(tmp_path / 'nope.yaml')


def test_stribeck_speed_zero_inside_bounds_is_rejected(tmp_path):
    document = _default_document()
    document['nominal_model']['phi_s0'] = -30.0 * 0.98  # phi_s(T) = 0 at T = 30 degC
    with pytest.raises(ParameterError, match='Stribeck speed'):
        load_parameter_set(_write(tmp_path, document))


def test_with_overrides_validates():
    params = load_parameter_set()
    changed = params.with_overrides(wear_threshold=40.0)
    assert changed.wear_threshold == 40.0 and params.wear_threshold == 35.0
    with pytest.raises(ParameterError, match='alarm.wear_threshold'):
        params.with_overrides(wear_threshold=-1.0)
    with pytest.raises(ParameterError, match='unknown parameter'):
        params.with_overrides(colour=1.0)
