"""
``robot-wear-monitor replay``: recorded bags through the monitoring service.

One bag: :func:`robot_wear_monitor.monitoring.replay.replay_bag`; this verb reads the options,
prints the summary line (one per joint with several joints) or the summary JSON, and draws the
wear trend (:func:`robot_wear_monitor.reporting.replay_report.plot_replay`).  Many bags (several
paths, a folder of bags, ``--manifest``, or ``--workers``/``--dask``):
:func:`robot_wear_monitor.fleet.batch.run_batch`, one task per bag, the history as the output.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
from typing import Any

from robot_wear_monitor.cli.options import (add_config, add_gear_ratio_and_torque_scale,
                                            add_history, add_joints, add_json, add_params,
                                            add_progress, add_robot, emit_json,
                                            joint_selection, loading_modules, print_json,
                                            progress_wanted, shown_location, write_json_out)
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import open_history
from robot_wear_monitor.input_files import MAX_JSON_BYTES, read_text_file
from robot_wear_monitor.text import escaped, iso_time, LINE_LIMIT, shorten

HELP = 'replay a recorded bag through the monitoring service'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``replay``."""
    parser.add_argument('bag', metavar='BAG', nargs='*',
                        help='recorded ROS 2 bag(s) (MCAP or sqlite3), or folders of bags')
    parser.add_argument('--out', metavar='OUT_BAG',
                        help='output bag directory (required with one bag unless --history is '
                             'given); with many bags a folder: OUT/<robot>/<bag name>/')
    parser.add_argument('--manifest', metavar='CSV',
                        help='bags of many robots: a CSV with the columns robot,bag (a '
                             'relative bag path is relative to the CSV)')
    add_robot(parser, help_text='the robot of the bags (its key in the history; default: the '
                                'node config\'s robot_id, else "default"); a manifest names '
                                "each bag's robot")
    parser.add_argument('--workers', type=int, metavar='N',
                        help='replay many bags on N processes of this machine (default 1)')
    parser.add_argument('--dask', metavar='ADDRESS',
                        help='submit the bags to the Dask scheduler at ADDRESS (e.g. '
                             "tcp://10.0.0.5:8786); the workers must read the bags' paths")
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
    add_history(parser, help_text='also keep the wear history (with many bags: the output)',
                writer=True)
    parser.add_argument('--truth', metavar='JSON',
                        help='truth of a simulated bag (simulate writes BAG.truth.json), added '
                             'to the summary and the plot; nothing beside the bag is read '
                             'unless named here')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing OUT_BAG')
    parser.add_argument('--strict', action='store_true',
                        help='refuse a recording whose end is cut (default: read up to the cut)')
    add_progress(parser)


def is_batch(args: argparse.Namespace) -> bool:
    """Return True when the command names many bags (or asks for workers or Dask)."""
    # deferred import: start-up time (recordings: not for --help)
    from robot_wear_monitor.recordings import is_bag
    return bool(len(args.bag) > 1 or args.manifest or args.workers is not None
                or args.dask or any(not is_bag(Path(b)) and Path(b).is_dir()
                                    for b in args.bag))


