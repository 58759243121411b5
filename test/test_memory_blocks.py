"""Constant-memory analysis (issue #16): least squares a block of rows at a time equal
the whole-matrix solutions, and spilled lift tables read back the same values. Small
data only: the mechanisms, not multi-million-sample bags (benchmarks/bench_memory.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.flank_fit import fit_shift
from cam_metrology.metrology.spill import release, spill
from cam_metrology.metrology.synthetic import PolynomialRampCam

CAM = PolynomialRampCam()


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize('block_rows', [1, 3, 64, 1000, 10_000])
def test_block_lstsq_equals_whole_matrix_lstsq(block_rows):
    rng = np.random.default_rng(3)
    a = rng.normal(size=(2000, 4)) * [1.0, 1e3, 1e-3, 7.0]   # columns of unlike scales
    y = a @ [0.5, -2e-3, 40.0, 1.5] + rng.normal(0, 0.1, 2000)
    want = np.linalg.lstsq(a, y, rcond=None)[0]
    assert _rel(block_lsq.lstsq(a, y, block_rows=block_rows), want) < 1e-12
    tri, rows = block_lsq.triangle((a[k:k + block_rows], y[k:k + block_rows])
                                   for k in range(0, 2000, block_rows))
    assert rows == 2000
    # rho^2 of the triangle is the residual sum of squares of the solution
    res = y - a @ want
    assert tri[4, 4] ** 2 == pytest.approx(res @ res, rel=1e-12)
    inv, sv = block_lsq.inverse_normal(tri)
    assert _rel(inv, np.linalg.inv(a.T @ a)) < 1e-10
    assert _rel(sv, np.linalg.svd(a, compute_uv=False)) < 1e-12


def test_harmonic_lstsq_with_a_mask_equals_the_masked_matrix():
    rng = np.random.default_rng(5)
    theta = rng.uniform(0, 2 * np.pi, 5000)
    y = 3e-3 + 2e-6 * np.cos(theta) - 1e-6 * np.sin(theta) + rng.normal(0, 1e-7, 5000)
    mask = rng.random(5000) < 0.3
    t = theta[mask]
    want = np.linalg.lstsq(np.column_stack([np.ones_like(t), np.cos(t), np.sin(t)]),
                           y[mask], rcond=None)[0]
    got = block_lsq.harmonic_lstsq(theta, y, mask, block_rows=97)
    assert _rel(got, want) < 1e-12
    assert got == pytest.approx([3e-3, 2e-6, -1e-6], abs=2e-8)   # and the truth


@pytest.mark.parametrize('runout, weighted, subset', [
    (False, False, False), (True, False, False), (True, True, True), (False, True, True)])
def test_block_fit_shift_equals_the_one_block_fit(runout, weighted, subset):
    """Gauss-Newton a block of rows at a time (blocks of 333 rows, and the used
    samples spread over many blocks) gives the one-block fit to 1e-12 relative."""
    rng = np.random.default_rng(11)
    n = 20_000
    theta = np.linspace(0.0, 6 * np.pi, n, endpoint=False)
    x = (theta + np.pi) % (2 * np.pi) - np.pi
    d_true = np.radians(0.01)
    s = 4e-4 + CAM(x - d_true, 0) + rng.normal(0, 1e-6, n)
    if runout:
        s += 3e-6 * np.cos(theta) - 1e-6 * np.sin(theta)
    kw = dict(theta=theta if runout else None,
              used=(rng.random(n) < 0.6) if subset else None,
              weights=rng.uniform(0.5, 2.0, n) if weighted else None)
    one = fit_shift(x, s, CAM, block_rows=1 << 20, **kw)
    many = fit_shift(x, s, CAM, block_rows=333, **kw)
    for name in ('d', 'c', 'd_std', 'c_std', 'sigma'):
        assert getattr(many, name) == pytest.approx(getattr(one, name), rel=1e-12, abs=0)
    assert many.runout == pytest.approx(one.runout, rel=1e-9, abs=1e-18)
    np.testing.assert_allclose(many.residuals, one.residuals, rtol=0, atol=1e-16)   # m
    assert abs(one.d - d_true) < 5 * one.d_std   # and it is the right answer


def test_spilled_table_reads_back_the_same_values():
    rng = np.random.default_rng(2)
    table = rng.normal(size=(50_000, 3))
    out = spill(table, min_bytes=1 << 20)
    assert isinstance(out, np.memmap) and not out.flags.writeable
    np.testing.assert_array_equal(out, table)   # the same float64 bits: a copy, no rounding
    release(out)
    np.testing.assert_array_equal(out[:, 1], table[:, 1])
    assert spill(out) is out
    small = table[:100]
    assert spill(small, min_bytes=1 << 20) is small and spill(None) is None
    release(small, None, [out, small])   # arrays in memory are left alone


def _resident_kb(address: int) -> int | None:
    """Rss [kB] of the mapping holding ``address`` (Linux /proc/self/smaps), or None."""
    try:
        lines = open('/proc/self/smaps').read().splitlines()
    except OSError:
        return None
    inside = False
    for line in lines:
        head = line.split()[0]
        if '-' in head and all(c in '0123456789abcdef-' for c in head):
            lo, hi = (int(v, 16) for v in head.split('-'))
            inside = lo <= address < hi
        elif inside and line.startswith('Rss:'):
            return int(line.split()[1])
    return None


def test_release_gives_back_the_pages_a_reader_touched():
    table = spill(np.arange(3 * 400_000, dtype=float).reshape(-1, 3), min_bytes=1)
    address = table.ctypes.data
    if _resident_kb(address) is None:
        pytest.skip('no /proc/self/smaps')
    assert float(table[:, 1].sum()) == pytest.approx(3 * 400_000 * (400_000 - 1) / 2
                                                     + 400_000)
    assert _resident_kb(address) >= 0.9 * table.nbytes / 1024   # read: resident
    release(table)
    assert _resident_kb(address) < 0.1 * table.nbytes / 1024
    assert table[-1, 2] == 3 * 400_000 - 1   # still there, read again from the file


@pytest.mark.parametrize('block', [1, 2, 7, 1 << 16])
def test_unwrap_a_block_at_a_time_is_numpy_unwrap(block):
    from cam_metrology.metrology.features import unwrapped_blocks, unwrapped_span

    rng = np.random.default_rng(9)
    turning = np.cumsum(rng.uniform(-0.5, 3.0, 3000))   # forwards and back, big steps
    for theta in (np.mod(turning, 2 * np.pi), -np.mod(turning, 2 * np.pi) + 1.0,
                  np.array([0.0, np.pi, 0.0, -np.pi, 2 * np.pi])):   # steps of exactly pi
        got = np.concatenate(list(unwrapped_blocks(theta, block)))
        np.testing.assert_array_equal(got, np.unwrap(theta))
    assert unwrapped_span(np.mod(turning, 2 * np.pi)) == np.ptp(np.unwrap(
        np.mod(turning, 2 * np.pi)))


def test_out_bag_written_during_the_replay_reads_back_as_the_one_written_after(tmp_path):
    """``analyze --out-bag`` writes while replaying (no outputs held): the bag holds the
    same messages, in the same order, with the same bytes, as ``write_outputs`` of a
    replay that kept every output; and its report is the analysis' report."""
    from pathlib import Path

    from cam_metrology import bagio
    from cam_metrology.offline.analyze import analyze_bag, make_cores
    from cam_metrology.offline.replay import run_offline, write_outputs
    from cam_metrology.wire.topics import METROLOGY_REPORT

    bag = Path(__file__).resolve().parents[1] / 'bags' / 'default_clean'
    streamed, after = tmp_path / 'streamed', tmp_path / 'after'
    run = analyze_bag(str(bag), out_bag=str(streamed), only_metrology=True)
    cores, _ = make_cores({}, True)   # several cores: test_replay (the same writer)
    kept = run_offline(bag, cores, superseded_tables=True)
    n = write_outputs(kept, after)
    assert n == len(kept.outputs) > 5

    def messages(path):
        return [(m.topic, m.stamp_ns, bytes(m.msg))
                for m in bagio.iter_messages(path, raw=True)]

    got, want = messages(streamed), messages(after)
    assert len(got) == len(want) > 5000
    assert got == want
    assert bagio.bag_topics(streamed) == bagio.bag_topics(after)
    (last,) = [m for m in bagio.iter_messages(streamed, [METROLOGY_REPORT])][-1:]
    report = json.loads(last.msg.data)
    assert report['features']['lobe_1']['angle_deg'] == \
        run.report['features']['lobe_1']['angle_deg']


