"""
Convert the KUKA LBR iiwa 14 raw friction runs into one MCAP bag of sensor_msgs/JointState.

The raw runs (``../shared/data/external/kuka_iiwa_yezhao_drake/raw_runs/*.csv.gz``, see its
PROVENANCE.md) hold one joint per run: time, position, velocity and torque of the tested joint.
This script lays the runs one after the other on one time line and publishes every sample as a
JointState of all 7 joints ``iiwa_joint_1`` .. ``iiwa_joint_7``:

* the tested joint: position ``q_rad``, velocity ``dq_rad_s``, effort ``tau_measured_Nm``
  (raw sign, N m) of the run, sample by sample;
* the six other joints: the position the data gives for them in that run (their mean over the
  run, ``q<k>_mean_rad`` of ``runs_index.csv``; the raw runs do not hold their samples),
  velocity 0 and effort 0 (the data has no velocity or torque of the held joints).

Time: run k's header stamps are ``offset_k + t_s`` with ``t_s`` the run's own time (so the clock
reset inside ``joint7_vel_p6`` stays in the header stamps) and ``offset_k`` a whole number of
nanoseconds placing the run ``gap_s`` after the previous one (the first run starts at
2017-01-15 00:00:00 UTC, when the data were recorded).  The bag receive time is the header stamp,
made strictly increasing (1 ns after the previous message where the stamps go back), so the
bag order is the file order.  The run table (file, joint, offset, messages) is stored in the
bag's ``metadata.yaml`` under ``custom_data: kuka_runs`` (JSON).

Usage::

    python3 bench/kuka_to_bag.py OUT_BAG [--kuka-dir DIR] [--storage mcap|sqlite3]
        [--test-set joint3 ...] [--runs-per-set N]

Segment a joint of the bag with ``raw_run_segmenter_config(joint='iiwa_joint_N')``: it finds the
same passes as the raw-run path (test/recordings/test_kuka_bag.py).
"""

from __future__ import annotations

import argparse
import csv
from dataclasses import asdict, dataclass
import json
import os
from pathlib import Path
import sys
import time
from typing import Sequence

import numpy as np
from robot_wear_monitor.recordings.bags import (encode_joint_states, JOINT_STATE_TYPE,
                                                JOINT_STATES_TOPIC, STORAGES, TYPESTORE)
from robot_wear_monitor.recordings.tables import list_kuka_runs, parse_run_name, read_kuka_run

#: Joint names of the iiwa in the bag (those of Drake's iiwa14 URDF).
JOINT_NAMES = tuple(f'iiwa_joint_{k}' for k in range(1, 8))
#: Header stamp of the first sample of the first run [ns]: 2017-01-15 00:00:00 UTC.
START_NS = 1_484_438_400 * 1_000_000_000
DEFAULT_KUKA_DIR = Path(__file__).resolve().parents[2] / 'shared' / 'data' / 'external' / \
    'kuka_iiwa_yezhao_drake'


@dataclass(frozen=True)
class PlacedRun:
    """
    Where one raw run lies in the bag.

    :ivar source: the raw run file (relative to the KUKA folder).
    :ivar test_set: its test set, e.g. ``joint5_new_pose_friction_test``.
    :ivar joint: the tested joint's name in the bag.
    :ivar offset_ns: header stamp [ns] = offset_ns + round(t_s x 1e9).
    :ivar first_message: index of its first message in the bag.
    :ivar messages: its number of messages (= samples).

    """

    source: str
    test_set: str
    joint: str
    offset_ns: int
    first_message: int
    messages: int


def held_positions(kuka_dir: Path) -> dict[str, list[float]]:
    """Return raw run file name -> mean position of the 7 joints [rad] (runs_index.csv)."""
    table = {}
    with open(kuka_dir / 'runs_index.csv', newline='', encoding='utf-8') as stream:
        for row in csv.DictReader(stream):
            table[Path(row['file']).name] = [float(row[f'q{k}_mean_rad']) for k in range(1, 8)]
    return table


def select_runs(kuka_dir: Path, *, test_sets: Sequence[str] | None = None,
                runs_per_set: int | None = None) -> list[Path]:
    """Return the raw runs to convert, in bag order (by test set, then by speed)."""
    runs = list_kuka_runs(kuka_dir)
    if test_sets:
        runs = [r for r in runs if parse_run_name(r)[0] in set(test_sets)]
    if runs_per_set is not None:
        kept, count = [], {}
        for run in runs:
            test_set = parse_run_name(run)[0]
            count[test_set] = count.get(test_set, 0) + 1
            if count[test_set] <= runs_per_set:
                kept.append(run)
        runs = kept
    return runs