def main(args: argparse.Namespace) -> int:
    """Run ``replay``: one bag (write OUT_BAG, print the summary) or many (:func:`main_batch`)."""
    with loading_modules():  # rosbags and the monitoring modules
        # deferred import: start-up time (numpy, rosbags: not for --help)
        from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
        from robot_wear_monitor.monitoring.replay import replay_bag
    if not args.bag and not args.manifest:
        raise InputError('name a bag (or several, a folder of bags, or --manifest CSV)')
    if is_batch(args):
        return main_batch(args)
    if args.out is None and args.history is None:
        raise InputError('--out OUT_BAG or --history: the replay needs somewhere to write')
    [bag] = args.bag
    args.bag = bag
    if args.out is not None and Path(args.out).exists() and not args.overwrite:
        raise InputError(f'{args.out}: already exists (use --overwrite to replace it)')
    truth = None
    if args.truth:  # the simulation module is loaded for it only
        # deferred import: start-up time (numpy: --truth only)
        from robot_wear_monitor.experiment.simulation import read_truth_json
        truth = read_truth_json(args.truth)
    joint, joints = joint_selection(args.joint)
    configuration = MonitorConfig.load(
        config_file=args.config, joint=joint, joints=joints, gear_ratio=args.gear_ratio,
        torque_scale=args.torque_scale, params_file=args.params, robot=args.robot)
    result = replay_bag(args.bag, out_bag=args.out, configuration=configuration,
                        storage=args.storage,
                        history_file=args.history, overwrite=args.overwrite,
                        history_init=True if args.init else None,
                        progress=progress_wanted(args), truth=truth, recover=not args.strict)
    if result.recovery is not None and not result.recovery.complete:
        print(f'warning: {shorten(args.bag, 200)}: unfinished recording '
              f'({escaped(result.recovery.reason)}): read '
              f'{result.recovery.messages} complete messages up to bag time '
              f'{result.recovery.last_stamp_s:.3f} s; what followed is lost (--strict '
              f'refuses such a recording)', file=sys.stderr)
    for partial in result.removed_partials:
        print(f'removed {shorten(partial, 200)}: the unfinished output of a replay that was '
              'killed',
              file=sys.stderr)
    for note in result.notes:
        print(f'note: {escaped(note)}', file=sys.stderr)
    for warning in result.warnings:
        print(f'warning: {escaped(warning)}', file=sys.stderr)
    summary = result.summary()
    warn_if_emptier(args.json_out, summary)
    write_json_out(args.json_out, summary)
    if args.plot:
        # deferred import: start-up time (matplotlib: --plot only)
        from robot_wear_monitor.reporting.replay_report import plot_replay
        plot_replay(result, args.plot, bag=args.bag,
                    threshold=configuration.alarm_policy().threshold)
    if args.json:
        print_json(summary)
        return 0
    print(escaped(summary_line(result, summary))
          + (f'; wrote {shorten(args.out, 200)}' if args.out
             else f'; history {shown_location(args.history)}'))
    if joints:
        for entry in result.joints:
            print(joint_summary_line(entry))
    return 0


def summary_line(result: Any, summary: dict) -> str:
    """
    Return the replay's line: experiments, skipped ones, and the joints' state in words.

    "no alarm" only when no joint's alarm is latched in the history and every estimate of the
    run was valid; an invalid estimate says why the wear cannot be judged; a run that found
    only experiments the history already holds reports the state from the history.
    """
    # deferred import: start-up time (monitoring.diagnostics: not for --help)
    from robot_wear_monitor.monitoring.diagnostics import is_routine, rejection_text

    first = summary['first_alarm']
    defects = {r: n for r, n in result.rejections.items() if not is_routine(r)}
    skipped = result.rejections.get('friction_levels_already_in_history', 0)
    line = (f'{len(result.updates)} experiments from {result.message_count} messages; '
            + (f'{skipped} already in the history (skipped, not estimated again); '
               if skipped else ''))
    latched = [state for state in result.latched
               if first is None or state['joint'] != first.get('joint', state['joint'])]
    if first is not None:
        line += f'alarm at experiment {first["index"]} (w-hat {first["wear"]:.1f})'
    elif latched:
        line += 'alarm LATCHED (from the history: ' + ', '.join(
            f'{state["joint"]} since {iso_time(state["alarm_since_stamp_s"])}'
            for state in latched) + ')'
    elif result.invalid:
        line += 'CANNOT JUDGE the wear'
    elif defects:
        line += 'alarm not raised, but bad data were rejected'
    else:
        line += 'no alarm'
    invalid = result.invalid
    if invalid:
        line += (f'; {len(invalid)} of {len(result.updates)} estimates invalid, '
                 f'{invalid[-1].plausibility.text()}')
    if not result.updates and not latched:
        known = [state for state in result.states if state['last_estimate'] is not None]
        line += ''.join(
            f'; {state["joint"]}: last estimate w-hat {state["last_estimate"]["wear"]:.1f} at '
            f'{iso_time(state["last_estimate"]["stamp_s"])}'
            + ('' if state['last_estimate']['valid'] else ' (invalid)')
            for state in known if state['last_estimate']['wear'] is not None)
    if defects:
        line += '; WARNING: ' + rejection_text(defects) + explain_defects(defects)
    return line