@pytest.mark.parametrize('reach', [None, 1e-6])
def test_sensitive_point_on_the_samples_near_its_windows_equals_all_samples(
        monkeypatch, reach):
    """The sensitive-point shift from the samples near its windows (copied once) is the
    one from every sample; a shift beyond their reach falls back to every sample."""
    from cam_metrology.metrology import sensitive_point as spm

    rng = np.random.default_rng(4)
    x = rng.uniform(-np.pi, np.pi, 30_000)
    d_true = np.radians(0.02)
    ref = CAM(x - d_true, 0) + rng.normal(0, 1e-6, x.size)
    used = rng.random(x.size) < 0.9
    lo, hi = CAM.support
    am, an = spm.sensitive_points(CAM, lo, hi)
    kw = dict(half_window=np.radians(1.0), pairs=1, spacing=np.radians(0.5), order=1,
              limits=(-np.inf, np.inf), inward_only=False, validity_tol=1e-6, max_iter=10)
    whole = spm._sp_iterate(x[used], ref[used], CAM, am, an, max_shift=np.inf, **kw)
    if reach is not None:
        monkeypatch.setattr(spm, 'SP_REACH', reach)   # the shift (0.02 deg) is beyond it
    got = spm.sensitive_point_shift(x, ref, CAM, am, an, used=used, **kw)
    assert got.d == whole.d and got.d_std == whole.d_std and got.valid == whole.valid
    assert [c.samples for pair in got.crossings for c in pair] == \
        [c.samples for pair in whole.crossings for c in pair]
    assert abs(got.d - d_true) < 5 * got.d_std