def convert(kuka_dir: str | os.PathLike, out: str | os.PathLike, *, storage: str = 'mcap',
            test_sets: Sequence[str] | None = None, runs_per_set: int | None = None,
            gap_s: float = 1.0) -> list[PlacedRun]:
    """Write the raw runs as one bag at ``out`` (which must not exist); return the run table."""
    from rosbags.rosbag2 import Writer
    folder = Path(kuka_dir)
    target = Path(out)
    if target.exists():
        raise FileExistsError(f'{target}: already exists')
    held = held_positions(folder)
    runs = select_runs(folder, test_sets=test_sets, runs_per_set=runs_per_set)
    if not runs:
        raise ValueError(f'{folder}: no raw run selected')
    placed: list[PlacedRun] = []
    writer = Writer(target, version=9, storage_plugin=STORAGES[storage])
    writer.open()
    try:
        connection = writer.add_connection(JOINT_STATES_TOPIC, JOINT_STATE_TYPE,
                                           typestore=TYPESTORE)
        next_start_ns = START_NS
        last_receive = -1
        first_message = 0
        for path in runs:
            run = read_kuka_run(path)
            column = run.joint - 1
            n = len(run)
            t_ns = np.round(run.t_s * 1e9).astype(np.int64)
            offset_ns = int(next_start_ns - t_ns.min())
            stamp_ns = offset_ns + t_ns
            position = np.tile(np.asarray(held[path.name], dtype=np.float64), (n, 1))
            velocity = np.zeros((n, 7))
            effort = np.zeros((n, 7))
            position[:, column] = run.q_rad
            velocity[:, column] = run.dq_rad_s
            effort[:, column] = run.tau_measured_Nm
            messages = encode_joint_states(stamps_s=np.zeros(n), names=JOINT_NAMES,
                                           position=position, velocity=velocity,
                                           effort=effort)
            # the exact stamps (float seconds would round them to ~0.2 us)
            size = len(messages[0])
            block = np.frombuffer(b''.join(messages), dtype=np.uint8).reshape(n, size).copy()
            sec, nanosec = np.divmod(stamp_ns, 1_000_000_000)
            block[:, 4:8] = sec.astype('<i4').view(np.uint8).reshape(n, 4)
            block[:, 8:12] = nanosec.astype('<u4').view(np.uint8).reshape(n, 4)
            data = block.tobytes()
            # receive time: the stamp, made strictly increasing (bag order = file order)
            index = np.arange(n)
            base = stamp_ns - index
            base[0] = max(base[0], last_receive + 1)
            receive = (np.maximum.accumulate(base) + index).tolist()
            for i in range(n):
                writer.write(connection, receive[i], data[i * size:(i + 1) * size])
            last_receive = int(receive[-1])
            placed.append(PlacedRun(source=str(path.relative_to(folder)),
                                    test_set=run.test_set, joint=JOINT_NAMES[column],
                                    offset_ns=offset_ns, first_message=first_message,
                                    messages=n))
            first_message += n
            next_start_ns = int(stamp_ns.max()) + int(round(gap_s * 1e9))
        writer.set_custom_data('kuka_runs', json.dumps([asdict(p) for p in placed]))
    finally:
        writer.close()
    return placed


def placed_runs(bag: str | os.PathLike) -> list[PlacedRun]:
    """Return the run table stored in a converted bag's metadata.yaml."""
    from ruamel.yaml import YAML
    meta = YAML(typ='safe').load((Path(bag) / 'metadata.yaml').read_text())
    custom = meta['rosbag2_bagfile_information'].get('custom_data') or {}
    return [PlacedRun(**entry) for entry in json.loads(custom['kuka_runs'])]


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: convert the raw runs and print what was written."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('out', help='bag folder to create')
    parser.add_argument('--kuka-dir', default=str(DEFAULT_KUKA_DIR))
    parser.add_argument('--storage', choices=sorted(STORAGES), default='mcap')
    parser.add_argument('--test-set', action='append', dest='test_sets',
                        help='convert only this test set (repeatable), e.g. joint3')
    parser.add_argument('--runs-per-set', type=int, default=None,
                        help='the first N runs (by speed) of each set')
    args = parser.parse_args(argv)
    start = time.perf_counter()
    try:
        placed = convert(args.kuka_dir, args.out, storage=args.storage,
                         test_sets=args.test_sets, runs_per_set=args.runs_per_set)
    except (OSError, ValueError) as error:
        print(f'kuka_to_bag: error: {error}', file=sys.stderr)
        return 2
    seconds = time.perf_counter() - start
    messages = sum(p.messages for p in placed)
    print(f'{args.out}: {len(placed)} runs, {messages} JointState messages of '
          f'{len(JOINT_NAMES)} joints ({args.storage}) in {seconds:.1f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
