"""
Parameter sets of the friction model and the wear monitor, read from YAML and validated.

A parameter set holds the coefficients of the nominal friction model (5) and of the wear profile
(7), the measurement model of eqs. (9)-(14) (noise sigma, load mean and std), the temperature
bounds of the estimator (16), the design bounds of (24) and the alarm thresholds.  Units: torques
are normalised (dimensionless), speeds are motor side in rad/s, temperatures in degrees C.

Every field is required.  Loading reports the first problem as a :class:`ParameterError` that names
the file and the dotted field (``noise.sigma``), so that a maintenance engineer can fix the file.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
import math
import os
from pathlib import Path
import sys
from typing import Any, Mapping

from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.extensions import (extension_from_mapping, extension_to_mapping,
                                                 ExtensionError, ModelExtension)
from robot_wear_monitor.yaml_files import load_yaml_file, shorten
import yaml

PACKAGE_NAME = 'robot_wear_monitor'
DEFAULT_PARAMETER_FILE = 'irb6620_joint2.yaml'


class ParameterError(InputError):
    """A parameter file or value is invalid; the message names the file and the field."""


@dataclass(frozen=True)
class FrictionModel:
    """
    Coefficients of the complete friction model (8) = nominal (5) + wear profile (7).

    Units: torques normalised; speeds motor side [rad/s]; temperatures [degC]; wear w is the
    dimensionless wear level of the paper (0 = new, 100 = failure).  ``extension`` holds the
    terms an audit added (optional section ``added_terms`` of the YAML file, see
    :mod:`robot_wear_monitor.model.extensions`); None for the paper's model.
    """

    f_c0: float
    f_c_load: float
    f_s0: float
    f_s_load: float
    f_s_temp: float
    f_v0: float
    f_v_temp: float
    phi_s0: float
    phi_s_load: float
    phi_s_temp: float
    t_v0: float
    alpha: float
    f_s_wear: float
    f_v_wear: float
    phi_s_wear: float
    extension: ModelExtension | None = None


@dataclass(frozen=True)
class DirectionTerms:
    """
    Model (4) of one direction of motion: f = f_c + f_s exp(-|v/phi_s|^alpha) + f_v |v|.

    At the conditions of the data the set was identified from; friction in the set's unit,
    speeds motor side [rad/s], f_v [friction/(rad/s)].
    """

    f_c: float
    f_s: float
    phi_s: float
    alpha: float
    f_v: float


#: The keys of a direction's terms in the ``direction_model`` section, in order.
DIRECTION_KEYS = ('f_c', 'f_s', 'phi_s', 'alpha', 'f_v')
#: The directions of motion of the ``direction_model`` section (signed speed > 0, < 0).
DIRECTIONS = ('positive', 'negative')


@dataclass(frozen=True)
class ParameterSet:
    """A validated parameter set: model, measurement model, bounds and alarm thresholds."""

    name: str
    model: FrictionModel
    sigma: float
    load_mean: float
    load_std: float
    temperature_min_degc: float
    temperature_max_degc: float
    wear_max: float
    speed_min_rad_s: float
    speed_max_rad_s: float
    speed_separation_rad_s: float
    design_temperature_degc: float
    design_wear: float
    wear_threshold: float
    wear_warning: float
    source: str = '<built-in>'
    #: what the set's data could not identify (``temperature``, ``load``, ``wear``): the terms
    #: in them are zero or borrowed, and what needs them is refused (:meth:`require`)
    not_identified: tuple[str, ...] = ()
    #: the unit of the friction levels the set describes (``normalised`` or e.g. ``N.m``)
    friction_unit: str = 'normalised'
    #: model (4) per direction of motion (positive, negative) when the data said the
    #: directions differ (optional section ``direction_model``); None: symmetric.  Levels of
    #: eq. (3) are the mean of the two directions, which the nominal model describes.
    direction_model: tuple[DirectionTerms, DirectionTerms] | None = None

    def require(self, *what: str, purpose: str) -> None:
        """
        Raise ParameterError when the set did not identify one of ``what`` (e.g. 'wear').

        ``purpose`` says what needs it, e.g. ``'estimating wear'``.
        """
        missing = [w for w in what if w in self.not_identified]
        if missing:
            raise ParameterError(
                f'{self.source}: parameter set {self.name!r} did not identify '
                f'{" and ".join(missing)} (its data had no {" or ".join(missing)} variation): '
                f'{purpose} needs it; identify it from data that vary it (identify --wear-test '
                'for wear)')

    @property
    def estimates_wear(self) -> bool:
        """
        Return False for a set without a wear model (``identify --no-wear-model``).

        Such a set (``not_identified`` holds ``wear``) estimates the temperature only: w-hat is
        not determined and raises no alarm.
        """
        return 'wear' not in self.not_identified

    def require_estimator(self, *, purpose: str) -> None:
        """
        Raise ParameterError unless the estimator (16)-(19) can run with this set.

        It needs the temperature and load terms; a set without a wear model (only ``wear``
        not identified) estimates T-hat alone.
        """
        if {'temperature', 'load'} & set(self.not_identified):
            self.require('wear', 'temperature', 'load', purpose=purpose)

    def with_overrides(self, **changes: Any) -> 'ParameterSet':
        """Return a copy with some scalar fields replaced, validated like a loaded file."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        unknown = sorted(set(changes) - set(values) - {'model'})
        if unknown:
            raise ParameterError(f'{self.source}: unknown parameter(s) {", ".join(unknown)}')
        values.update(changes)
        candidate = ParameterSet(**values)
        _check_constraints(candidate, self.source)
        return candidate


