"""
Re-analysis of many recordings: one replay task per bag, on a process pool or a Dask cluster.

The bags come as paths (a bag, or a folder of bags) or as a manifest CSV with the columns
``robot,bag``.  Every bag is one task (:func:`replay_one`), run by a process pool on this
machine (``workers``) or submitted to an existing Dask cluster (``dask_address``).  The history
is the output: each task opens the history itself (a SQLite file or a PostgreSQL URL) and adds
its experiments in one transaction each.

**Same numbers as one by one.**  A joint's wear trend is a filter over its experiments in time
order, so the bags of one robot run one after the other, earliest recording first; the robots
run in parallel: on the pool and on Dask alike, the next bag of a robot is submitted when its
previous bag is done.  A bag that fails is
reported with its reason and does not stop the others (a task never raises).  A bag already in
the history (same robot, same recording fingerprint) is skipped.
"""

from __future__ import annotations

from collections import deque
import concurrent.futures
from dataclasses import dataclass, field, replace
import hashlib
import math
import multiprocessing
import os
from pathlib import Path
import time
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, TYPE_CHECKING

from robot_wear_monitor.errors import InputError, no_such_path_text
from robot_wear_monitor.history import open_history
from robot_wear_monitor.input_files import check_robot_name, csv_rows, read_text_file
from robot_wear_monitor.recordings import is_bag
from robot_wear_monitor.text import shorten
from robot_wear_monitor.yaml_files import load_yaml_file

if TYPE_CHECKING:  # the monitoring modules load numpy: imported where a task runs
    from robot_wear_monitor.monitoring.monitor_config import MonitorConfig

#: The robot of bags given without a manifest and without ``--robot``.
DEFAULT_ROBOT = 'default'
#: Limits of a manifest: size of the file and number of rows.
MAX_MANIFEST_BYTES = 16 * 1024 * 1024
MAX_BAGS = 100_000
#: Bytes read from each end of each bag file for its fingerprint.
_FINGERPRINT_BYTES = 1 << 16


class BatchError(InputError):
    """The list of bags cannot be formed (missing path, bad manifest); the message says why."""


@dataclass(frozen=True)
class BagTask:
    """
    One recording to replay: the robot it comes from and where it is.

    ``out_bag``: where its node outputs go (``<out>/<robot>/<bag name>``), or None.
    ``order``: its place among the robot's bags (0 first; time order).
    """

    robot: str
    bag: Path
    out_bag: Optional[Path] = None
    order: int = 0


@dataclass(frozen=True)
class ReplaySettings:
    """
    What every task of a batch replays with (picklable: it travels to the workers).

    The fields mirror ``replay``'s options: the node config file, the joint selection, the
    overrides, the history (path or ``postgresql://`` URL) and the output storage.
    """

    history: Optional[str] = None
    config_file: Optional[str] = None
    joint: Optional[str] = None
    joints: Optional[tuple[str, ...]] = None
    gear_ratio: Optional[float] = None
    torque_scale: Optional[float] = None
    params_file: Optional[str] = None
    storage: str = 'mcap'
    overwrite: bool = False
    recover: bool = True
    #: both nodes' validated parameters, read once where the batch starts (None: read from
    #: the fields above by each task); each task sets its robot (:meth:`configuration_for`)
    configuration: Optional[MonitorConfig] = None

    def configuration_for(self, robot: str) -> MonitorConfig:
        """Return the nodes' configuration of a task of ``robot`` (its ``robot_id``)."""
        if self.configuration is not None:
            return self.configuration.for_robot(robot)
        # deferred import: start-up time (numpy: the parent loads it late)
        from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
        return MonitorConfig.load(config_file=self.config_file, joint=self.joint,
                                  joints=list(self.joints) if self.joints else None,
                                  gear_ratio=self.gear_ratio, torque_scale=self.torque_scale,
                                  params_file=self.params_file, robot=robot)


@dataclass
class BagOutcome:
    """
    What one task did with its bag.

    ``status``: ``done``, ``skipped`` (already in the history) or ``failed`` (``reason`` says
    why).  ``experiments``: estimates added; ``alarms``: alarms raised among them;
    ``peak_rss_mb``: the worker process's peak resident memory [MB] after the task.
    """

    robot: str
    bag: str
    status: str
    reason: str = ''
    experiments: int = 0
    skipped_experiments: int = 0
    alarms: int = 0
    first_alarm: Optional[dict[str, Any]] = None
    out_bag: Optional[str] = None
    elapsed_s: float = 0.0
    peak_rss_mb: float = 0.0
    pid: int = 0

    def as_json(self) -> dict[str, Any]:
        """Return the outcome as a JSON-ready dict."""
        return dict(self.__dict__)


