"""``robot-wear-monitor replay``: a recorded bag through the monitoring service.

The replay itself is :func:`robot_wear_monitor.monitoring.replay.replay_bag`; this verb reads
the options, prints the summary line (one per joint with several joints) or the summary JSON,
and draws the wear trend (:func:`robot_wear_monitor.reporting.report.plot_replay`).
"""

from __future__ import annotations

import argparse
import sys

from robot_wear_monitor.cli.options import (add_config, add_gear_ratio_and_torque_scale,
                                            add_joints, add_json, add_params,
                                            joint_selection, print_json, write_json_out)
from robot_wear_monitor.errors import InputError

HELP = 'replay a recorded bag through the monitoring service'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``replay``."""
    parser.add_argument('bag', metavar='BAG', help='recorded ROS 2 bag (MCAP or sqlite3)')
    parser.add_argument('--out', required=True, metavar='OUT_BAG', help='output bag directory')
    add_json(parser, what='the summary JSON', legacy_path=True)
    parser.add_argument('--plot', metavar='PNG', help='draw the wear trend (like Fig. 11)')
    add_joints(parser, help_text='joint to monitor; several as NAME,NAME or repeated --joint, '
                                 'or "all" (every joint of the recording): outputs under '
                                 "<joint>/ (default: the node config's joint)")
    add_gear_ratio_and_torque_scale(parser, gear_default='from the node config (--config)')
    add_params(parser)
    add_config(parser, help_text='node parameter file (default: the packaged wear_monitor.yaml; '
                                 'per-joint values as <joint>: {gear_ratio: ...})')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                        help='storage of OUT_BAG (default mcap)')
    parser.add_argument('--history', metavar='FILE', help='also keep the SQLite wear history')
    parser.add_argument('--truth', metavar='JSON',
                        help='truth of a simulated bag (simulate writes BAG.truth.json), added '
                             'to the summary and the plot; nothing beside the bag is read '
                             'unless named here')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing OUT_BAG')
    parser.add_argument('--strict', action='store_true',
                        help='refuse a recording whose end is cut (default: read up to the cut)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def main(args: argparse.Namespace) -> int:
    """Run ``replay``: write OUT_BAG, print the summary (text or ``--json``)."""
    from pathlib import Path

    from robot_wear_monitor.experiment.simulation import read_truth_json
    from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
    if Path(args.out).exists() and not args.overwrite:
        raise InputError(f'{args.out}: already exists (use --overwrite to replace it)')
    truth = read_truth_json(args.truth) if args.truth else None
    joint, joints = joint_selection(args.joint)
    experiment, estimator = replay_parameters(
        config_file=args.config, joint=joint, joints=joints, gear_ratio=args.gear_ratio,
        torque_scale=args.torque_scale, params_file=args.params)
    result = replay_bag(args.bag, out_bag=args.out, experiment_parameters=experiment,
                        estimator_parameters=estimator, storage=args.storage,
                        history_file=args.history, overwrite=args.overwrite,
                        progress=not args.no_progress, truth=truth, recover=not args.strict)
    if result.recovery is not None and not result.recovery.complete:
        print(f'warning: {args.bag}: unfinished recording ({result.recovery.reason}): read '
              f'{result.recovery.messages} complete messages up to bag time '
              f'{result.recovery.last_stamp_s:.3f} s; what followed is lost (--strict '
              f'refuses such a recording)', file=sys.stderr)
    for partial in result.removed_partials:
        print(f'removed {partial}: the unfinished output of a replay that was killed',
              file=sys.stderr)
    for note in result.notes:
        print(f'note: {note}', file=sys.stderr)
    summary = result.summary()
    write_json_out(args.json_out, summary)
    if args.plot:
        from robot_wear_monitor.reporting.report import plot_replay
        plot_replay(result, args.plot, bag=args.bag, threshold=estimator['wear_threshold'])
    if args.json:
        print_json(summary)
        return 0
    first = summary['first_alarm']
    skipped = result.rejections.get('friction_levels_already_in_history', 0)
    print(f'{len(result.updates)} experiments from {result.message_count} messages; '
          + (f'{skipped} already in the history (skipped, not estimated again); '
             if skipped else '')
          + ('no alarm' if first is None else
             f'alarm at experiment {first["index"]} (w-hat {first["wear"]:.1f})')
          + f'; wrote {args.out}')
    if joints:
        for entry in result.joints:
            print(joint_summary_line(entry))
    return 0


def joint_summary_line(entry: dict, *, estimates: bool = True) -> str:
    """Return one line on a joint: samples, passes, levels per speed, experiments, or why not."""
    speeds = ', '.join(f'{k} rad/s x{v}' for k, v in entry['levels_per_speed_rad_s'].items())
    other = entry['levels_at_other_speeds_rad_s']
    alarm = entry['first_alarm']
    line = (f'  {entry["joint"]}: {entry["samples"]} samples, {entry["passes"]} passes, '
            f'{entry["levels"]} levels' + (f' ({speeds})' if speeds else '')
            + f', {entry["experiments"]} experiments'
            + (f', {entry["estimates"]} estimates' if estimates else '')
            + (f', alarm at experiment {alarm["index"]}' if alarm else ''))
    if other:
        line += ('; levels at no configured speed: '
                 + ', '.join(f'{k} rad/s x{v}' for k, v in other.items()))
    if entry['no_experiment']:
        line += f'; no experiment: {entry["no_experiment"]}'
    return line
