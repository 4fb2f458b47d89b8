"""
``robot-wear-monitor identify``: files in, a loadable parameter set out; mistakes exit 2.

The friction levels are written by ``test/wear_testing/independent_robot.py``'s model functions
(not the package's simulation) for a joint whose parameters differ from the packaged set.
"""

import json

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.estimation.estimator import estimate_wear
from robot_wear_monitor.model.params import load_parameter_set
from wear_testing import independent_robot as robot

GRID = np.array([2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1])
SIGMA = 4.23e-3
ROBOT = {**robot.PAPER_PARAMETERS, 'F_ctl': 0.05, 'F_stl': 0.2, 'phi_stl': 12.0,
         'F_sw': 1.1e-3, 'phi_sw': 2.6}


def write_csv(path, columns):
    names = list(columns)
    lines = [','.join(names)]
    lines += [','.join(repr(float(v)) if not isinstance(v, str) else v for v in row)
              for row in zip(*(columns[n] for n in names))]
    path.write_text('\n'.join(lines) + '\n', encoding='utf-8')
    return path


def levels(*, seed, n_experiments, wear=None, repeats=1, temperature=(30.0, 50.0),
           loads=(0.1, 0.9)):
    rng = np.random.default_rng(seed)
    speeds = np.repeat(GRID, repeats)
    columns = {k: [] for k in ('speed', 'friction', 'temperature', 'load', 'experiment')}
    for k in range(n_experiments):
        t, load = rng.uniform(*temperature), rng.uniform(*loads)
        w = 0.0 if wear is None else wear[k]
        friction = robot.friction_model(speeds, load, t, w, ROBOT) + rng.normal(
            0, SIGMA, speeds.size)
        columns['speed'] += list(speeds)
        columns['friction'] += list(friction)
        columns['temperature'] += [t] * speeds.size
        columns['load'] += [load] * speeds.size
        columns['experiment'] += [k] * speeds.size
    return columns


@pytest.fixture(scope='module')
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp('identify')
    baseline = write_csv(folder / 'baseline.csv', levels(seed=0, n_experiments=40))
    wear = 35.0 * (np.arange(20) / 15) ** 2
    test = write_csv(folder / 'wear.csv', levels(seed=1, n_experiments=20, wear=wear,
                                                 repeats=4, temperature=(38, 42),
                                                 loads=(0.45, 0.55)))
    return {'folder': folder, 'baseline': baseline, 'wear': test}


def test_identify_writes_a_loadable_set_report_and_figures(files, capsys):
    folder = files['folder']
    out = folder / 'robot.yaml'
    report = folder / 'report.json'
    code = main(['identify', str(files['baseline']), '--wear-test', str(files['wear']),
                 '--critical-experiment', '15', '--name', 'my_robot', '--out', str(out),
                 '--json-out', str(report), '--plots', str(folder / 'fig')])
    assert code == 0
    text = capsys.readouterr().out
    assert 'held-out error [mu, sigma]' in text and 'loaded back' in text
    params = load_parameter_set(out)
    assert params.name == 'my_robot'
    assert params.model.f_c_load == pytest.approx(0.05, abs=0.01)
    assert params.model.f_s_wear == pytest.approx(1.1e-3, rel=0.15)
    data = json.loads(report.read_text())
    assert data['loaded_back'] is True
    assert len(data['wear']['wear_levels']) == 20
    assert set(data['nominal']['parameters']) >= {'f_c0', 'alpha', 't_v0'}
    for name in ('identify_residuals.png', 'identify_wear.png'):
        size = (folder / 'fig' / name).stat().st_size
        assert 1000 < size < 150_000
    # every --params consumer can use it: the estimator reads it
    estimate = estimate_wear([2.1, 28.5, 35.1, 41.7], [0.16, 0.085, 0.075, 0.085],
                             params=params)
    assert np.isfinite(estimate.wear[0])
    assert main(['estimate', '--speeds', '28.5,35.1,41.7', '--friction', '0.085,0.075,0.085',
                 '--params', str(out)]) == 0


