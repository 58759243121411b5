"""Analysis of one long feature out of memory (issue #26 item 4): exact medians by radix
selection, the stable angle order through buckets in temporary files, running medians
a chunk at a time, repeated angles merged a block at a time; and the whole lobe
analysis on its long-column path (forced on small data by lowering the spill size)
giving the numbers of the in-memory path."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import median_filter

from cam_metrology.metrology import long_columns, spill
from cam_metrology.metrology.synthetic import PolynomialRampCam

CAM = PolynomialRampCam()


def _values(rng: np.random.Generator, n: int, kind: int) -> np.ndarray:
    """Normal values [any unit] of several scales; with ties, zeros and -0.0."""
    v = rng.normal(size=n) * 10.0 ** rng.integers(-8, 3)
    if kind % 3 == 0:
        v = np.round(v, 1)   # many ties
    v[rng.random(n) < 0.05] = 0.0
    if kind % 5 == 0:
        v[: n // 3] = -0.0
    return v


@pytest.mark.parametrize('gather_max', [1, 7, 1 << 20])
def test_median_by_radix_selection_is_numpy_median(monkeypatch, gather_max) -> None:
    """``long_columns.median`` of values handed out in blocks equals ``numpy.median``
    (odd and even counts, ties, negative numbers and signed zeros), also when the
    selection needs all four 16-bit passes (``GATHER_MAX`` 1)."""
    monkeypatch.setattr(long_columns, 'GATHER_MAX', gather_max)
    rng = np.random.default_rng(1)
    for kind in range(12):
        n = int(rng.integers(1, 3000))
        v = _values(rng, n, kind)
        got = long_columns.median(lambda: (v[a:a + 97] for a in range(0, n, 97)))
        np.testing.assert_allclose(got, np.median(v), rtol=1e-15, atol=0)
    assert np.isnan(long_columns.median(lambda: iter([np.zeros(0)])))


def test_buckets_give_the_stable_sort_order() -> None:
    """Rows appended block by block into angle buckets and read back bucket by bucket
    come out in the order of ``numpy.argsort(kind='stable')`` (ties in arrival order),
    for 1 to 19 buckets."""
    rng = np.random.default_rng(2)
    dtype = np.dtype([('x', 'f8'), ('i', 'i8')])
    for count in (1, 2, 5, 19):
        n = int(rng.integers(500, 3000))
        x = np.round(rng.uniform(-3, 3, n), 2)   # ties
        buckets = long_columns.Buckets(dtype, 'x', float(x.min()), float(x.max()), count)
        for a in range(0, n, 101):
            rows = np.empty(min(101, n - a), dtype)
            rows['x'], rows['i'] = x[a:a + 101], np.arange(a, a + rows.size)
            buckets.add(rows)
        got = np.concatenate([part['i'] for part in buckets.sorted()])
        np.testing.assert_array_equal(got, np.argsort(x, kind='stable'))


def test_running_deviation_in_chunks_is_the_whole_median_filter() -> None:
    """Value minus the running median of 9, chunk by chunk (chunks of 0 to n values,
    shorter than the window too), equals ``median_filter(size=9, mode='nearest')`` of
    the whole sequence, to 1e-15 of the values' scale."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = int(rng.integers(1, 2000))
        v = rng.normal(size=n)
        cuts = np.sort(rng.integers(0, n, size=int(rng.integers(0, 40))))
        parts = np.split(np.arange(n), cuts)
        out = list(long_columns.running_deviation((v[p], p) for p in parts))
        idx = np.concatenate([p for _, p in out])
        np.testing.assert_array_equal(idx, np.arange(n))
        dev = np.concatenate([d for d, _ in out])
        np.testing.assert_allclose(dev, v - median_filter(v, size=9, mode='nearest'),
                                   rtol=0, atol=1e-15)