def test_local_deviation_in_place_equals_the_copy() -> None:
    """``overwrite=True`` (a table's residual column used for the result) gives the same
    numbers as the copying path and reuses the array, for angles in order and out of
    order."""
    from cam_metrology.metrology.lift_error import local_deviation

    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(-3, 3, 5000))
    r = rng.normal(0, 1e-6, 5000)
    want = local_deviation(x, r)
    work = r.copy()
    got = local_deviation(x, work, overwrite=True)
    assert got is work
    np.testing.assert_allclose(got, want, rtol=0, atol=0)
    shuffled = rng.permutation(5000)   # angles out of order: scattered back in place
    rs = r[shuffled].copy()
    want = local_deviation(x[shuffled], rs)
    got = local_deviation(x[shuffled], rs, overwrite=True)
    assert got is rs
    np.testing.assert_allclose(got, want, rtol=0, atol=0)
    assert not np.array_equal(want, r[shuffled])   # the deviations, not the input


def test_analysis_without_plot_tables_gives_the_same_report() -> None:
    """``analyze`` without ``--report`` makes no referenced copies of the lift tables
    (``plot_tables=False``: memory for features of millions of samples): the report is
    the same as with them, number for number, and no tables are kept."""
    import json
    from pathlib import Path

    from cam_metrology.offline.analyze import analyze_bag

    bag = str(Path(__file__).resolve().parent.parent / 'bags' / 'irregular')
    with_tables = analyze_bag(bag, plot_tables=True)
    without = analyze_bag(bag, plot_tables=False)
    assert with_tables.tables and without.tables == {}
    a, b = (json.dumps({k: v for k, v in r.report.items() if k != 'provenance'},
                       sort_keys=True) for r in (with_tables, without))
    assert a == b


def _assembled(spill_bytes: int, samples, chunk: int = 997):
    """The samples through a FeatureAssembler: in chunks (bulk), a few per message,
    two NaN samples; closed by feature_done."""
    from cam_metrology.metrology.features import FeatureAssembler

    asm = FeatureAssembler(spill_bytes=spill_bytes)
    theta, s = samples.theta.copy(), samples.s.copy()
    theta[5], s[77] = np.nan, np.inf   # dropped and counted
    n = theta.size
    for k in range(0, n - 10, chunk):
        b = min(k + chunk, n - 10)
        assert asm.add_bulk(['lobe'] * (b - k), samples.stamp_ns[k:b], theta[k:b],
                            s[k:b], 0) == []
    for k in range(n - 10, n):   # the per-message path after the bulk one
        assert asm.add('lobe', int(samples.stamp_ns[k]), float(theta[k]), float(s[k]), 0) == []
    (fs,) = asm.close('lobe')
    return fs