@dataclass
class BatchResult:
    """The outcomes of a batch, in the order the bags were given, and its totals."""

    outcomes: list[BagOutcome] = field(default_factory=list)
    wall_s: float = 0.0
    workers: int = 1
    executor: str = 'in-process'

    def count(self, status: str) -> int:
        """Return how many bags ended with ``status``."""
        return sum(1 for o in self.outcomes if o.status == status)

    @property
    def failed(self) -> list[BagOutcome]:
        """Return the bags that failed."""
        return [o for o in self.outcomes if o.status == 'failed']

    def summary(self) -> dict[str, Any]:
        """Return the JSON summary: totals and one entry per bag."""
        return {
            'bags': len(self.outcomes), 'done': self.count('done'),
            'skipped': self.count('skipped'), 'failed': self.count('failed'),
            'experiments': sum(o.experiments for o in self.outcomes),
            'alarms': sum(o.alarms for o in self.outcomes),
            'workers': self.workers, 'executor': self.executor, 'wall_s': self.wall_s,
            'outcomes': [o.as_json() for o in self.outcomes],
        }

    def summary_line(self) -> str:
        """Return the one-line summary printed at the end of a batch."""
        return (f'{len(self.outcomes)} bags: {self.count("done")} done, '
                f'{self.count("skipped")} skipped (already in the history), '
                f'{self.count("failed")} failed; '
                f'{sum(o.experiments for o in self.outcomes)} experiments, '
                f'{sum(o.alarms for o in self.outcomes)} alarms raised; '
                f'{self.wall_s:.1f} s on {self.workers} worker(s) ({self.executor})')


# --- which bags -----------------------------------------------------------------------------

def _cut(text: str, limit: int = 80) -> str:
    return text if len(text) <= limit else text[:limit - 1] + '\u2026'


def read_manifest(path: str | os.PathLike) -> list[tuple[str, Path]]:
    """
    Return the (robot, bag) rows of a manifest CSV with the columns ``robot,bag``.

    A relative bag path is relative to the manifest's folder.  The file is read with a bound
    as it is read (:func:`~robot_wear_monitor.input_files.read_text_file`: a regular file of
    at most :data:`MAX_MANIFEST_BYTES`); robot names follow ``--robot``'s rule.  Raises
    BatchError naming the file and line for a missing column, an empty robot or bag, a bad
    robot name, a field over the csv limit, text that is not UTF-8, or a file over the limits.
    """
    manifest = Path(path)
    where = f'--manifest {shorten(manifest, 200)}'
    text = read_text_file(manifest, what='manifest', limit_bytes=MAX_MANIFEST_BYTES,
                          error=BatchError)
    rows: list[tuple[str, Path]] = []
    lines = csv_rows(text, source=f'--manifest {manifest}', error=BatchError)
    header = next(lines, (1, []))[1]
    columns = {name.strip(): index for index, name in enumerate(header)}
    missing = {'robot', 'bag'} - set(columns)
    if missing:
        raise BatchError(f'{where}: missing column(s) {", ".join(sorted(missing))} '
                         '(the header must name robot,bag)')
    for line, row in lines:
        if not any(cell.strip() for cell in row):
            continue  # a blank line
        cells = {name: row[i].strip() if i < len(row) else '' for name, i in columns.items()}
        robot, bag = cells['robot'], cells['bag']
        if not robot or not bag:
            raise BatchError(f'{where}: line {line}: empty robot or bag')
        robot = check_robot_name(robot, where=f'{where}: line {line}: ', error=BatchError)
        rows.append((robot, (manifest.parent / bag) if not Path(bag).is_absolute()
                     else Path(bag)))
        if len(rows) > MAX_BAGS:
            raise BatchError(f'{where}: more than {MAX_BAGS} bags')
    return rows