def test_local_deviation_of_long_columns_equals_the_in_memory_one(monkeypatch) -> None:
    """``local_deviation`` on its long path (buckets in temporary files; sorted angles:
    chunks) gives the in-memory numbers, for angles in order, shuffled, and spilled
    (memory-mapped) columns, in place or into a new column."""
    from cam_metrology.metrology.lift_error import local_deviation

    rng = np.random.default_rng(4)
    n = 20_000
    x = np.sort(rng.uniform(-3, 3, n))
    r = rng.normal(0, 1e-6, n)
    shuffled = rng.permutation(n)
    want_sorted = local_deviation(x, r)
    want_shuffled = local_deviation(x[shuffled], r[shuffled])
    monkeypatch.setattr(spill, 'SPILL_BYTES', 1024)
    got = local_deviation(x, r.copy(), overwrite=True)
    np.testing.assert_allclose(got, want_sorted, rtol=0, atol=1e-21)   # m
    xm = spill.spill(x[shuffled], min_bytes=1)
    rm = spill.spill(r[shuffled], min_bytes=1)
    got = local_deviation(xm, rm)
    assert isinstance(got, np.memmap)
    np.testing.assert_allclose(got, want_shuffled, rtol=0, atol=1e-21)


def test_repeated_angles_merged_block_by_block_equal_the_whole_merge() -> None:
    """``merge_repeated_blocks`` over a sorted table cut anywhere (positions across
    block ends) gives ``merge_repeated``'s positions, mean lifts and counts."""
    from cam_metrology.metrology.asymmetry import merge_repeated, merge_repeated_blocks

    rng = np.random.default_rng(5)
    for _ in range(40):
        n = int(rng.integers(1, 2000))
        a = np.sort(np.round(rng.uniform(-1, 1, n), int(rng.integers(1, 4))))
        h = rng.normal(size=n)
        parts = np.split(np.arange(n), np.sort(rng.integers(0, n, int(rng.integers(0, 20)))))
        got = merge_repeated_blocks((a[p], h[p]) for p in parts)
        want = merge_repeated(a, h)
        np.testing.assert_array_equal(got[2], want[2])
        for g, w in zip(got[:2], want[:2]):
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-15)


def _feature(jitter: float, grid: bool = False):
    """A lobe of 3.3 revolutions x 3600 samples (1 um noise, a first-harmonic run-out
    of 3 um, three spikes), encoder angles jittered by ``jitter`` [rad] (no two
    samples at the same angle: the table order is then the same for any sort), or on
    the encoder's grid of 3600 counts (``grid``: the samples of 3-4 revolutions at each
    angle are ties of the table's sort)."""
    from cam_metrology.metrology.features import FeatureSamples
    from cam_metrology.metrology.synthetic import sample_lobe

    samples = sample_lobe(CAM, np.radians(123.4), n_per_rev=3600, revolutions=3.3,
                          noise=1e-6, seed=6)
    rng = np.random.default_rng(6)
    theta = samples.theta + rng.uniform(-jitter, jitter, samples.theta.size)
    if grid:
        count = 2.0 * np.pi / 3600
        theta = np.round(samples.theta / count) * count
    s = samples.s + 3e-6 * np.cos(theta - 0.4)
    s[[500, 4000, 9000]] += 40e-6
    return FeatureSamples('lobe_1', theta, s, samples.stamp_ns, theta.size, 0, 0, 3.3)