#: What a bad-data rejection of a replay means for the estimates, in words.
_DEFECT_MEANING = {
    'segmentation_pass_torque_saturated': 'the drive torque sat at its limit in those passes '
    '(a clipped torque is no friction): their speeds are missing from the experiments',
}


def explain_defects(defects: dict) -> str:
    """Return the meaning of the known bad-data rejections (' (...)'), or ''."""
    known = [_DEFECT_MEANING[r] for r in sorted(defects) if r in _DEFECT_MEANING]
    return f' ({"; ".join(known)})' if known else ''


def warn_if_emptier(path: str | None, summary: dict) -> None:
    """Say so on stderr when ``path`` holds a summary with more experiments than ``summary``."""
    if not path or not Path(path).is_file():
        return
    try:  # read bounded (a regular file of at most MAX_JSON_BYTES); InputError is a ValueError
        old = json.loads(read_text_file(path, what='summary', limit_bytes=MAX_JSON_BYTES))
        before = len(old.get('experiments', ()))
    except (ValueError, AttributeError, TypeError):
        return
    after = len(summary['experiments'])
    if before > after:
        print(f'note: {shorten(path, 200)} held {before} experiments, this run estimated '
              f'{after} (the '
              'others are in the history already); the new summary replaces it and carries '
              "each joint's state from the history under 'state'", file=sys.stderr)


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
    return escaped(line)  # a joint's name from a recording: no control character raw


def main_batch(args: argparse.Namespace) -> int:
    """
    Run ``replay`` on many bags: one task per bag, a progress bar and a summary.

    Exit 2 when any bag failed (each is named with its reason on stderr as it fails).
    """
    # deferred import: start-up time (the batch, tqdm: many bags only)
    from robot_wear_monitor.fleet.batch import (BagOutcome, collect_bags, ReplaySettings,
                                                run_batch)
    from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
    from tqdm import tqdm
    for option, given in (('--truth', args.truth), ('--plot', args.plot)):
        if given:
            raise InputError(f'{option} is for one bag; with many bags the history is the '
                             'output (see the fleet command)')
    if args.history is None and args.out is None:
        raise InputError('many bags need --history (the output) or --out DIR')
    if args.workers is not None and args.dask:
        raise InputError('--workers and --dask: choose one (Dask has its own workers)')
    if args.workers is not None and not 1 <= args.workers <= 256:
        raise InputError(f'--workers must be 1-256, got {args.workers}')
    tasks = collect_bags(paths=args.bag, manifest=args.manifest, robot=args.robot,
                         out_dir=args.out)
    joint, joints = joint_selection(args.joint)
    # read and checked once, before the workers start (each task sets its robot)
    configuration = MonitorConfig.load(
        config_file=args.config, joint=joint, joints=joints, gear_ratio=args.gear_ratio,
        torque_scale=args.torque_scale, params_file=args.params)
    settings = ReplaySettings(history=args.history, config_file=args.config, joint=joint,
                              joints=tuple(joints) if joints else None,
                              gear_ratio=args.gear_ratio, torque_scale=args.torque_scale,
                              params_file=args.params, storage=args.storage,
                              overwrite=args.overwrite, recover=not args.strict,
                              configuration=configuration)
    if args.history is not None:  # made (or refused) once, before the workers start
        open_history(args.history, init=True if args.init else None).close()

    def report(outcome: BagOutcome) -> None:  # a failure as it happens, above the bar
        if outcome.status == 'failed':
            # bag folder names and reasons come from other people's files: escaped
            tqdm.write(f'failed: {shorten(outcome.bag, LINE_LIMIT)} '
                       f'(robot {shorten(outcome.robot, LINE_LIMIT)}):'
                       f' {shorten(outcome.reason, 400)}', file=sys.stderr)

    result = run_batch(tasks, settings=settings, workers=args.workers or 1,
                       dask_address=args.dask, progress=progress_wanted(args),
                       on_outcome=report)
    if not emit_json(args, result.summary()):
        print(result.summary_line())
    return 2 if result.failed else 0