def collect_bags(*, paths: Sequence[str | os.PathLike] = (),
                 manifest: str | os.PathLike | None = None, robot: str | None = None,
                 out_dir: str | os.PathLike | None = None) -> list[BagTask]:
    """
    Return the tasks of ``paths`` (bags, or folders of bags) and of a ``manifest``.

    Bags given as paths belong to ``robot`` (default :data:`DEFAULT_ROBOT`); a manifest names
    each bag's robot.  With ``out_dir``, each bag's output bag is ``out_dir/<robot>/<bag
    name>``.  Raises BatchError for a path that is neither a bag nor a folder with bags, a
    bag named twice, or no bag at all.
    """
    pairs: list[tuple[str, Path]] = []
    for given in paths:
        path = Path(given)
        if not path.exists():
            raise BatchError(no_such_path_text(_cut(str(path)), what='bag or folder'))
        if is_bag(path):
            pairs.append((robot or DEFAULT_ROBOT, path))
            continue
        inner = sorted(child for child in path.iterdir() if is_bag(child)) \
            if path.is_dir() else []
        if not inner:
            raise BatchError(f'{_cut(str(path))}: neither a bag nor a folder of bags')
        pairs += [(robot or DEFAULT_ROBOT, child) for child in inner]
    if manifest is not None:
        pairs += read_manifest(manifest)
    if not pairs:
        raise BatchError('no bag given (name bags, a folder of bags, or --manifest CSV)')
    if len(pairs) > MAX_BAGS:
        raise BatchError(f'{len(pairs)} bags: more than the limit of {MAX_BAGS}')
    seen: dict[Path, str] = {}
    for owner, bag in pairs:
        key = bag.resolve()
        if key in seen:
            raise BatchError(f'{_cut(str(bag))}: named twice (robots {seen[key]!r} and '
                             f'{owner!r})')
        seen[key] = owner
    names: dict[tuple[str, str], Path] = {}
    for owner, bag in pairs:
        previous = names.setdefault((owner, bag.name), bag)
        if out_dir is not None and previous != bag:
            raise BatchError(f'two bags of robot {owner!r} are named {bag.name!r} '
                             f'({previous} and {bag}): their outputs under --out would '
                             'collide')
    return order_tasks([BagTask(robot=owner, bag=bag,
                                out_bag=None if out_dir is None
                                else Path(out_dir) / owner / bag.name)
                        for owner, bag in pairs])


def recording_start_ns(bag: Path) -> Optional[int]:
    """Return the start time [ns since the epoch] from a bag's ``metadata.yaml``, or None."""
    if not bag.is_dir():
        return None
    try:  # read bounded as it is read (a regular file of at most MAX_YAML_BYTES)
        info = load_yaml_file(bag / 'metadata.yaml', what='bag metadata')
        return int(info['rosbag2_bagfile_information']['starting_time']
                   ['nanoseconds_since_epoch'])
    except (InputError, KeyError, TypeError, ValueError):
        return None


def order_tasks(tasks: Iterable[BagTask]) -> list[BagTask]:
    """
    Return ``tasks`` with each robot's bags numbered in time order (then by path).

    The list keeps the given order; ``order`` is a bag's place in its robot's sequence.
    """
    tasks = list(tasks)
    by_robot: dict[str, list[int]] = {}
    for index, task in enumerate(tasks):
        by_robot.setdefault(task.robot, []).append(index)
    ordered = list(tasks)
    for indices in by_robot.values():
        def key(index: int) -> tuple[float, str]:
            start = recording_start_ns(tasks[index].bag)
            return (math.inf if start is None else float(start), str(tasks[index].bag))
        for place, index in enumerate(sorted(indices, key=key)):
            ordered[index] = replace(tasks[index], order=place)
    return ordered


def recording_fingerprint(bag: str | os.PathLike) -> str:
    """
    Return a fingerprint of a recording's content (hex SHA-256).

    Over each file's name (relative to the bag), size and its first and last 64 KiB: the same
    recording copied elsewhere has the same fingerprint; a different or grown one does not.
    """
    root = Path(bag)
    files = [root] if root.is_file() else sorted(p for p in root.rglob('*') if p.is_file())
    digest = hashlib.sha256()
    for path in files:
        size = path.stat().st_size
        name = path.name if path == root else str(path.relative_to(root))
        digest.update(f'{name}\0{size}\0'.encode())
        with path.open('rb') as handle:
            digest.update(handle.read(_FINGERPRINT_BYTES))
            if size > 2 * _FINGERPRINT_BYTES:
                handle.seek(size - _FINGERPRINT_BYTES)
            digest.update(handle.read(_FINGERPRINT_BYTES))
    return digest.hexdigest()