@pytest.mark.parametrize('grid', [False, True], ids=['jittered', 'encoder_grid_ties'])
def test_lobe_on_its_long_column_path_gives_the_in_memory_report(
        monkeypatch, grid: bool) -> None:
    """The whole lobe analysis (fit, outliers, noise model, base reference, sensitive
    point, per-revolution repeatability, lift table, asymmetry, lift errors) and the
    form and cam card of its table, on the long-column path (every column spilled and
    read a block at a time: spill size lowered to 1 KiB) equal the in-memory path:
    angles to 1e-10 deg, lifts to 1e-9 um, the same outliers and iterations; also with
    thousands of tied angles (samples on the encoder's grid), whose order both paths
    take from one rule (``long_columns.angle_order``: ties in stamp order): the short
    path's unstable sort once moved the card's area by 8e-7 of itself and lift-error
    values by nm against the long path's."""
    from cam_design.cam_card import card_from_table
    from cam_metrology.metrology.analysis import Settings, analyze_lobe
    from cam_metrology.metrology.feature_form import lobe_form
    from cam_metrology.metrology.lift_error import referenced_rows
    from cam_metrology.metrology.lobe_columns import card_rows, support_area
    from cam_metrology.scene.model import FormSettings

    fs = _feature(0.0, grid=True) if grid else _feature(2e-6)

    def report(long: bool):
        if long:
            monkeypatch.setattr(spill, 'SPILL_BYTES', 1024)
        res = analyze_lobe(fs, CAM, 1, Settings())
        table = spill.spill(res.table)
        form = lobe_form(table, res.values, 1, FormSettings())
        rows = referenced_rows(table, res.values)
        assert isinstance(rows, np.memmap) == long
        heights = (1e-3, 3e-3)
        area = support_area(rows, CAM.support) if long else None
        alpha, lift = card_rows(rows, CAM, heights)
        assert (alpha.size < rows.shape[0] / 4) == long   # only around peak and events
        card = card_from_table(alpha, lift, heights, CAM, area=area)
        monkeypatch.undo()
        return res, form, card

    short, short_form, short_card = report(False)
    long, long_form, long_card = report(True)
    assert isinstance(long.table, np.memmap)
    tied = int(np.count_nonzero(np.diff(short.table[:, 0]) == 0))
    assert (tied > 3000) == grid, tied
    for key in ('samples_outliers_rejected', 'iterations'):
        assert long.values[key] == short.values[key]
    assert short.values['samples_outliers_rejected'] >= 3   # the spikes
    for key in ('angle_deg', 'angle_std_deg', 'sensitive_point_angle_deg', 'asymmetry_deg'):
        assert long.values[key] == pytest.approx(short.values[key], abs=1e-10)
    devs = short.values['per_revolution_deviation_arcsec']
    np.testing.assert_allclose(long.values['per_revolution_deviation_arcsec'], devs,
                               rtol=0, atol=1e-6)
    for group in ('lift_error_um', 'fit_residual_um'):
        for key in ('max_plus', 'max_minus', 'rms'):
            assert long.values[group][key] == pytest.approx(short.values[group][key],
                                                            abs=1e-9)
    for key in ('probe_noise_estimate_um', 'base_circle_runout_um', 'lift_offset_mm'):
        assert long.values[key] == pytest.approx(short.values[key], rel=1e-10)
    np.testing.assert_allclose(long.table, short.table, rtol=0, atol=1e-15)
    assert long_form['roundness_um'] == pytest.approx(short_form['roundness_um'], abs=1e-9)
    assert long_form['form_filter'] == short_form['form_filter']
    for got, want in zip(long_form['harmonics'][:5], short_form['harmonics'][:5]):
        assert got['upr'] == want['upr']
        assert got['amplitude_um'] == pytest.approx(want['amplitude_um'], abs=1e-9)
    assert long_card['max_lift_m'] == pytest.approx(short_card['max_lift_m'], abs=1e-15)
    assert long_card['area_m_rad'] == pytest.approx(short_card['area_m_rad'], rel=1e-12)
    for got, want in zip(long_card['heights'], short_card['heights']):
        assert got['opening_deg'] == pytest.approx(want['opening_deg'], abs=1e-10)
        assert got['closing_deg'] == pytest.approx(want['closing_deg'], abs=1e-10)