_MODEL_SECTIONS = {
    'nominal_model': ('f_c0', 'f_c_load', 'f_s0', 'f_s_load', 'f_s_temp', 'f_v0', 'f_v_temp',
                      'phi_s0', 'phi_s_load', 'phi_s_temp', 't_v0', 'alpha'),
    'wear_model': ('f_s_wear', 'f_v_wear', 'phi_s_wear'),
}
#: Optional section of the terms an audit added (model/extensions.py).
_EXTENSION_SECTION = 'added_terms'
#: Optional section of what the identification could not identify, and the friction unit.
_IDENTIFICATION_SECTION = 'identification'
#: Optional section of model (4) per direction of motion.
_DIRECTION_SECTION = 'direction_model'
IDENTIFIABLE = ('temperature', 'load', 'wear')
# section -> {yaml key: ParameterSet field}
_SCALAR_SECTIONS = {
    'noise': {'sigma': 'sigma'},
    'load': {'mean': 'load_mean', 'std': 'load_std'},
    'estimation': {'temperature_min_degc': 'temperature_min_degc',
                   'temperature_max_degc': 'temperature_max_degc',
                   'wear_max': 'wear_max'},
    'design': {'speed_min_rad_s': 'speed_min_rad_s', 'speed_max_rad_s': 'speed_max_rad_s',
               'speed_separation_rad_s': 'speed_separation_rad_s',
               'temperature_degc': 'design_temperature_degc', 'wear': 'design_wear'},
    'alarm': {'wear_threshold': 'wear_threshold', 'wear_warning': 'wear_warning'},
}


#: The largest magnitude of any value in a parameter set (normalised torques are below 1,
#: torques in N.m below 1e4, motor speeds below 1e5 rad/s): far beyond it, products overflow.
MAX_MAGNITUDE = 1e6
#: Physical ranges of the values whose meaning fixes them: temperatures [degC], wear [w], the
#: smallest noise std a likelihood can be computed with [friction unit] (below about 1e-10
#: the covariance of eq. (14) is no longer positive definite in floating point).
TEMPERATURE_RANGE_DEGC = (-273.15, 1000.0)
WEAR_LIMIT = 1000.0
#: The smallest upper end of the wear start grid (the grid needs room for its points).
WEAR_MAX_MIN = 10.0
SIGMA_MIN = 1e-9
#: The largest ratio load.std / noise.sigma (the covariance's condition number is about its
#: square).
LOAD_TO_NOISE_MAX = 1e6
#: The largest Stribeck exponent alpha (fits use 0.3-5; the paper's is 1.36).
ALPHA_MAX = 10.0