def test_identify_json_to_stdout_without_wear_test(files, capsys):
    out = files['folder'] / 'nominal.yaml'
    assert main(['identify', str(files['baseline']), '--out', str(out), '--json']) == 0
    data = json.loads(capsys.readouterr().out)
    assert data['wear'] is None
    assert data['name'] == 'identified_baseline'
    assert 0.9 < data['nominal']['held_out_error']['std'] / SIGMA < 1.1
    assert 'not identified: no wear test' in out.read_text()


def _mutated(files, name, change):
    columns = levels(seed=0, n_experiments=40)
    change(columns)
    return write_csv(files['folder'] / name, columns)


@pytest.mark.parametrize('change, message', [
    (lambda c: c.pop('temperature'), "no 'temperature' column"),
    (lambda c: c.pop('load'), "no 'load' column"),
    (lambda c: c.__setitem__('temperature', [40.0] * len(c['speed'])), 'single temperature'),
    (lambda c: c.__setitem__('load', [0.5] * len(c['speed'])), 'single load'),
    (lambda c: c.__setitem__('speed', [10.0 + (i % 3) for i in range(len(c['speed']))]),
     'distinct speed'),
])
def test_bad_baseline_exits_2_with_one_line(files, capsys, change, message):
    path = _mutated(files, f'bad_{abs(hash(message))}.csv', change)
    out = files['folder'] / 'never.yaml'
    assert main(['identify', str(path), '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert message in error
    assert len(error.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize('extra, message', [
    (['--critical-experiment', '99'], 'no such experiment'),
    (['--critical-experiment', 'x'], 'no such experiment'),
    ([], '--critical-experiment'),
])
def test_bad_wear_test_arguments_exit_2(files, capsys, extra, message):
    out = files['folder'] / 'never.yaml'
    argv = ['identify', str(files['baseline']), '--wear-test', str(files['wear']),
            '--out', str(out)] + extra
    assert main(argv) == 2
    error = capsys.readouterr().err
    assert message in error and len(error.strip().splitlines()) == 1
    assert not out.exists()


def test_wear_test_without_experiment_column_and_named_columns(files, capsys):
    columns = levels(seed=1, n_experiments=3)
    columns.pop('experiment')
    path = write_csv(files['folder'] / 'noexp.csv', columns)
    out = files['folder'] / 'never.yaml'
    assert main(['identify', str(files['baseline']), '--wear-test', str(path),
                 '--critical-experiment', '1', '--out', str(out)]) == 2
    assert "'experiment' is missing" in capsys.readouterr().err
    renamed = levels(seed=0, n_experiments=40)
    renamed['joint_temp'] = renamed.pop('temperature')
    path = write_csv(files['folder'] / 'renamed.csv', renamed)
    assert main(['identify', str(path), '--temperature-column', 'joint_temp', '--out',
                 str(files['folder'] / 'renamed.yaml')]) == 0
    assert main(['identify', str(path), '--temperature-column', 'nope', '--out',
                 str(out)]) == 2
    assert 'nope' in capsys.readouterr().err


def test_temperature_bounds_option_sets_the_estimation_bounds(files, capsys):
    out = files['folder'] / 'bounds.yaml'
    assert main(['identify', str(files['baseline']), '--temperature-bounds', '35,45',
                 '--out', str(out)]) == 0
    params = load_parameter_set(out)
    assert (params.temperature_min_degc, params.temperature_max_degc) == (35.0, 45.0)
    assert 'given by --temperature-bounds' in out.read_text()
    capsys.readouterr()
    assert main(['identify', str(files['baseline']), '--temperature-bounds', '45,35',
                 '--out', str(out)]) == 2
    assert 'LOW < HIGH' in capsys.readouterr().err


def test_raw_runs_without_temperature_say_where_it_must_come_from(kuka_dir, tmp_path, capsys):
    run = kuka_dir / 'raw_runs' / 'joint6_vel_p5.csv.gz'
    out = tmp_path / 'never.yaml'
    assert main(['identify', str(run), '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert "no 'temperature' column" in error and '--temperature-column' in error
    assert len(error.strip().splitlines()) == 1
    assert not out.exists()