def test_verdict_of_a_long_table_equals_the_in_memory_one(monkeypatch) -> None:
    """``judge_lobe`` of a spilled lift table (lift-error band and zones by running
    extremes, max lift, duration and centreline from the rows around the design's peak
    and events) gives the checks of the in-memory table: the same names and statuses,
    values to 1e-9 of their unit."""
    from cam_metrology.metrology.tolerances import judge_lobe
    from cam_metrology.scene.model import Tolerances, ToleranceZone

    rng = np.random.default_rng(7)
    alpha = np.sort(rng.uniform(-np.pi, np.pi, 60_000))
    design = CAM(alpha, 0)
    measured = design + 3e-6 + 2e-6 * np.sin(3 * alpha) + rng.normal(0, 5e-7, alpha.size)
    table = np.column_stack([alpha, measured, design])
    tol = Tolerances(lift_error_um=(-6.0, 6.0), max_lift_um=(-5.0, 5.0),
                     duration_deg=(-1.0, 1.0), centreline_deg=(-0.5, 0.5),
                     lift_error_zones=(ToleranceZone(-20.0, 10.0, (-4.0, 4.0)),
                                       ToleranceZone(170.0, 175.0, (-1.0, 1.0))))
    feature = {'runout_fitted': True, 'status': 'ok'}
    want = judge_lobe(tol, feature, table, CAM)
    monkeypatch.setattr(spill, 'SPILL_BYTES', 1024)
    got = judge_lobe(tol, feature, spill.spill(table, min_bytes=1), CAM)
    assert len(want['checks']) == len(got['checks']) >= 8
    for g, w in zip(got['checks'], want['checks']):
        assert (g['quantity'], g['result']) == (w['quantity'], w['result'])
        assert g['value'] == pytest.approx(w['value'], abs=1e-9)
    assert got['not_checked'] == want['not_checked']


def test_derivative_errors_of_a_long_table_equal_the_in_memory_ones(monkeypatch) -> None:
    """The velocity and acceleration errors of a spilled lift table (its rows binned a
    block at a time: bins going on across blocks) equal the in-memory ones: maxima and
    rms to 1e-9 relative, the same angles of the maxima."""
    from cam_metrology.metrology.derivative_error import derivative_errors

    rng = np.random.default_rng(8)
    alpha = np.sort(rng.uniform(-np.pi, np.pi, 150_000))   # about 20 rows a 0.05 deg bin
    design = CAM(alpha, 0)
    bump = 4e-6 * np.exp(-((alpha + 0.5) / 0.15) ** 2)
    measured = design + bump + rng.normal(0, 2e-7, alpha.size)
    table = np.column_stack([alpha, measured, design])
    feature = {'runout_fitted': False}
    want = derivative_errors(table, feature, CAM)
    monkeypatch.setattr(spill, 'SPILL_BYTES', 1024)
    got = derivative_errors(spill.spill(table, min_bytes=1), feature, CAM)
    assert set(got) == set(want) and 'derivative_error' not in got
    for quantity, stats in want.items():
        for key in ('max_abs', 'rms'):
            assert got[quantity][key] == pytest.approx(stats[key], rel=1e-9)
        assert got[quantity]['at_deg'] == pytest.approx(stats['at_deg'], abs=1e-9)


def test_nose_lift_error_of_a_long_table_equals_the_in_memory_one(monkeypatch) -> None:
    """A track's mean lift error at the nose from a spilled table (a block of rows at a
    time) equals the in-memory mean to 1e-9 um."""
    from cam_metrology.metrology.tracks import nose_lift_error_um

    rng = np.random.default_rng(9)
    alpha = np.sort(rng.uniform(-np.pi, np.pi, 100_000))
    design = CAM(alpha, 0)
    measured = design + 2e-6 * np.cos(alpha) ** 8 + rng.normal(0, 3e-7, alpha.size)
    table = np.column_stack([alpha, measured, design])
    values = {'runout_fitted': True}
    want = nose_lift_error_um(table, values)
    monkeypatch.setattr(spill, 'SPILL_BYTES', 1024)
    got = nose_lift_error_um(spill.spill(table, min_bytes=1), values)
    assert want is not None and abs(want) > 0.5   # um: the error at the nose is there
    assert got == pytest.approx(want, abs=1e-9)