def test_a_spilled_feature_is_assembled_and_measured_as_one_in_memory():
    """A feature whose columns go to temporary files as they arrive (``spill_bytes``
    small) holds the same samples as one assembled in memory, and its analysis gives
    the same report values (angles to 1e-9 deg, lift errors to 1e-9 um)."""
    from cam_metrology.metrology.analysis import Settings, analyze_lobe
    from cam_metrology.metrology.synthetic import sample_lobe

    nose = np.radians(123.4)
    samples = sample_lobe(CAM, nose, n_per_rev=3600, revolutions=3.3, noise=1e-6, seed=4)
    mem = _assembled(1 << 40, samples)
    disk = _assembled(1024, samples)
    assert isinstance(disk.theta, np.memmap) and isinstance(disk.s, np.memmap)
    assert isinstance(disk.stamp_ns, np.memmap) and not isinstance(mem.theta, np.memmap)
    assert (disk.received, disk.nan_dropped, disk.duplicates_dropped) == \
        (mem.received, mem.nan_dropped, mem.duplicates_dropped) == (samples.theta.size, 2, 0)
    assert disk.revolutions == pytest.approx(mem.revolutions, abs=1e-12)
    for a, b in ((disk.theta, mem.theta), (disk.s, mem.s)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(disk.stamp_ns, mem.stamp_ns)   # integers [ns]
    got = analyze_lobe(disk, CAM, 1, Settings())
    want = analyze_lobe(mem, CAM, 1, Settings())
    assert got.values['angle_deg'] == pytest.approx(want.values['angle_deg'], abs=1e-9)
    assert got.values['angle_deg'] == pytest.approx(np.degrees(nose), abs=5e-3)   # truth
    for key in ('max_plus', 'max_minus', 'rms'):
        assert got.values['lift_error_um'][key] == pytest.approx(
            want.values['lift_error_um'][key], abs=1e-9)
    np.testing.assert_allclose(got.table, want.table, rtol=0, atol=1e-15)


def test_referenced_rows_are_the_kept_rows_of_the_referenced_table():
    """``referenced_rows`` (a block at a time, no referenced copy of the table) equals
    ``feature_referenced``'s table at its kept rows, with and without the harmonic."""
    from cam_metrology.metrology.lift_error import feature_referenced, referenced_rows

    rng = np.random.default_rng(8)
    alpha = np.sort(rng.uniform(-np.pi, np.pi, 300_000))
    design = CAM(alpha, 0)
    measured = design + 2e-6 * np.cos(alpha) + 5e-6 + rng.normal(0, 1e-7, alpha.size)
    measured[1000] += 1e-3   # a spike: not kept
    table = spill(np.column_stack([alpha, measured, design]), min_bytes=1)
    for runout in (False, True):
        ref, good = feature_referenced(table, {'runout_fitted': runout})
        rows = referenced_rows(table, {'runout_fitted': runout})
        assert not good[1000] and rows.shape == (int(np.count_nonzero(good)), 3)
        np.testing.assert_allclose(rows, ref[good], rtol=0, atol=1e-18)   # m, rad
        # the base circle referenced: the offset (and the run-out) are gone
        base = rows[:, 2] == 0
        assert abs(float(np.median(rows[base, 1]))) < 1e-7 + 3e-6 * (not runout)


def test_readings_minus_harmonic_built_in_blocks_into_a_spilled_column() -> None:
    """The run-out-free readings of the per-revolution fits, written a block at a time
    into a temporary file (1.2 M samples: above the spill size), equal the closed form
    s - (a cos theta + b sin theta) to 1e-15 m; below the spill size they stay in memory
    with the same values."""
    rng = np.random.default_rng(11)
    theta = rng.uniform(0.0, 8 * np.pi, 1_200_000)
    s = 1e-3 * rng.normal(size=theta.size)
    a, b = 12e-6, -7e-6
    want = s - (a * np.cos(theta) + b * np.sin(theta))
    got = block_lsq.minus_harmonic(theta, s, a, b)
    assert isinstance(got, np.memmap) and not got.flags.writeable
    assert float(np.max(np.abs(got - want))) < 1e-15
    small = block_lsq.minus_harmonic(theta[:1000], s[:1000], a, b)
    assert not isinstance(small, np.memmap)
    assert float(np.max(np.abs(small - want[:1000]))) < 1e-15


def test_base_reference_falls_back_to_the_fitted_level_and_runout() -> None:
    """With fewer than 10 base-circle samples the reference is the fit's level and
    run-out, c + a cos theta + b sin theta [m], at every sample."""
    from cam_metrology.metrology.analysis import base_reference

    theta = np.linspace(0.0, 2 * np.pi, 500, endpoint=False)
    s = np.zeros(theta.size)
    base = np.zeros(theta.size, bool)
    base[:5] = True
    ref = base_reference(theta, s, base, True, (2e-5, (3e-6, -4e-6)))
    want = 2e-5 + 3e-6 * np.cos(theta) - 4e-6 * np.sin(theta)
    assert float(np.max(np.abs(ref - want))) < 1e-18
