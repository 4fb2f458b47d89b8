"""
``robot-wear-monitor identify``: a parameter set (models (5), (7), sigma) from levels.

The inputs are read by :func:`robot_wear_monitor.audit.identify_inputs.load_identify_levels`
and fitted by :func:`robot_wear_monitor.audit.identification.identify`; this verb checks the
options, writes ``--out`` (loaded back), ``--plots``, ``--levels-out`` and ``--json-out``, and
prints the summary or ``--json``.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
import math
from pathlib import Path
from typing import Any

from robot_wear_monitor.atomic_files import write_text_atomic
from robot_wear_monitor.cli.level_options import (add_configuration_column, add_friction_unit,
                                                  add_level_source, friction_unit,
                                                  level_source_scales, print_notes,
                                                  write_levels_out)
from robot_wear_monitor.cli.options import (add_json, BAG_SCALE_DEFAULT, emit_json, FINITE,
                                            parse_float_list, PROG)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.segmentation_settings import EXPERIMENT_GAPS_S
from robot_wear_monitor.text import shorten

HELP = 'identify a parameter set (models (5), (7), sigma) from friction levels'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``identify``."""
    parser.add_argument('baseline', metavar='BASELINE',
                        help='healthy-joint friction levels: a CSV with speed, friction, '
                             'temperature, load (optionally experiment), or raw runs / a bag '
                             'that the segmentation turns into levels')
    parser.add_argument('--wear-test', metavar='WEAR',
                        help='levels of an accelerated wear test (same columns plus '
                             'experiment, the time index k)')
    parser.add_argument('--critical-experiment', metavar='K',
                        help='experiment of the wear test identified with w = --critical-wear')
    parser.add_argument('--critical-wear', type=FINITE, default=35.0, metavar='W',
                        help="wear level of experiment K (default 35, the paper's convention)")
    parser.add_argument('--from-params', metavar='FILE',
                        help='reference parameter set for the fields the data cannot determine '
                             '(default: the packaged IRB 6620 joint 2 set)')
    parser.add_argument('--name', help='name of the new set (default: identified_<BASELINE>)')
    parser.add_argument('--out', required=True, metavar='PARAMS.yaml',
                        help='write the parameter set here (atomically; loaded back to check)')
    add_json(parser, what='the JSON report', legacy_path=True)
    parser.add_argument('--plots', metavar='DIR', help='write the residual figures here')
    parser.add_argument('--temperature-bounds', type=parse_float_list, metavar='LOW,HIGH',
                        help='temperature bounds of the estimator [degC] (default: the '
                             "baseline's temperature range)")
    parser.add_argument('--temperature-column', metavar='COLUMN',
                        help='column holding the joint temperature [degC] (default temperature)')
    parser.add_argument('--load-column', metavar='COLUMN',
                        help='column holding the load torque (default load)')
    parser.add_argument('--temperature-topic', metavar='TOPIC',
                        help='bag input: the joint temperature [degC] recorded on this topic '
                             '(sensor_msgs/Temperature or std_msgs/Float64), per level at its '
                             'time')
    parser.add_argument('--load-topic', metavar='TOPIC',
                        help='bag input: the load torque tau_l (normalised) recorded on this '
                             'topic (std_msgs/Float64), per level at its time')
    parser.add_argument('--experiment-gap', type=FINITE,
                        default=EXPERIMENT_GAPS_S['identify_bag'], metavar='S',
                        help='bag input: levels more than S seconds apart start a new '
                             f"experiment (default {EXPERIMENT_GAPS_S['identify_bag']:g}; "
                             'see docs/segmentation.md for the gap of each context)')
    parser.add_argument('--folds', type=int, default=5,
                        help='cross-validation folds of the held-out error (default 5)')
    parser.add_argument('--speed-only', action='store_true',
                        help='levels without temperature or load variation: identify the '
                             'speed model (4) at their conditions and write a set that says '
                             'temperature, load and wear were not identified')
    parser.add_argument('--pool-joints', action='store_true',
                        help="--speed-only on levels of several joints (a 'joint' column): "
                             'fit them as one joint (default: refused; select one with '
                             '--joint NAME)')
    add_friction_unit(parser)
    add_configuration_column(parser)
    parser.add_argument('--load-mean', type=FINITE, metavar='MU',
                        help="mean of the load estimate of eq. (14) in the load's unit "
                             "(default: the baseline's load column)")
    parser.add_argument('--load-std', type=FINITE, metavar='SIGMA',
                        help='std of the load estimate of eq. (14) (with --load-mean)')
    parser.add_argument('--borrowed-wear', choices=('scaled', 'reference'), default=None,
                        help='without --wear-test: the wear model (7) of --from-params scaled '
                             "to this joint's friction and speed range (default; the assumption "
                             'is written in the set), or taken as it stands (a joint like the '
                             'reference, in its unit)')
    parser.add_argument('--no-wear-model', action='store_true',
                        help='without --wear-test: write a set with no wear model; estimate, '
                             'replay and the nodes then report T-hat only, w-hat "not '
                             'determined" and no wear alarm (for a joint with no basis for a '
                             'wear model; not the default)')
    add_level_source(parser, gear_default=(BAG_SCALE_DEFAULT + ' (level tables and raw runs '
                                           'in joint speeds: their speeds are multiplied by R '
                                           'too)'))


