"""
``robot-wear-monitor audit``: what the friction model misses in measured friction levels.

The audit itself is :func:`robot_wear_monitor.audit.run.run_audit`; this verb reads the data,
prints the summary (or ``--json``), and writes ``--out-params``, ``--plots``, ``--levels-out``
and ``--json-out``.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from robot_wear_monitor.cli.level_options import (add_friction_unit, add_level_source,
                                                  friction_unit, level_source_scales, print_notes,
                                                  write_levels_out)
from robot_wear_monitor.cli.options import (add_json, add_params, emit_json, FINITE, params_from,
                                            PROG)
from robot_wear_monitor.errors import InputError

HELP = 'find and model what the friction model misses in measured friction levels'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``audit``."""
    parser.add_argument('data', metavar='DATA',
                        help='friction-level CSV (speed, friction, ...), a raw run or a folder '
                             'of raw runs (t_s, q_rad, dq_rad_s, tau_measured_Nm), or a bag')
    parser.add_argument('--model', default='speed', metavar='speed|nominal|complete',
                        help='model to audit: speed (4), nominal (5) or complete (8) '
                             '(default speed)')
    add_params(parser)
    parser.add_argument('--group', metavar='COLUMN',
                        help='identify the speed model separately per value of this column '
                             '(default for raw runs of several joints: joint)')
    add_json(parser, what='the JSON report', legacy_path=True)
    parser.add_argument('--plots', metavar='DIR', help='write the residual figures here')
    parser.add_argument('--fdr', type=FINITE, default=0.01,
                        help='false-discovery rate of each step (default 0.01)')
    parser.add_argument('--max-effects', type=int, default=4,
                        help='add at most this many effects (default 4)')
    parser.add_argument('--folds', type=int, default=5, help='cross-validation folds (default 5)')
    parser.add_argument('--out-params', metavar='FILE',
                        help='write the parameter set extended by the added terms (YAML, '
                             'section added_terms; nominal and complete models) for estimate, '
                             'replay, design and the nodes (--params FILE)')
    add_friction_unit(parser)
    add_level_source(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``audit``: print the summary or the JSON report; write the requested files."""
    # deferred import: start-up time (numpy, scipy: not for --help)
    from robot_wear_monitor.audit.data import load_audit_data, MODELS
    from robot_wear_monitor.audit.run import run_audit

    if args.model not in MODELS:
        raise InputError(f'unknown --model {args.model!r} (expected {", ".join(MODELS)})')
    if args.out_params and args.model == 'speed':
        raise InputError('--out-params needs --model nominal or complete (a parameter set holds '
                         'model (5) and (7), not the speed model (4))')
    if not 0 < args.fdr < 1:
        raise InputError(f'--fdr must be between 0 and 1, got {args.fdr}')
    if args.max_effects < 0 or args.folds < 2:
        raise InputError('--max-effects must be >= 0 and --folds >= 2')
    params = params_from(args) if args.model != 'speed' or args.params else None
    gear_ratio, torque_scale = level_source_scales(args)
    notes: list[str] = []  # how raw runs were read, for stderr
    table = load_audit_data(args.data, model=args.model, joint=args.joint, topic=args.topic,
                            known_torque=args.known_torque,
                            standstill_speed_rad_s=args.standstill_speed,
                            flip_sign=not args.raw_sign, gear_ratio=gear_ratio,
                            torque_scale=torque_scale, config_file=args.config,
                            speed_tolerance=args.speed_tolerance,
                            notes=notes)
    print_notes(notes)
    levels_out = write_levels_out(args, [table])
    unit = friction_unit(args, args.data, torque_scale, command='audit',
                         note=not args.json, holder='the report')
    group = args.group
    if group is None and args.model == 'speed' and 'joint' in table.text:
        group = 'joint'
    # the packaged set (one ABB joint, normalised torque) is not applied to another robot's
    # data without --params: no T or w estimates, no errors without their basis
    result = run_audit(table=table, model=args.model, params=params, group=group,
                       fdr=args.fdr, max_effects=args.max_effects, n_folds=args.folds,
                       estimate=bool(args.params))
    result = replace(result, friction_unit=unit)
    report = result.to_dict()
    if args.model != 'speed' and not args.params:
        report['estimate_changes'] = {'applies': False, 'reason': NO_PARAMS}
    if args.out_params and result.extended_params is not None:
        # deferred import: start-up time (numpy, scipy: not for --help)
        from robot_wear_monitor.audit.export import write_parameter_set
        write_parameter_set(args.out_params, result.extended_params,
                            header=params_header(args, result))
        report['out_params'] = args.out_params
    if levels_out:
        report['levels_out'] = levels_out
    if args.plots:
        # deferred import: start-up time (numpy, scipy, matplotlib: not for --help)
        from robot_wear_monitor.audit.figures import plot_audit
        report['figures'] = [str(p) for p in plot_audit(result=result, table=table,
                                                        out_dir=args.plots)]
    if emit_json(args, report):
        return 0
    print(result.summary())
    if args.model != 'speed' and not args.params:
        print(f'  T and w not estimated: {NO_PARAMS}')
    if args.out_params:
        print(f'extended parameter set written to {args.out_params} (use: {PROG} estimate '
              f'--params {args.out_params} ...)')
    return 0


#: Why the audit estimates no T and w without --params.
NO_PARAMS = ('no --params: the packaged parameter set (ABB IRB 6620 joint 2, normalised '
             'torque) is not applied to data of another robot or unit; give --params FILE to '
             'estimate T and w with the model found')


def params_header(args: argparse.Namespace, result) -> str:
    """Return the comment lines of an ``audit --out-params`` file (provenance, defaults)."""
    lines = [f'Parameter set extended by {PROG} audit {args.data} --model {args.model}.',
             f'Base: {result.extended_params.name} from '
             f'{args.params or "the packaged set"}; model ({5 if args.model == "nominal" else 8})'
             ' re-identified jointly with the added terms on '
             f'{result.n_levels} levels;',
             f'held-out RMS error {result.rms_before:.4g} -> {result.rms_after:.4g} '
             f'(noise floor {result.noise_floor:.4g}).']
    lines += [f'Added: {e.name} [{", ".join(e.variables)}]' for e in result.effects]
    if not result.effects:
        lines.append('No effect added: the set is the re-identified model alone.')
    lines += [f'Not measured online: {name}, evaluated at {value!r} ({how}).'
              for name, (value, how) in result.offline.items()]
    return '\n'.join(lines)
