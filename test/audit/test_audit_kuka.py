"""Audit of the measured KUKA iiwa friction levels (skipped when ../shared is absent)."""

import json
import os

import numpy as np
import pytest
from robot_wear_monitor.audit.data import load_audit_data
from robot_wear_monitor.audit.run import run_audit
from threadpoolctl import threadpool_info, threadpool_limits


@pytest.fixture(scope='module')
def kuka_table(kuka_dir):
    return load_audit_data(kuka_dir)


def _blas_threads():
    """Return the thread counts of the loaded BLAS libraries (numpy's and scipy's OpenBLAS)."""
    return sorted({int(info['num_threads']) for info in threadpool_info()
                   if info['user_api'] == 'blas'})


@pytest.fixture(scope='module')
def kuka_audit(kuka_table):
    # one BLAS thread, as the command line runs it (blas_threads.use_single_blas_thread)
    with threadpool_limits(limits=1, user_api='blas'):
        assert _blas_threads() == [1]
        return run_audit(table=kuka_table, model='speed', group='joint', max_effects=2)


def test_raw_runs_are_segmented_into_levels_per_pass_pair(kuka_table):
    assert kuka_table.n_rows > 600
    assert set(kuka_table.text['joint']) == {f'joint{i}' for i in range(1, 8)}
    assert set(kuka_table.text['pose']) == {'standard', 'new_pose'}
    assert len(set(kuka_table.text['experiment'])) > 60
    # sign flipped as the data's author did: friction of the unloaded joints is positive
    joint6 = kuka_table.text['joint'] == 'joint6'
    assert np.all(kuka_table.numeric['friction'][joint6] > 0)


def test_speed_model_misses_the_window_and_gravity_load_effects(kuka_table, kuka_audit):
    result = kuka_audit
    # joint3's speed oscillates: levels at 5 set-points at most (4 before issue 43's band of
    # the run's own noise; its 0.2 rad/s levels may straddle two of the audit's 2 % bins)
    joint3 = kuka_table.numeric['speed'][kuka_table.text['joint'] == 'joint3']
    assert len(np.unique(np.round(joint3, 1))) <= 5
    assert result.effects, 'the speed-only model leaves significant structure'
    named = {v for effect in result.effects for v in effect.variables}
    assert named & {'position_span', 'load_torque', 'position_centre'}
    # model (4) in its domain with unsupported Stribeck terms dropped (issue 43) starts lower
    # (0.096-0.099 N.m held out, was 0.137), so the effects' share is smaller: 0.099 -> 0.088
    # on the 784 levels of issue 43's reading of the runs (0.096 -> 0.074 on the 781 before)
    assert result.rms_after < 0.92 * result.rms_before
    # issue 10: a candidate whose effect raises the held-out error is rejected, the next tried
    # (with the one fitter of issue 43 the first two candidates are both added, so the
    # two-effect audit may end at its maximum before any is rejected)
    assert any(s['decision'].startswith('rejected') for s in result.steps) or (
        len(result.effects) == 2 and result.stop_reason.startswith('maximum'))
    assert result.noise_floor < result.rms_after  # the audit does not reach the floor here
    json.dumps(result.to_dict(), allow_nan=False)


def test_several_blas_threads_give_the_same_decisions_and_errors(kuka_table, kuka_audit):
    # the library with the BLAS's default threads must decide as the command line does (one
    # thread): the summation order must not pick the local minimum or the period.  The held-out
    # errors agree within half the 1 % gain a decision needs (0.2 % on this machine: one fold
    # of the second effect ends in another local minimum, its sum of squares 0.16 % higher)
    cores = len(os.sched_getaffinity(0))
    if cores < 2:
        pytest.skip('one core: the BLAS runs one thread only')
    with threadpool_limits(limits=cores, user_api='blas'):
        if max(_blas_threads()) < 2:
            pytest.skip('the BLAS runs one thread only here')
        threaded = run_audit(table=kuka_table, model='speed', group='joint', max_effects=2)

    def decisions(result):
        return [(s.get('tried'), s['decision'].split(':')[0]) for s in result.steps]

    assert decisions(threaded) == decisions(kuka_audit)
    assert [e.name for e in threaded.effects] == [e.name for e in kuka_audit.effects]
    for one, several in zip(kuka_audit.steps, threaded.steps):
        if 'rms_cv_with_term' in one:
            assert several['rms_cv_with_term'] == pytest.approx(one['rms_cv_with_term'],
                                                                rel=5e-3)
    assert threaded.rms_before == pytest.approx(kuka_audit.rms_before, rel=5e-3)
    assert threaded.rms_after == pytest.approx(kuka_audit.rms_after, rel=5e-3)


def test_the_replicate_error_and_the_lack_of_fit_statement_on_measured_data(kuka_audit):
    # the cycles of a run repeat its speed: their scatter is the pure error of the data
    lof = kuka_audit.lack_of_fit
    assert lof is not None and lof.pure_dof > 500
    assert 0.01 < lof.pure_error < kuka_audit.rms_after
    # the goal: within 1.5 x the replicate error, or a statement naming the speeds
    assert kuka_audit.rms_after <= 1.5 * lof.pure_error or (
        lof.p_value < 0.01 and lof.speed_range is not None
        and 'the model cannot explain the speeds' in lof.statement()
        and 'lack of fit remains against the replicate error' in kuka_audit.stop_reason)
    assert kuka_audit.noise_floor == lof.pure_error


def test_single_raw_run_is_read_and_segmented(kuka_dir):
    table = load_audit_data(kuka_dir / 'raw_runs' / 'joint6_vel_p5.csv.gz')
    assert table.n_rows >= 4
    assert 'joint' not in table.columns  # one joint: no group column
    assert np.all(np.abs(table.numeric['speed'] - 0.5) < 0.02)