def main(args: argparse.Namespace) -> int:
    """Run ``identify``: write the parameter set, print the summary or the JSON report."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.audit.export import write_identified_parameter_set
    from robot_wear_monitor.audit.identification import identify
    from robot_wear_monitor.audit.identify_inputs import default_set_name, load_identify_levels
    from robot_wear_monitor.audit.figures import plot_identification
    from robot_wear_monitor.model.params import load_parameter_set

    if (args.wear_test is None) != (args.critical_experiment is None):
        raise InputError('--wear-test and --critical-experiment K go together (K is the '
                         'experiment of the wear test with w = --critical-wear)')
    if not (math.isfinite(args.critical_wear) and args.critical_wear > 0):
        raise InputError(f'--critical-wear must be > 0, got {args.critical_wear}')
    if args.folds < 2:
        raise InputError(f'--folds must be >= 2, got {args.folds}')
    bounds = None
    if args.temperature_bounds is not None:
        if len(args.temperature_bounds) != 2 or not (
                args.temperature_bounds[0] < args.temperature_bounds[1]):
            raise InputError('--temperature-bounds: expected LOW,HIGH with LOW < HIGH')
        bounds = (args.temperature_bounds[0], args.temperature_bounds[1])
    if args.no_wear_model and (args.wear_test or args.borrowed_wear or args.speed_only):
        given = ('--wear-test' if args.wear_test else '--borrowed-wear' if args.borrowed_wear
                 else '--speed-only')
        raise InputError(f'--no-wear-model writes a set without a wear model: {given} '
                         'contradicts it (give one or the other)')
    if args.configuration_column and args.load_mean is not None:
        raise InputError("--configuration-column takes each configuration's load estimate "
                         'from its levels; --load-mean gives one for all: give one or the other')
    if (args.load_mean is None) != (args.load_std is None):
        raise InputError('--load-mean and --load-std go together (the load estimate '
                         'N(mu, sigma^2) of eq. (14))')
    if args.load_std is not None and not args.load_std >= 0:
        raise InputError(f'--load-std must be >= 0, got {args.load_std}')
    from_params = load_parameter_set(args.from_params)
    gear_ratio, torque_scale = level_source_scales(args)

    def levels(path: str, role: str):
        return load_identify_levels(
            path, role=role, joint=args.joint, topic=args.topic, flip_sign=not args.raw_sign,
            gear_ratio=gear_ratio, torque_scale=torque_scale,
            temperature_topic=args.temperature_topic, load_topic=args.load_topic,
            experiment_gap_s=args.experiment_gap, temperature_column=args.temperature_column,
            load_column=args.load_column, known_torque=args.known_torque,
            standstill_speed_rad_s=args.standstill_speed, config_file=args.config,
            speed_tolerance=args.speed_tolerance, notes=notes)

    notes: list[str] = []  # how raw runs were read, for stderr

    if args.speed_only:
        if args.plots:
            raise InputError('--plots draws the residual figures of model (5); with '
                             "--speed-only give them from the audit's fit of model (4), the "
                             f'same fit: {PROG} audit BASELINE --plots DIR')
        if args.configuration_column:
            raise InputError('--configuration-column splits the load estimate of a set of '
                             'model (5); --speed-only identifies no load')
        return _speed_only(args, from_params, gear_ratio, torque_scale)
    try:
        baseline = levels(args.baseline, 'BASELINE')
    except InputError as error:
        if _varies_in_conditions(args, gear_ratio, torque_scale):
            raise
        raise InputError(f'{error} (levels that vary in speed only: --speed-only identifies '
                         'the speed model (4) at their conditions)') from None
    wear_test = levels(args.wear_test, 'WEAR') if args.wear_test else None
    print_notes(notes)
    levels_out = write_levels_out(
        args, [baseline] if wear_test is None else [baseline, wear_test],
        roles=None if wear_test is None else ['baseline', 'wear_test'])
    unit = _friction_unit(args, torque_scale, note=False)
    result = identify(baseline=baseline, from_params=from_params,
                      name=args.name or default_set_name(args.baseline),
                      wear_test=wear_test, critical_experiment=args.critical_experiment,
                      critical_wear=args.critical_wear, temperature_bounds_degc=bounds,
                      n_folds=args.folds, friction_unit=unit,
                      load_prior=(None if args.load_mean is None else
                                  (args.load_mean, args.load_std)),
                      borrowed_wear=('none' if args.no_wear_model else
                                     args.borrowed_wear or 'scaled'),
                      configuration_column=args.configuration_column)
    configured: list = []
    if args.configuration_column:
        result, configured = _column_sets(result, baseline, args.configuration_column)
    loaded = write_identified_parameter_set(args.out, result)
    report = result.to_dict()
    report['out'] = str(args.out)
    report['loaded_back'] = loaded.name == result.params.name
    if levels_out:
        report['levels_out'] = levels_out
    configurations = result.extra.get('load_configurations') or []
    per_configuration: list[dict] = []
    if len(configurations) > 1 and args.load_mean is None:
        # deferred import: start-up time (numpy, scipy: not for --help)
        from robot_wear_monitor.audit.configurations import for_configuration
        out = Path(args.out)
        for index in range(len(configurations)):
            label = configurations[index].get('label') or f'load{index + 1}'
            path = out.with_name(f'{out.stem}_{label}{out.suffix or ".yaml"}')
            written = write_identified_parameter_set(
                path, configured[index] if configured else for_configuration(result, index))
            per_configuration.append({'out': str(path), 'name': written.name,
                                      **configurations[index]})
    report['configuration_sets'] = per_configuration
    if args.plots:
        report['figures'] = [str(p) for p in plot_identification(
            result=result, baseline=baseline, wear_test=wear_test, out_dir=args.plots)]
    if emit_json(args, report):
        return 0
    print(result.summary())
    if not args.friction_unit and unit == 'normalised':
        print(f'note: the friction unit of {shorten(str(args.baseline))} is not stated; the set '
              "says 'normalised' (give --friction-unit UNIT, e.g. A or N.m)")
    print(f'parameter set {loaded.name!r} written to {args.out} (loaded back and validated)')
    for entry in per_configuration:
        which = (f"{entry['column']} = {entry['value']}, " if 'column' in entry else '')
        print(f"parameter set {entry['name']!r} for {which}loads {entry['low']:.4g}-"
              f"{entry['high']:.4g} (load estimate {entry['mean']:.4g} +- {entry['std']:.4g}) "
              f"written to {entry['out']}")
    if per_configuration and args.configuration_column:
        print(f'{args.out}: ' + str(result.extra.get('pooled_note', '')).replace('\n', '\n  '))
    elif per_configuration:
        print(f'the load column has {len(per_configuration)} configurations: {args.out} holds '
              'the load estimate over both (for a monitor that does not know its payload); '
              'monitor each configuration with its own set (a tighter load estimate: '
              'docs/identify.md)')
    return 0


def _column_sets(result: Any, baseline: Any, column: str) -> tuple[Any, list]:
    """
    Return (the pooled result with its header note, the configurations' results).

    The note says the pooled set is for a monitor that does not know its configuration and
    what that costs on these levels (the held-out check of
    :func:`~robot_wear_monitor.audit.configurations.temperature_cost`).
    """
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.audit.configurations import pooled_header, temperature_cost
    from robot_wear_monitor.audit.configurations import for_configuration
    configurations = result.extra.get('load_configurations') or []
    configured = [for_configuration(result, i) for i in range(len(configurations))]
    cost = temperature_cost(table=baseline, residual=result.nominal.residual,
                            held_out_residual=result.nominal.held_out_residual,
                            pooled=result.params, sets=[c.params for c in configured],
                            column=column)
    extra = {**result.extra, 'pooled_note': pooled_header(cost, column),
             'configuration_cost': cost}
    return replace(result, extra=extra), [replace(c, extra={**c.extra, 'configuration_cost':
                                                            cost}) for c in configured]


def _varies_in_conditions(args: argparse.Namespace, gear_ratio: float | None,
                          torque_scale: float | None) -> bool:
    """Return True when the baseline gives temperature and load (columns, topics) that vary."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    import numpy as np
    from robot_wear_monitor.audit.data import load_audit_data
    if any((args.temperature_topic, args.load_topic, args.temperature_column,
            args.load_column)):
        return True
    table = load_audit_data(args.baseline, model='speed', joint=args.joint, topic=args.topic,
                            flip_sign=not args.raw_sign, gear_ratio=gear_ratio,
                            torque_scale=torque_scale, known_torque=args.known_torque,
                            config_file=args.config)
    return all(name in table.numeric and np.unique(table.numeric[name]).size > 1
               for name in ('temperature', 'load'))


def _speed_only(args: argparse.Namespace, from_params, gear_ratio: float | None,
                torque_scale: float | None) -> int:
    """Identify model (4) from levels that vary in speed only; write the speed-only set."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.audit.data import load_audit_data
    from robot_wear_monitor.audit.identify_inputs import default_set_name
    from robot_wear_monitor.audit.friction_sign import check_speed_fit_friction
    from robot_wear_monitor.audit.speed_model import speed_only_parameter_set
    notes: list[str] = []  # how raw runs were read, for stderr
    # deferred import: start-up time (numpy: not for --help)
    from robot_wear_monitor.model.params import load_parameter_set, parameter_set_yaml_text
    if args.wear_test or args.critical_experiment:
        raise InputError(f'{args.baseline}: --speed-only identifies model (4) only; a wear '
                         'test (7) needs the nominal model (5), from levels with temperature '
                         'and load that vary')
    table = load_audit_data(args.baseline, model='speed', joint=args.joint, topic=args.topic,
                            flip_sign=not args.raw_sign, gear_ratio=gear_ratio,
                            torque_scale=torque_scale, known_torque=args.known_torque,
                            standstill_speed_rad_s=args.standstill_speed,
                            config_file=args.config,
                            speed_tolerance=args.speed_tolerance, notes=notes)
    print_notes(notes)
    table = _one_joint(table, joint=args.joint, pool=args.pool_joints)
    levels_out = write_levels_out(args, [table])
    unit = _friction_unit(args, torque_scale)
    result = speed_only_parameter_set(table=table, from_params=from_params,
                                      name=args.name or default_set_name(args.baseline),
                                      friction_unit=unit, n_folds=args.folds)
    check_speed_fit_friction({k: p.value for k, p in result.fit.groups['all'].items()}, table)
    header = (f'Speed-only parameter set from {PROG} identify {args.baseline}: model (4) at '
              "the data's conditions.\nNot identified: temperature, load, wear (borrowed from "
              f'{from_params.name}); the set refuses to estimate wear.\n'
              f'Friction unit: {unit}.')
    write_text_atomic(args.out, parameter_set_yaml_text(result.params, header=header))
    loaded = load_parameter_set(args.out)
    report = result.to_dict()
    report['out'] = str(args.out)
    report['loaded_back'] = loaded.name == result.params.name
    if levels_out:
        report['levels_out'] = levels_out
    if emit_json(args, report):
        return 0
    print(result.summary())
    print(f'parameter set {loaded.name!r} written to {args.out} (loaded back and validated)')
    return 0


def _friction_unit(args: argparse.Namespace, torque_scale: float | None, *,
                   note: bool = True) -> str:
    """Return the friction unit of the baseline (:func:`~.options.friction_unit`)."""
    return friction_unit(args, args.baseline, torque_scale, command='identify', note=note)


def _one_joint(table: Any, *, joint: str | None, pool: bool) -> Any:
    """
    Return the levels of one joint of a table with a ``joint`` column (a set is one joint).

    ``joint`` selects it; ``pool`` keeps every joint as one; otherwise levels of several
    joints are refused, naming them (their friction can differ manyfold).
    """
    if 'joint' not in table.text:
        return table
    names = sorted(set(table.text['joint'].tolist()))
    if joint is not None:
        rows = table.text['joint'] == joint
        if not rows.any():
            raise InputError(f'--joint {shorten(joint)}: not in the levels (joints: '
                             f'{shorten(", ".join(names))})')
        return table.subset(rows)
    if len(names) > 1 and not pool:
        raise InputError(f'{table.source}: levels of {len(names)} joints '
                         f'({shorten(", ".join(names))}): a parameter set describes one joint; '
                         'select one with --joint NAME, or fit them as one with --pool-joints')
    return table