# --- one task -------------------------------------------------------------------------------

def _peak_rss_mb() -> float:
    # deferred import: start-up time (resource: the peak-memory figure only)
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def replay_one(task: BagTask, settings: ReplaySettings) -> BagOutcome:
    """Replay one bag into the history; never raise (a failure is the outcome's ``reason``)."""
    # deferred import: start-up time (the replay: in the workers only)
    from robot_wear_monitor.blas_threads import use_single_blas_thread
    from robot_wear_monitor.monitoring.replay import replay_bag
    use_single_blas_thread()
    started = time.perf_counter()
    outcome = BagOutcome(robot=task.robot, bag=str(task.bag), status='failed',
                         pid=os.getpid())
    try:
        fingerprint = recording_fingerprint(task.bag)
        if settings.history is not None:
            with open_history(settings.history, robot=task.robot) as history:
                if history.has_recording(robot=task.robot, fingerprint=fingerprint):
                    outcome.status = 'skipped'
                    outcome.reason = 'already in the history'
                    return outcome
        configuration = settings.configuration_for(task.robot)
        if task.out_bag is not None:
            task.out_bag.parent.mkdir(parents=True, exist_ok=True)
        result = replay_bag(task.bag, out_bag=task.out_bag, configuration=configuration,
                            storage=settings.storage,
                            history_file=settings.history, overwrite=settings.overwrite,
                            progress=False, recover=settings.recover)
        outcome.experiments = len(result.updates)
        outcome.skipped_experiments = result.rejections.get(
            'friction_levels_already_in_history', 0)
        raised = [u for u in result.updates if u.alarm_raised]
        outcome.alarms = len(raised)
        if raised:
            outcome.first_alarm = {'joint': raised[0].joint, 'index': raised[0].index,
                                   'stamp_s': raised[0].stamp_s}
        outcome.out_bag = None if result.out_bag is None else str(result.out_bag)
        if settings.history is not None:
            with open_history(settings.history, robot=task.robot) as history:
                history.add_recording(robot=task.robot, fingerprint=fingerprint,
                                      name=task.bag.name, experiments=outcome.experiments)
        outcome.status = 'done'
    except InputError as error:
        outcome.reason = _cut(str(error).splitlines()[0] if str(error) else 'input error', 300)
    except Exception as error:  # noqa: BLE001 - a failed bag must not stop the batch
        outcome.reason = _cut(f'{type(error).__name__}: {error}', 300)
    finally:
        outcome.elapsed_s = time.perf_counter() - started
        outcome.peak_rss_mb = _peak_rss_mb()
    return outcome


# --- many tasks -----------------------------------------------------------------------------

def _chains(tasks: Sequence[BagTask]) -> dict[str, deque[int]]:
    """Return, per robot, the indices of its tasks in their time order."""
    chains: dict[str, list[int]] = {}
    for index, task in enumerate(tasks):
        chains.setdefault(task.robot, []).append(index)
    return {robot: deque(sorted(indices, key=lambda i: tasks[i].order))
            for robot, indices in chains.items()}


def _progress_bar(total: int, enabled: bool) -> Any:
    # deferred import: start-up time (tqdm: a progress bar only)
    from tqdm import tqdm
    return tqdm(total=total, unit='bag', desc='replay', disable=not enabled, mininterval=0.5)


def run_batch(tasks: Sequence[BagTask], *, settings: ReplaySettings, workers: int = 1,
              dask_address: str | None = None, dask_client: Any = None,
              progress: bool = False,
              on_outcome: Optional[Callable[[BagOutcome], None]] = None) -> BatchResult:
    """
    Replay every task; return the outcomes in the order of ``tasks``.

    ``workers`` 1 runs in this process; more runs a process pool of that size.
    ``dask_address`` (or an open ``dask_client``) submits the tasks to a Dask cluster instead.
    ``on_outcome`` is called in this process as each bag finishes (in completion order).
    """
    if workers < 1:
        raise BatchError(f'--workers: must be >= 1, got {workers}')
    outcomes: list[Optional[BagOutcome]] = [None] * len(tasks)
    started = time.perf_counter()
    bar = _progress_bar(len(tasks), progress)

    def finished(index: int, outcome: BagOutcome) -> None:
        outcomes[index] = outcome
        bar.update(1)
        if on_outcome is not None:
            on_outcome(outcome)

    with bar:
        if dask_address is not None or dask_client is not None:
            executor = _run_dask(tasks, settings, finished, dask_address, dask_client)
        elif workers == 1:
            executor = 'in-process'
            for chain in _chains(tasks).values():
                for index in chain:
                    finished(index, replay_one(tasks[index], settings))
        else:
            executor = f'process pool ({workers})'
            _run_pool(tasks, settings, finished, workers)
    result = BatchResult(outcomes=[o for o in outcomes if o is not None],
                         wall_s=time.perf_counter() - started, executor=executor,
                         workers=workers)
    return result