def _number(value: Any, where: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = ''
        if isinstance(value, str):
            hint = (' (YAML reads numbers like 1e-3 as text: write 1.0e-3)'
                    if _looks_numeric(value) else '')
        raise ParameterError(f'{source}: {where}: expected a number, got '
                             f'{type(value).__name__} {shorten(repr(value))}{hint}')
    try:
        number = float(value)
    except OverflowError:  # a YAML integer of hundreds of digits
        number = math.inf if value > 0 else -math.inf
    if not math.isfinite(number):
        raise ParameterError(f'{source}: {where}: must be finite, got {shorten(number)}')
    if abs(number) > MAX_MAGNITUDE:
        raise ParameterError(f'{source}: {where}: must be within +-{MAX_MAGNITUDE:g} (no '
                             f'friction model, speed or temperature is larger), got '
                             f'{shorten(number)}')
    return number


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _section(document: Mapping[str, Any], key: str, expected: tuple, source: str) -> dict:
    if key not in document:
        raise ParameterError(f'{source}: missing section {shorten(repr(key))}')
    section = _mapping_of(document[key], key, expected, source)
    return {name: _number(section[name], f'{key}.{name}', source) for name in expected}


def _mapping_of(section: Any, key: str, expected: tuple, source: str) -> Mapping[str, Any]:
    """Return ``section`` when it is a mapping of exactly the keys ``expected``."""
    if not isinstance(section, Mapping):
        raise ParameterError(f'{source}: {key}: expected a mapping, got {type(section).__name__}')
    missing = [name for name in expected if name not in section]
    if missing:
        raise ParameterError(f'{source}: missing key {key}.{missing[0]}')
    extra = sorted(set(section) - set(expected))
    if extra:
        raise ParameterError(f'{source}: unknown key {key}.{shorten(str(extra[0]))} '
                             f'(expected {", ".join(expected)})')
    return section


def _check_constraints(params: ParameterSet, source: str) -> None:
    """Raise ParameterError for the first value outside its admissible range."""
    model = params.model
    checks = (
        (params.sigma >= SIGMA_MIN, 'noise.sigma', f'must be >= {SIGMA_MIN:g}', params.sigma),
        (all(TEMPERATURE_RANGE_DEGC[0] <= t <= TEMPERATURE_RANGE_DEGC[1] for t in (
            params.temperature_min_degc, params.temperature_max_degc,
            params.design_temperature_degc)),
         'estimation.temperature_min_degc/temperature_max_degc, design.temperature_degc',
         f'must be between {TEMPERATURE_RANGE_DEGC[0]:g} and {TEMPERATURE_RANGE_DEGC[1]:g} degC',
         (params.temperature_min_degc, params.temperature_max_degc,
          params.design_temperature_degc)),
        (params.wear_max <= WEAR_LIMIT, 'estimation.wear_max', f'must be <= {WEAR_LIMIT:g}',
         params.wear_max),
        (params.design_wear <= WEAR_LIMIT, 'design.wear', f'must be <= {WEAR_LIMIT:g}',
         params.design_wear),
        (params.load_std >= 0, 'load.std', 'must be >= 0', params.load_std),
        (params.load_std <= LOAD_TO_NOISE_MAX * params.sigma, 'load.std',
         f'must be <= {LOAD_TO_NOISE_MAX:g} x noise.sigma (the covariance of eq. (14) would not '
         'be positive definite in floating point)', params.load_std),
        (params.temperature_min_degc < params.temperature_max_degc,
         'estimation.temperature_min_degc', 'must be < estimation.temperature_max_degc',
         params.temperature_min_degc),
        (params.wear_max >= max(WEAR_MAX_MIN, params.wear_threshold), 'estimation.wear_max',
         f'must be >= {WEAR_MAX_MIN:g} and >= alarm.wear_threshold (the start grid reaches the '
         'alarm)', params.wear_max),
        (params.speed_min_rad_s > 0, 'design.speed_min_rad_s', 'must be > 0',
         params.speed_min_rad_s),
        (params.speed_min_rad_s < params.speed_max_rad_s, 'design.speed_min_rad_s',
         'must be < design.speed_max_rad_s', params.speed_min_rad_s),
        (params.speed_separation_rad_s >= 0, 'design.speed_separation_rad_s', 'must be >= 0',
         params.speed_separation_rad_s),
        (params.design_wear >= 0, 'design.wear', 'must be >= 0', params.design_wear),
        (params.wear_threshold > 0, 'alarm.wear_threshold', 'must be > 0',
         params.wear_threshold),
        (0 <= params.wear_warning <= params.wear_threshold, 'alarm.wear_warning',
         'must be between 0 and alarm.wear_threshold', params.wear_warning),
        (0 < model.alpha <= ALPHA_MAX, 'nominal_model.alpha',
         f'must be > 0 and <= {ALPHA_MAX:g} (a Stribeck exponent)', model.alpha),
        (model.t_v0 != 0, 'nominal_model.t_v0', 'must not be 0', model.t_v0),
        (model.phi_s_load != 0, 'nominal_model.phi_s_load', 'must not be 0', model.phi_s_load),
        (model.phi_s_wear > 0, 'wear_model.phi_s_wear', 'must be > 0', model.phi_s_wear),
    )
    for ok, where, rule, value in checks:
        if not ok:
            raise ParameterError(f'{source}: {where}: {rule}, got {shorten(value)}')
    for bound in (params.temperature_min_degc, params.temperature_max_degc,
                  params.design_temperature_degc):
        stribeck = model.phi_s0 + model.phi_s_temp * bound
        if stribeck == 0:
            raise ParameterError(
                f'{source}: nominal_model.phi_s0/phi_s_temp: the Stribeck speed '
                f'phi_s0 + phi_s_temp*T is 0 at T = {bound} degC')


def parameter_set_from_mapping(document: Any, *, source: str = '<mapping>') -> ParameterSet:
    """Validate a parsed YAML document and return the :class:`ParameterSet` it describes."""
    if not isinstance(document, Mapping):
        raise ParameterError(
            f'{source}: expected a mapping at the top level, got {type(document).__name__}')
    known = {'name', *_MODEL_SECTIONS, *_SCALAR_SECTIONS, _EXTENSION_SECTION,
             _IDENTIFICATION_SECTION, _DIRECTION_SECTION}
    extra = sorted(set(document) - known)
    if extra:
        raise ParameterError(f'{source}: unknown section {shorten(repr(extra[0]))}')
    name = document.get('name')
    if not isinstance(name, str) or not name.strip():
        raise ParameterError(f'{source}: name: expected a non-empty string, got '
                             f'{shorten(repr(name))}')
    coefficients: dict[str, float] = {}
    for key, expected in _MODEL_SECTIONS.items():
        coefficients.update(_section(document, key, expected, source))
    scalars: dict[str, Any] = {}
    for key, mapping in _SCALAR_SECTIONS.items():
        values = _section(document, key, tuple(mapping), source)
        scalars.update({mapping[k]: v for k, v in values.items()})
    extension = None
    if document.get(_EXTENSION_SECTION) is not None:
        try:
            extension = extension_from_mapping(document[_EXTENSION_SECTION], _EXTENSION_SECTION)
        except ExtensionError as error:
            raise ParameterError(f'{source}: {error}') from None
    params = ParameterSet(name=name, model=FrictionModel(**coefficients, extension=extension),
                          source=source, **scalars,
                          **_identification(document.get(_IDENTIFICATION_SECTION), source),
                          direction_model=_direction_model(document.get(_DIRECTION_SECTION),
                                                           source))
    _check_constraints(params, source)
    return params


def _direction_model(section: Any, source: str) -> tuple[DirectionTerms, DirectionTerms] | None:
    """Return the terms of the optional ``direction_model`` section (positive, negative)."""
    if section is None:
        return None
    section = _mapping_of(section, _DIRECTION_SECTION, DIRECTIONS, source)
    terms = []
    for direction in DIRECTIONS:
        where = f'{_DIRECTION_SECTION}.{direction}'
        values = DirectionTerms(**_section({where: section[direction]}, where, DIRECTION_KEYS,
                                           source))
        for ok, key, rule, value in (
                (values.phi_s > 0, 'phi_s', 'must be > 0', values.phi_s),
                (0 < values.alpha <= ALPHA_MAX, 'alpha', f'must be > 0 and <= {ALPHA_MAX:g}',
                 values.alpha)):
            if not ok:
                raise ParameterError(f'{source}: {where}.{key}: {rule}, got {shorten(value)}')
        terms.append(values)
    return terms[0], terms[1]


def _identification(section: Any, source: str) -> dict[str, Any]:
    """Return the ParameterSet fields of the optional ``identification`` section."""
    if section is None:
        return {}
    if not isinstance(section, Mapping):
        raise ParameterError(f'{source}: identification: expected a mapping')
    extra = sorted(set(section) - {'not_identified', 'friction_unit', 'identified'})
    if extra:
        raise ParameterError(f'{source}: identification: unknown key {shorten(repr(extra[0]))}')
    missing = section.get('not_identified', []) or []
    if not isinstance(missing, list) or any(m not in IDENTIFIABLE for m in missing):
        raise ParameterError(f'{source}: identification.not_identified: a list of '
                             f'{", ".join(IDENTIFIABLE)}, got {shorten(repr(missing))}')
    unit = section.get('friction_unit', 'normalised')
    if not isinstance(unit, str) or not unit.strip() or len(unit) > 40:
        raise ParameterError(f'{source}: identification.friction_unit: a short text, got '
                             f'{shorten(repr(unit))}')
    return {'not_identified': tuple(missing), 'friction_unit': unit.strip()}


def packaged_config_file(file_name: str) -> Path:
    """
    Return the path of a packaged ``config/`` file, wherever the package is installed.

    Looks in the ament share directory (colcon install on a ROS host), in ``<prefix>/share``
    (pip install), in the ``share`` folder of the prefix this module is installed in (colcon
    install without ament_index_python), and in the source tree, in that order.
    """
    candidates = []
    try:  # pragma: no cover - only on a ROS 2 host
        # imported on use: not every importer of this module needs it (start-up time)
        from ament_index_python.packages import get_package_share_directory
        candidates.append(Path(get_package_share_directory(PACKAGE_NAME)) / 'config')
    except Exception:  # noqa: BLE001 - ament may be absent or the package not indexed
        pass
    candidates.append(Path(sys.prefix) / 'share' / PACKAGE_NAME / 'config')
    here = Path(__file__).resolve()
    # <prefix>/lib/pythonX.Y/site-packages/robot_wear_monitor/model/params.py -> <prefix>/share
    candidates.extend(parent / 'share' / PACKAGE_NAME / 'config' for parent in here.parents)
    candidates.append(here.parents[2] / 'config')  # the source tree
    for folder in candidates:
        path = folder / file_name
        if path.is_file():
            return path
    raise ParameterError(
        f'the packaged {file_name} was not found in ' + ', '.join(str(c) for c in candidates))


def default_parameter_file() -> Path:
    """Return the path of the packaged default parameter set (IRB 6620 joint 2)."""
    return packaged_config_file(DEFAULT_PARAMETER_FILE)


def load_parameter_set(path: str | os.PathLike | None = None) -> ParameterSet:
    """
    Load and validate a parameter-set YAML file (the packaged default when ``path`` is None).

    :raises ParameterError: the file is missing, not YAML, or a field is missing or invalid; the
        message names the file and the field.

    """
    file = Path(path) if path is not None else default_parameter_file()
    document = load_yaml_file(file, what='parameter file', error=ParameterError)
    return parameter_set_from_mapping(document, source=str(file))


def parameter_set_to_mapping(params: ParameterSet) -> dict:
    """
    Return the YAML-ready document of a parameter set (what :func:`load_parameter_set` reads).

    The ``added_terms`` section is written only when the model has added terms.
    """
    document: dict[str, Any] = {'name': params.name}
    for key, names in _MODEL_SECTIONS.items():
        document[key] = {n: float(getattr(params.model, n)) for n in names}
    for key, mapping in _SCALAR_SECTIONS.items():
        document[key] = {k: float(getattr(params, f)) for k, f in mapping.items()}
    if params.model.extension is not None and params.model.extension.terms:
        document[_EXTENSION_SECTION] = extension_to_mapping(params.model.extension)
    if params.not_identified or params.friction_unit != 'normalised':
        document[_IDENTIFICATION_SECTION] = {
            'identified': [t for t in ('speed',) + IDENTIFIABLE
                           if t not in params.not_identified],
            'not_identified': list(params.not_identified),
            'friction_unit': params.friction_unit}
    if params.direction_model is not None:
        document[_DIRECTION_SECTION] = {
            direction: {k: float(getattr(terms, k)) for k in DIRECTION_KEYS}
            for direction, terms in zip(DIRECTIONS, params.direction_model)}
    return document


def parameter_set_yaml_text(params: ParameterSet, *, header: str = '') -> str:
    """Return a parameter set as YAML text (``header`` lines are written as comments first)."""
    comments = ''.join(f'# {line}\n' if line else '#\n' for line in header.splitlines())
    body = yaml.safe_dump(parameter_set_to_mapping(params), sort_keys=False,
                          default_flow_style=False, width=99)
    return comments + body