def _failed(task: BagTask, reason: str) -> BagOutcome:
    return BagOutcome(robot=task.robot, bag=str(task.bag), status='failed', reason=reason)


def _run_pool(tasks: Sequence[BagTask], settings: ReplaySettings,
              finished: Callable[[int, BagOutcome], None], workers: int) -> None:
    """Run the tasks on a process pool: each robot's next bag when its previous one is done."""
    chains = _chains(tasks)
    # fork where there is one: the workers start with the replay already imported (numpy,
    # scipy, rosbags: about 1 s a process); the parent holds no history connection
    # deferred import: load order (the replay before the workers fork)
    import robot_wear_monitor.monitoring.replay  # noqa: F401
    method = 'fork' if 'fork' in multiprocessing.get_all_start_methods() else 'spawn'
    context = multiprocessing.get_context(method)
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers,
                                                mp_context=context) as pool:
        running: dict[concurrent.futures.Future, tuple[str, int]] = {}

        def submit_next(robot: str) -> None:
            if chains[robot]:
                index = chains[robot].popleft()
                running[pool.submit(replay_one, tasks[index], settings)] = (robot, index)

        for robot in chains:
            submit_next(robot)
        while running:
            done, _ = concurrent.futures.wait(running,
                                              return_when=concurrent.futures.FIRST_COMPLETED)
            for future in done:
                robot, index = running.pop(future)
                try:
                    outcome = future.result()
                except Exception as error:  # noqa: BLE001 - a worker that died
                    outcome = _failed(tasks[index], f'worker failed: {type(error).__name__}: '
                                                    f'{_cut(str(error), 200)}')
                finished(index, outcome)
                submit_next(robot)


def _run_dask(tasks: Sequence[BagTask], settings: ReplaySettings,
              finished: Callable[[int, BagOutcome], None], address: str | None,
              client: Any) -> str:
    """Submit the tasks to Dask: each robot's next bag when its previous one is done."""
    try:
        # deferred import: optional extra 'dask'
        from distributed import as_completed, Client
    except ImportError as error:  # pragma: no cover - dask is a dependency
        raise BatchError(f'--dask needs the distributed package: pip install '
                         f'"robot_wear_monitor[dask]" ({error})') from None
    own = client is None
    if own:
        try:
            client = Client(address, timeout='20s')
        except (OSError, TimeoutError) as error:
            raise BatchError(f'--dask {_cut(str(address))}: cannot connect to the scheduler '
                             f'({_cut(str(error), 200)})') from None
    try:
        chains = _chains(tasks)
        running: dict[Any, tuple[str, int]] = {}

        def submit_next(robot: str) -> Any:
            index = chains[robot].popleft()
            future = client.submit(replay_one, tasks[index], settings, pure=False)
            running[future] = (robot, index)
            return future

        pending = as_completed([submit_next(robot) for robot in chains if chains[robot]])
        for future in pending:
            robot, index = running.pop(future)
            try:
                outcome = future.result()
            except Exception as error:  # noqa: BLE001 - a lost worker or task
                outcome = _failed(tasks[index], f'dask task failed: {type(error).__name__}: '
                                                f'{_cut(str(error), 200)}')
            finished(index, outcome)
            if chains[robot]:
                pending.add(submit_next(robot))
        workers = len(client.scheduler_info().get('workers', {}))
        return f'dask ({workers} workers)'
    finally:
        if own:
            client.close()


def settings_summary(settings: ReplaySettings) -> Mapping[str, Any]:
    """Return the settings as a JSON-ready dict (for the summary file)."""
    return dict(settings.__dict__, joints=list(settings.joints) if settings.joints else None)
