"""Junction-aware reconstruction (docs/methods.md, "Junctions of h''") and the noise
judged from the rows: closed-form lobes whose h'' jumps at known angles
(``truth_lobes``), scipy's GCV smoothing spline as the reference to beat."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.interpolate import make_smoothing_spline

from cam_design.lift_table import hinges, junctions, partial_spline, smoother_band
from cam_design.lift_table.noise import flat_rows
from cam_design.lift_table.spline import SplineOptions, reconstruct_spline
from cam_design.lift_table.truth_lobes import DEG, families, measured_table

FAMILIES = {f.name: f for f in families()}
EVAL = 0.05 * DEG


def jump_at(law, t):
    """h''(t+) - h''(t-) [m/rad^2] of the truth."""
    return float((law(np.array([t + 1e-9]), 2) - law(np.array([t - 1e-9]), 2))[0])


def hinge_matrix(taus, n):
    """(n, 2J): each junction's hinges on n nodes, opening on its longer side."""
    x = np.arange(n, dtype=float)
    return np.column_stack([hinges.hinge_values(hinges.side_of(t, n) * (x - t),
                                                hinges.taper_nodes(n))
                            for t in taus])


def acc_errors(fam, a, h, **options):
    """RMS h'' error [m/rad^2] of ours and of scipy's GCV spline on a fine grid."""
    grid = np.arange(a[0], a[-1], EVAL)
    truth = fam.law(grid, 2)
    rec = reconstruct_spline(a, h, SplineOptions(**options))
    ours = float(np.sqrt(np.mean((rec.evaluate(grid, 2) - truth) ** 2)))
    ref = float(np.sqrt(np.mean((make_smoothing_spline(a, h)(grid, 2) - truth) ** 2)))
    return ours, ref, rec


def test_truth_lobes_jump_where_they_say():
    """The truth itself: h and h' continuous at every listed junction, h'' jumping
    there by more than 1e-3 m/rad^2, and the derivatives those of the lift."""
    for fam in FAMILIES.values():
        for t in fam.junctions:
            lo, hi = np.array([t - 1e-9]), np.array([t + 1e-9])
            assert abs((fam.law(hi) - fam.law(lo))[0]) < 1e-10
            assert abs((fam.law(hi, 1) - fam.law(lo, 1))[0]) < 1e-8
            assert abs(jump_at(fam.law, t)) > 1e-3
        a = np.linspace(-math.pi, math.pi, 40001)
        for nu in range(2):
            num = np.gradient(fam.law(a, nu), a)
            scale = float(np.max(np.abs(fam.law(a, nu + 1))))
            assert np.mean(np.isclose(num, fam.law(a, nu + 1), atol=1e-3 * scale)) > 0.999


def test_partial_spline_recovers_a_step_of_hpp_exactly():
    """Noise-free lift = cosine + a step c of h'' at a point between two nodes: the
    partial spline with the hinge there reproduces c (the smooth part takes the
    cosine, which its penalty barely sees)."""
    step = 0.5 * DEG
    a = -math.pi + step * np.arange(1, 721)
    t = 20.3 * DEG
    jump = 0.04                                               # m/rad^2
    h = 1e-3 * np.cos(a) + jump * 0.5 * np.clip(a - t, 0, None) ** 2
    tau = (t - a[0]) / step
    fit = partial_spline.partial_fit(h, [tau], 100.0)
    side = hinges.side_of(tau, a.size)          # the hinge opens on its longer side
    assert side * fit.coef[0] / step ** 2 == pytest.approx(jump, abs=1e-4)   # m/rad^2


@pytest.mark.parametrize('name, step_deg, sigma', [
    ('dwell', 1.0, 0.5e-6), ('constant acceleration', 0.5, 0.5e-6),
    ('circular arc', 2.5, 2e-6), ('circular arc', 0.5, 0.1e-6)])
def test_junctions_are_found_within_one_step(name, step_deg, sigma):
    """Every junction whose step of h'' is at least 0.01 m/rad^2 is found within one
    table step, with the sign of the step; nothing is found more than 10 steps from a
    junction of the law (a second step next to a junction can stand in for its
    third-derivative change on a fine, nearly noise-free table)."""
    fam = FAMILIES[name]
    step = step_deg * DEG
    a, h = measured_table(fam.law, step, sigma=sigma, seed=3)
    rec = reconstruct_spline(a, h)
    found = np.radians(rec.parameter['junctions_deg'])
    jumps = np.asarray(rec.parameter['acceleration_jumps_m_per_rad2'])
    for t in fam.junctions:
        true_jump = jump_at(fam.law, t)
        if abs(true_jump) < 0.01:
            continue
        k = int(np.argmin(np.abs(found - t)))
        assert abs(found[k] - t) <= step, (np.degrees(t), np.degrees(found))
        assert np.sign(jumps[k]) == np.sign(true_jump)
    for f in found:
        assert np.min(np.abs(np.asarray(fam.junctions) - f)) <= 10 * step


#: (family, step [deg], noise [m], rounding [m], spikes): a small fixed set of the
#: benchmark's cases (python -m benchmarks reconstruction_accuracy runs them all)
CASES = [('ramped C1', 0.5, 0.5e-6, 0.0, 0), ('C2', 1.0, 0.5e-6, 0.0, 0),
         ('dwell', 1.0, 2e-6, 0.0, 0), ('constant acceleration', 0.5, 0.5e-6, 0.0, 5),
         ('circular arc', 2.5, 0.1e-6, 1e-5, 0), ('circular arc', 1.0, 0.5e-6, 0.0, 0)]


def test_acceleration_error_beats_scipy_gcv():
    """h'' RMS error against scipy's make_smoothing_spline (GCV) on the same rows:
    at most 0.9 x on every case, 0.7 x as the median."""
    ratios = []
    for name, step_deg, sigma, quantum, spikes in CASES:
        fam = FAMILIES[name]
        a, h = measured_table(fam.law, step_deg * DEG, sigma=sigma, quantum=quantum,
                              outliers=spikes, seed=11)
        ours, ref, _ = acc_errors(fam, a, h)
        ratios.append(ours / ref)
        assert ours <= 0.9 * ref, (name, step_deg, ours, ref)
    assert float(np.median(ratios)) <= 0.7, ratios


@pytest.mark.parametrize('name', ['constant acceleration', 'circular arc', 'dwell'])
def test_exact_tables_are_still_interpolated(name):
    """A computed (noise-free) table at 0.5 deg: judged exact, every row reproduced
    to rounding level, no junction search (interpolation keeps the jumps between
    rows)."""
    fam = FAMILIES[name]
    a, h = measured_table(fam.law, 0.5 * DEG)
    rec = reconstruct_spline(a, h)
    assert rec.sigma < 1e-9
    assert float(np.max(np.abs(rec.residual))) < 1e-9
    assert 'junctions_deg' not in rec.parameter


def cycle_trace(sigma, seed=0):
    """A cycle-averaged valve-lift trace: 0.5 deg crank over 720 deg (cam angle =
    crank / 2), the ramped lobe plus noise ``sigma`` [m], and the seated valve read
    as exactly 0.000 (two thirds of the cycle)."""
    law = FAMILIES['ramped C1'].law
    cam = np.arange(0.0, 720.0, 0.5) / 2 * DEG - math.pi
    truth = law(cam)
    rng = np.random.default_rng(seed)
    lift = truth + rng.normal(0.0, sigma, cam.size)
    lift[truth <= 0] = 0.0
    return cam, lift, law


def test_sensor_trace_is_judged_noisy():
    """20 um of scatter on the lobe is seen (sigma within 1.5 x), not hidden by the
    seated rows' exact zeros, and the acceleration stays that of the lobe (within
    25 % of the true peak), not the noise's."""
    cam, lift, law = cycle_trace(20e-6)
    rec = reconstruct_spline(cam, lift)
    assert 20e-6 / 1.5 < rec.sigma < 1.5 * 20e-6
    peak = float(np.max(np.abs(law(cam, 2))))
    assert float(np.max(np.abs(rec.acceleration))) < 1.25 * peak


@pytest.mark.parametrize('kind', ['noisy', 'rounded', 'seated trace'])
def test_noise_of_the_rows_without_fairing_them(kind):
    """rebound_noise (the halves of the scatter estimate need only the noise) gives the
    sigma [m] the fairing estimates, within 1e-12 relative: a noisy lobe with spikes,
    one rounded to 0.01 mm, and a trace with exactly flat seated rows."""
    from cam_design.lift_table.rebound import rebound_fairing, rebound_noise

    if kind == 'seated trace':
        a, h, _ = cycle_trace(20e-6)
    else:
        fam = FAMILIES['dwell']
        a, h = measured_table(fam.law, 0.5 * DEG, sigma=0.5e-6, outliers=5, seed=2,
                              quantum=1e-5 if kind == 'rounded' else 0.0)
    sigma = rebound_noise(a, h)
    assert sigma == pytest.approx(rebound_fairing(a, h).sigma, rel=1e-12, abs=0.0)
    assert sigma > 0.0


def test_hinges_on_a_grid_equal_the_hinges_at_scattered_points():
    """JunctionFit.hinge_part on an ascending grid (each hinge's points a slice) equals
    its values at the same points shuffled (found point by point), and both equal the
    sum over the junctions of their hinge values times their coefficients, for h..h'''
    (within 1e-12 of the largest value)."""
    fam = FAMILIES['circular arc']
    a, h = measured_table(fam.law, 0.5 * DEG, sigma=0.5e-6, seed=1)
    found = junctions.find_junctions(a, h, 10.0)
    assert found is not None and len(found.angles) >= 2
    x = np.linspace(a[0], a[-1], 4001)
    order = np.random.default_rng(0).permutation(x.size)
    length = hinges.taper_nodes(found.nodes)
    for nu in range(4):
        on_grid = found.hinge_part(x, nu)
        scattered = np.empty_like(x)
        scattered[order] = found.hinge_part(x[order], nu)
        direct = np.zeros_like(x)
        u = (x - found.x0) / found.step
        for k, t in enumerate(found.angles):
            tau = (t - found.x0) / found.step
            side = hinges.side_of(tau, found.nodes)
            vals = hinges.hinge_values(side * (u - tau), length, nu)
            direct += vals @ found.coef[2 * k:2 * k + 2] * float(side) ** nu
        direct /= found.step ** nu
        scale = float(np.max(np.abs(direct)))
        assert np.max(np.abs(on_grid - scattered)) <= 1e-12 * scale
        assert np.max(np.abs(on_grid - direct)) <= 1e-12 * scale


def test_flat_rows_are_runs_of_equal_values():
    y = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 2.0, 2.0, 2.0, 2.0, 3.0])
    assert flat_rows(y).tolist() == [True, True, True, False, False, False, False,
                                     False, True, False, False, False]


def test_partial_fit_solves_the_penalised_least_squares_problem():
    """The banded partial spline (smoother's factor, hinge columns as a low-rank
    addition) against the dense normal equations of min |y - f - G c|^2 + lam |D3 f|^2
    on 80 nodes: the same hinge coefficients and fitted values."""
    rng = np.random.default_rng(5)
    n, lam = 80, 30.0
    x = np.arange(n, dtype=float)
    y = 1e-3 * np.sin(x / 9.0) + 1e-6 * rng.normal(size=n)
    taus = [23.4, 61.7]
    fit = partial_spline.LevelSystem(y, lam).fit(taus)
    g = hinge_matrix(taus, n)
    d3 = np.diff(np.eye(n), 3, axis=0)
    k = g.shape[1]
    a = np.block([[np.eye(n) + lam * d3.T @ d3, g], [g.T, g.T @ g]])
    sol = np.linalg.solve(a, np.concatenate([y, g.T @ y]))
    assert np.allclose(fit.coef, sol[n:n + k], rtol=1e-6, atol=1e-12)
    fitted = fit.smooth + g @ fit.coef
    assert np.max(np.abs(fitted - (sol[:n] + g @ sol[n:]))) < 1e-12      # m


def test_fit_scalars_from_kept_products_equal_the_dense_problem():
    """The search scores a set of junctions from kept 2 x 2 inner products, without
    forming the fit: its residual sum of squares, penalised residual and the hinges'
    share of the hat-matrix trace against the dense partial spline on 80 nodes
    (H = S + R G (G'R G)^-1 G'R, so tr H - tr S is the hinges' share)."""
    rng = np.random.default_rng(6)
    n, lam = 80, 30.0
    x = np.arange(n, dtype=float)
    y = 1e-3 * np.sin(x / 9.0) + 1e-6 * rng.normal(size=n)
    taus = [23.4, 61.7, 40.25]
    system = partial_spline.LevelSystem(y, lam)
    score = system.score(taus)
    g = hinge_matrix(taus, n)
    d3 = np.diff(np.eye(n), 3, axis=0)
    smoother = np.linalg.inv(np.eye(n) + lam * d3.T @ d3)
    r = np.eye(n) - smoother
    coef = np.linalg.solve(g.T @ r @ g, g.T @ r @ y)
    f = smoother @ (y - g @ coef)
    hat = smoother + r @ g @ np.linalg.solve(g.T @ r @ g, g.T @ r)
    rss = float(np.sum((y - f - g @ coef) ** 2))
    penalised = rss + lam * float(np.sum((d3 @ f) ** 2))
    assert score.rss == pytest.approx(rss, rel=1e-7)                     # m^2
    assert score.objective == pytest.approx(penalised, rel=1e-7)         # m^2
    assert score.edf - system.trace == pytest.approx(np.trace(hat) - np.trace(smoother),
                                                     abs=1e-6)
    # one more junction added to a kept set gives the same as the set built at once
    grown = partial_spline.LevelSystem(y, lam)
    grown.score(taus[:2])
    assert grown.score(taus).rss == pytest.approx(score.rss, rel=1e-9)


def test_kept_hinge_penalty_is_the_third_differences_of_the_hinges():
    """P g of a junction's hinges on its own rows is kept per place and scaled by the
    level: equal to lam D3'D3 g formed afresh from hinge_values (within 1e-12 of its
    largest value) for junctions opening either way, and the same array again when the
    same place is asked for at another level (the search's levels share it)."""
    n = 3600
    length = hinges.taper_nodes(n)
    for tau in (900.37, 2500.81):
        side = hinges.side_of(tau, n)
        a, b = partial_spline._hinge_support(n, tau, 0, n)
        x = np.arange(n, dtype=float)
        g = hinges.hinge_values(side * (x - tau), length)[a:b]
        d3 = np.diff(g, 3, axis=0)
        for lam in (1e3, 1e7):
            direct = lam * np.column_stack([np.convolve(d3[:, k], [-1.0, 3.0, -3.0, 1.0])
                                            for k in range(2)])
            kept = lam * partial_spline._hinge_penalty(n, tau, a, b)
            assert np.max(np.abs(kept - direct)) <= 1e-12 * np.max(np.abs(direct))
        assert partial_spline._hinge_penalty(n, tau, a, b) is \
            partial_spline._hinge_penalty(n, tau, a, b)


def test_levels_on_the_lattice_are_the_level_searches_own():
    """Levels.on_lattice: a level on the search's half-decade lattice (within 1e-12
    decades of anchor + k LEVEL_STEP), within half a step of the level asked for, and
    the very level (the same system) the level search builds there."""
    fam = FAMILIES['dwell']
    a, h = measured_table(fam.law, 0.5 * DEG, sigma=0.5e-6, seed=1)
    levels = junctions.Levels(h)
    assert levels.on_lattice(123.0) == 123.0            # no lattice yet
    junctions.choose_level(h, [300.4], 1.4, 10 ** 3.3, levels)
    step = junctions.LEVEL_STEP
    for lam in (10 ** 2.1, 10 ** 3.3, 10 ** 4.74, 10 ** 6.0):
        snapped = levels.on_lattice(lam)
        k = (math.log10(snapped) - levels.anchor) / step
        assert abs(k - round(k)) < 1e-12 / step
        assert abs(math.log10(snapped) - math.log10(lam)) <= 0.5 * step + 1e-12
    built = [lam for lam in levels._systems if abs(math.log10(lam) - 3.3) > 1e-9]
    assert built and all(levels.on_lattice(lam) == lam for lam in built)


@pytest.mark.parametrize('lam', [1e2, 1e4, 1e6, 1e8])
def test_windowed_hinge_columns_equal_whole_table_solves(lam):
    """A hinge's column R g is solved on a window (the level's Toeplitz interior, or a
    block reaching one end of the table) and is zero outside it: against the
    whole-table banded solve at 3600 rows, near either end and inside, within 1e-7 of
    its peak (measured 2e-8 at lam 1e8, where an 80-bit reference puts the rounding of
    either solve at 2e-8, and below 1e-9 at lower levels)."""
    n = 3600
    system = partial_spline.LevelSystem(np.zeros(n), lam)
    for tau in (40.3, 500.25, 1700.5, 1900.75, 3100.1, 3560.6):
        g, rg = system.columns([tau])
        whole = partial_spline.residual_operator(np.array(g), lam)
        peak = np.max(np.abs(whole), axis=0)
        assert np.all(np.max(np.abs(rg - whole), axis=0) <= 1e-7 * peak), tau


@pytest.mark.parametrize('lam', [1e3, 1e6, 1e8])
def test_batched_windowed_columns_equal_one_solve_each(lam):
    """The columns of several junctions solved at once (one banded solve for all
    those on the level's interior block, the ends each alone) against each junction's
    own windowed solve: equal within 1e-14 of the column's peak (LAPACK treats each
    right-hand side alone; measured equal to the last digit). The windowed solve
    against the whole-table one: the test above."""
    n = 3600
    system = partial_spline.LevelSystem(np.zeros(n), lam)
    taus = (40.3, 500.25, 1700.5, 1900.75, 2500.4, 3560.6)
    places = [(*system.window(t), t) for t in taus]
    assert sum(0 < lo and hi < n for lo, hi, _ in places) >= 2     # a batch
    batch = partial_spline.windowed_residuals(n, lam, places)
    for place, got in zip(places, batch):
        alone, = partial_spline.windowed_residuals(n, lam, [place])
        peak = np.max(np.abs(alone), axis=0)
        assert got.shape == alone.shape == (place[1] - place[0], 2)
        assert np.all(np.max(np.abs(got - alone), axis=0) <= 1e-14 * peak), place
    # a level's system solves the columns it is asked for together, the same columns;
    # the hinges G (kept across levels) are each junction's own, opening on its longer
    # side
    g, rg = system.columns(list(taus))
    rows = np.arange(n, dtype=float)
    length = hinges.taper_nodes(n)
    for k, (lo, hi, t) in enumerate(places):
        own = hinges.hinge_values(hinges.side_of(t, n) * (rows - t), length)
        assert np.max(np.abs(g[:, 2 * k:2 * k + 2] - own)) <= 1e-12 * np.max(np.abs(own))
        alone, = partial_spline.windowed_residuals(n, lam, [(lo, hi, t)])
        assert np.max(np.abs(rg[lo:hi, 2 * k:2 * k + 2] - alone)) <= 1e-14 * np.max(
            np.abs(alone))
        assert not np.any(rg[:lo, 2 * k:2 * k + 2]) and not np.any(rg[hi:, 2 * k:2 * k + 2])


@pytest.mark.parametrize('n', [7, 1100, 3600])
def test_quadratics_basis_is_orthonormal_and_spans_the_quadratics(n):
    """The deflation's basis of the quadratics (LAPACK's QR called directly): Q'Q = I
    within 1e-14, 1, x and x^2 on linspace(-1, 1, n) reproduced from it within 1e-13
    (unit-sized values), the same Q as numpy's linalg.qr within 1e-15; a deflated
    vector is orthogonal to the quadratics within 1e-13 of its norm."""
    q = smoother_band.quadratics(n)
    assert np.max(np.abs(q.T @ q - np.eye(3))) < 1e-14
    x = np.linspace(-1.0, 1.0, n)
    a = np.column_stack([np.ones(n), x, x * x])
    assert np.max(np.abs(q @ (q.T @ a) - a)) < 1e-13
    assert np.max(np.abs(q - np.linalg.qr(a)[0])) < 1e-15
    r = np.random.default_rng(3).normal(size=(n, 2)) + a[:, 1:]
    assert np.max(np.abs(a.T @ smoother_band.deflate(r))) < 1e-13 * np.linalg.norm(r)


@pytest.mark.parametrize('lam', [10.0 ** 2.5, 10.0 ** 4.3, 10.0 ** 7.1])
def test_kept_interior_grams_equal_their_own_solves(lam):
    """A level's interior hinge Grams G'R G and G'R^2 G, kept per level (one Chebyshev
    fit in a right-opening junction's place, its mirror image for a left-opening one;
    the scan and the refinement read them) against the solve of the single place, at
    odd places between rows: within 1e-7 of the block's largest entry [node units] (7
    nodes reach 3e-9 .. 7e-8 relative at these levels); and the hinges of many places formed in one
    pass (``hinge_block``) equal to each place's own ``hinge_values`` within 1e-15 of
    the largest value."""
    length = hinges.taper_nodes(3600)
    for side in (1, -1):
        for frac in (0.0, 0.13, 0.5, 0.77, 0.999):
            (m1, v1), = partial_spline.interior_hinge_grams(lam, length, (side * frac,))
            m, v = partial_spline.interior_grams(lam, length, side, frac)
            assert np.max(np.abs(m - m1)) <= 1e-7 * np.max(np.abs(m1)), (side, frac)
            assert np.max(np.abs(v - v1)) <= 1e-7 * np.max(np.abs(v1)), (side, frac)
    u = np.arange(400.0)[:, None] - np.array([3.0, 10.25, 150.5, -2.0])[None, :]
    block = hinges.hinge_block(u, length)
    for j in range(u.shape[1]):
        one = hinges.hinge_values(u[:, j], length)
        assert np.max(np.abs(block[:, 2 * j:2 * j + 2] - one)) <= 1e-15 * np.max(np.abs(one))


def test_refit_without_changes_is_the_search_fit():
    """refit with the search's own values, level and no missing node hands back the
    search's last fit: the same as a fit made afresh at its junctions (fitted lift
    within 1e-12 m, steps of h'' within 1e-7 relative)."""
    fam = FAMILIES['circular arc']
    a, h = measured_table(fam.law, 0.5 * DEG, sigma=0.5e-6, seed=1)
    grid = a - a[0]
    found = junctions.find_junctions(grid, h, 10.0)
    assert found is not None
    same = junctions.refit(grid, h, np.zeros(h.size, dtype=bool), found, found.lam_d)
    fresh = junctions.refit(grid, h.copy(), np.zeros(h.size, dtype=bool),
                            dataclasses.replace(found, fitted_on=None), found.lam_d)
    assert same is found
    # the smooth part and the hinges' long quadratic tails nearly cancel: compare
    # their sum, the fitted lift
    fitted = same.smooth + same.hinge_part(grid)
    assert np.max(np.abs(fitted - fresh.smooth - fresh.hinge_part(grid))) < 1e-12   # m
    assert np.allclose(same.jumps, fresh.jumps, rtol=1e-7, atol=0.0)


def test_scan_statistic_equals_direct_inner_products():
    """The FFT scan's T at interior positions (both opening sides) against the
    efficient score computed from the full hinge columns of the same level:
    T = (w'b)^2 / (sigma^2 w'Vw), b = G'e, w = (1, -M01/M11), M = G'RG, V = (RG)'RG."""
    rng = np.random.default_rng(8)
    n, lam, sigma = 600, 200.0, 2e-6
    resid = sigma * rng.normal(size=n)
    pos, stat = junctions.scan(resid, lam, sigma, margin=3)
    system = partial_spline.LevelSystem(np.zeros(n), lam)
    for tau in (150.25, 201.5, 420.75, 455.0):
        g, rg = system.columns([tau])
        m, v, b = g.T @ rg, rg.T @ rg, g.T @ resid
        w = np.array([1.0, -m[0, 1] / m[1, 1]])
        direct = float((w @ b) ** 2 / (sigma ** 2 * (w @ v @ w)))
        k = int(np.argmin(np.abs(pos - tau)))
        assert pos[k] == pytest.approx(tau, abs=1e-9)
        assert stat[k] == pytest.approx(direct, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize('step_deg', [0.2, 1.0])
def test_no_junction_on_a_smooth_lobe(step_deg):
    """A C2 lobe (h'' continuous everywhere, only h''' jumps at its ends) with 0.5 um
    of noise: the scan's large statistics there are smoothing bias, refused (most by
    the pre-test), and the fit is the plain smoother's."""
    fam = FAMILIES['C2']
    a, h = measured_table(fam.law, step_deg * DEG, sigma=0.5e-6, seed=2)
    rec = reconstruct_spline(a, h)
    assert 'junctions_deg' not in rec.parameter


@pytest.mark.parametrize('name', ['dwell', 'constant acceleration', 'circular arc'])
def test_reused_level_systems_give_the_plain_search_result(name, monkeypatch):
    """The search reuses a level's system (factor, R y, hinge columns, recent fits)
    when it comes back to that level. The benchmark's 3600-row tables (0.5 um, seed 7)
    give the same junctions and the same lobe law (lift [m], h'' [m/rad^2] within 1e-9)
    as the plain search, which builds every system afresh and fits every time."""
    from cam_design.lift_table.lobe_table import lobe_law

    a, h = measured_table(FAMILIES[name].law, 2 * math.pi / 3600, sigma=0.5e-6, seed=7)
    x = np.linspace(-math.pi, math.pi, 7201)
    fast = lobe_law(a, h, key='t')
    with monkeypatch.context() as m:
        m.setattr(junctions.Levels, 'at',
                  lambda self, lam: partial_spline.LevelSystem(self.values, lam))
        m.setattr(junctions.LevelSystem, 'fit', junctions.LevelSystem._fit)
        plain = lobe_law(a, h, key='t')
    found = fast.lobe.rec.parameter['junctions_deg']
    assert len(found) == 4
    assert found == pytest.approx(plain.lobe.rec.parameter['junctions_deg'], abs=1e-9)
    assert np.max(np.abs(fast(x, 0) - plain(x, 0))) <= 1e-9
    assert np.max(np.abs(fast(x, 2) - plain(x, 2))) <= 1e-9


def test_search_is_not_moved_by_rounding_of_the_start_level():
    """The junctions found do not depend on the last digits of the start level: the
    constant-acceleration table (3600 rows, 0.5 um, seed 7) with the GCV level moved by
    +-1e-14 .. +-1e-12 (relative) gives the same 4 junctions at the same angles (within
    0.01 step). (With the hinge coefficients' right-hand side formed as G'(R y) it gave 5
    at +1e-14 and +1e-12.)"""
    from cam_design.lift_table import spline

    a, h = measured_table(FAMILIES['constant acceleration'].law, 2 * math.pi / 3600,
                          sigma=0.5e-6, seed=7)
    calls = []
    search = junctions.find_junctions

    def spy(grid, values, lam0, **kw):
        calls.append((grid, values, lam0, kw))
        return search(grid, values, lam0, **kw)

    original = spline.find_junctions
    spline.find_junctions = spy
    try:
        reconstruct_spline(a, h, SplineOptions())
    finally:
        spline.find_junctions = original
    grid, values, lam0, kw = calls[0]
    step = float(grid[1] - grid[0])
    ref = search(grid, values, lam0, **kw)
    assert ref is not None and len(ref.angles) == 4
    for eps in (1e-14, -1e-14, 1e-13, -1e-13, 1e-12, -1e-12):
        moved = search(grid, values, lam0 * (1.0 + eps), **kw)
        assert moved is not None and len(moved.angles) == 4
        assert np.max(np.abs(np.subtract(moved.angles, ref.angles))) <= 0.01 * step


@pytest.mark.parametrize('step_deg, ratio', [(0.5, 0.75), (1.0, 0.6)])
def test_rounded_dwell_edges_are_found_together(step_deg, ratio):
    """A dwell cam tabulated at 0.5 and 1 deg, 0.1 um of noise, rounded to 0.01 mm:
    each dwell edge alone lowers N ln(GCV) by only 7-10 (the level of the rest cannot
    rise while the other three steps of h'' are unexplained), all four together by
    about 80. The look-ahead finds all four within one step, with the sign of the
    truth's step, and h'' comes out well below scipy's GCV error (measured 0.56-0.66 x
    at 0.5 deg, 0.39-0.44 x at 1 deg; without the junctions 1.0 and 0.95 x) and below
    1.3 mm/rad^2 against the closed form (peak h'' 26 mm/rad^2)."""
    fam = FAMILIES['dwell']
    step = step_deg * DEG
    a, h = measured_table(fam.law, step, sigma=0.1e-6, quantum=1e-5, seed=5)
    ours, ref, rec = acc_errors(fam, a, h)
    found = np.radians(rec.parameter.get('junctions_deg', []))
    jumps = np.asarray(rec.parameter.get('acceleration_jumps_m_per_rad2', []))
    assert found.size == 4
    for t in fam.junctions:
        k = int(np.argmin(np.abs(found - t)))
        assert abs(found[k] - t) <= step
        assert np.sign(jumps[k]) == np.sign(jump_at(fam.law, t))
    assert ours < ratio * ref
    assert ours < 1.3e-3                                                 # m/rad^2
    assert not rec.warnings
    # each edge judged alone (the search without its look-ahead): none is taken
    from cam_design.lift_table.spline import GCV_GAMMA, choose_smoothing
    floor = 1e-5 / math.sqrt(12.0)
    start = choose_smoothing(h, step, criterion='gcv', gamma=GCV_GAMMA, sigma_floor=floor)
    assert junctions.find_junctions(a, h, start.lam_d, gamma=GCV_GAMMA, sigma_floor=floor,
                                    lookahead=False) is None
    assert len(junctions.find_junctions(a, h, start.lam_d, gamma=GCV_GAMMA,
                                        sigma_floor=floor).angles) == 4


def test_lookahead_does_not_take_false_pairs(monkeypatch):
    """A C2 lobe (no junction) at 2.5 deg with 0.1 um of noise and 5 spikes, searched
    with the look-ahead (the reconstruction's own coarse path above 2.25 deg runs it
    without): two candidates near a spike each miss the bar of 12 alone (N ln GCV
    lower by 6.6 and 4.4) and pass it together (36 for two), but the rest's level
    would rise only 1.4 times (its GCV already climbs between sqrt(10) and 10 times
    the level), where the four edges of a dwell raise it 70-90 times: no junction is
    taken. Without the level test both are, at -27.6 and -23.1 deg. The rows are those
    a fairing that confirms spikes one at a time leaves: the lone spike (row 51)
    replaced by its leave-one-out value, the four at -32.5, -30, -22.5 and -20 deg
    kept (the fairing now takes them out as a group: test_reconstruction_spikes)."""
    from cam_design.lift_table.rebound import ReboundOperator
    from cam_design.lift_table.spline import GCV_GAMMA, choose_smoothing

    fam = FAMILIES['C2']
    a, h = measured_table(fam.law, 2.5 * DEG, sigma=0.1e-6, outliers=5, seed=3)
    rows = h.copy()
    rows[51] += ReboundOperator(a).rebound(h)[51]
    start = choose_smoothing(rows, 2.5 * DEG, criterion='gcv', gamma=GCV_GAMMA)
    assert junctions.find_junctions(a, rows, start.lam_d, gamma=GCV_GAMMA) is None
    monkeypatch.setattr(junctions, 'LOOKAHEAD_LEVEL_RISE', 1.0)
    taken = junctions.find_junctions(a, rows, start.lam_d, gamma=GCV_GAMMA)
    assert taken is not None
    assert np.degrees(taken.angles) == pytest.approx([-27.6, -23.1], abs=0.1)


def _moving_junction_table(n=600):
    """A lobe-like row set with a step of h'' at node 260.3 and 0.2 um of noise [m]."""
    rng = np.random.default_rng(11)
    x = np.arange(n, dtype=float)
    y = 4e-3 * np.exp(-((x - 300.0) / 120.0) ** 2) + 1e-6 * rng.normal(size=n) * 0.2
    return y + 5e-8 * np.maximum(x - 260.3, 0.0) ** 2


@pytest.mark.parametrize('fixed', [[], [150.6], [150.6, 420.3]])
def test_moved_junction_objective_equals_the_dense_problem(fixed):
    """The angle refinement's shortcut (``LevelSystem.moved_objective``: one junction
    added from the fit of the others, its interior G'R G interpolated in its place
    between rows) against the dense penalised residual min_c (y - G c)'R (y - G c),
    R = (I + lam P)^-1 lam P, P = D3'D3, on 600 nodes, for right- and left-opening junctions
    at quarter and odd places: what the junction lowers it by [m^2] within 1e-6 of the
    objective (the dense problem's own rounding is a few 1e-7 of it), and the objective
    equal to the windowed columns' exact score within 1e-6 of that drop."""
    n, lam = 600, 30.0
    y = _moving_junction_table(n)
    system = partial_spline.LevelSystem(y, lam)
    d3 = np.diff(np.eye(n), 3, axis=0)
    p = lam * d3.T @ d3
    r = np.linalg.solve(np.eye(n) + p, p)     # I - S, without the cancellation of I - S

    def dense(taus):
        if not taus:
            return float(y @ r @ y)
        g = hinge_matrix(taus, n)
        c = np.linalg.solve(g.T @ r @ g, g.T @ r @ y)
        return float(y @ r @ y - (g.T @ r @ y) @ c)

    base, kept = dense(fixed), system.score(fixed).objective
    for tau in (258.0, 259.25, 260.3, 261.77, 262.5, 470.13, 471.5):
        assert system.interior(tau)
        fast = system.moved_objective(fixed, tau)
        drop = base - dense(fixed + [tau])
        assert drop > 0.0
        # the dense objective carries a few 1e-7 of its size in rounding (the drop
        # is 1e-5 .. 1e-3 of it)
        assert abs((kept - fast) - drop) <= 1e-6 * base                            # m^2
        assert abs(fast - system.score(fixed + [tau]).objective) <= 1e-6 * drop    # m^2
    assert not system.interior(20.5) and not system.interior(n - 20.5)


def test_refinement_with_the_shortcut_lands_where_exact_scores_do():
    """The refined junction angle with ``moved_objective`` against golden section on the
    exact windowed scores: within 0.01 node, from starts a quarter to 0.75 node off."""
    y = _moving_junction_table()
    system = partial_spline.LevelSystem(y, 30.0)
    for start in (259.75, 260.0, 260.5, 261.0):
        fast = junctions._refine(system, [150.6, start])[-1]
        exact = junctions.golden_minimum(
            lambda t: system.score([150.6, t]).objective, start - 1.0, start + 1.0,
            junctions.REFINE_ITERATIONS)
        assert fast == pytest.approx(exact, abs=0.01)
        assert fast == pytest.approx(260.3, abs=0.1)


@pytest.mark.parametrize('width', [0.0, 0.5, 0.85, 2.0])
def test_ramp_hinge_is_a_linear_change_of_h2_over_its_width(width):
    """ramp_hinge: its second derivative is 0 before the ramp, rises linearly to 1 over
    ``width`` nodes centred on 0 and stays 1 (a step at 0 for width 0); each derivative
    is the slope of the one below (central differences, 1e-4 node: within 1e-6, away
    from the ramp's ends); beyond the ramp the value is the step's u^2 / 2 + w^2 / 24."""
    u = np.linspace(-3.0, 3.0, 6001) + 1e-3 / 3.0
    h2 = hinges.ramp_hinge(u, width, 2)
    expect = np.clip(u / width + 0.5, 0.0, 1.0) if width > 0.0 else (u > 0.0).astype(float)
    assert np.max(np.abs(h2 - expect)) < 1e-12
    d = 1e-4
    clear = np.min(np.abs(u[:, None] - np.array([-0.5 * width, 0.5 * width])), axis=1) > 2 * d
    for nu in (0, 1):
        slope = (hinges.ramp_hinge(u + d, width, nu)
                 - hinges.ramp_hinge(u - d, width, nu)) / (2.0 * d)
        assert np.max(np.abs(slope - hinges.ramp_hinge(u, width, nu + 1))[clear]) < 1e-6
    beyond = u > 0.5 * width + 1e-9
    assert np.max(np.abs(hinges.ramp_hinge(u[beyond], width)
                         - (0.5 * u[beyond] ** 2 + width ** 2 / 24.0))) < 1e-12


def test_ramp_fit_of_width_zero_is_the_partial_spline_and_a_ramp_is_recovered():
    """ramp_fit with widths 0 is partial_fit (fitted lift within 1e-12 m, coefficients
    within 1e-9 relative). On exact rows of a quadratic plus a change of h'' by
    2e-6 m/node^2 over 0.85 node at node 30.4, the ramp fit at that width recovers
    the change within 1e-3 relative and, as a JunctionFit, evaluates h'' within 1e-6 of
    the change of the truth between the rows."""
    fam = FAMILIES['dwell']
    _, h = measured_table(fam.law, 5 * DEG, sigma=0.1e-6, seed=1)
    taus = [10.3, 30.7, 50.2]
    plain = partial_spline.partial_fit(h, taus, 1e3)
    ramp = junctions.ramp_fit(h, taus, [0.0] * 3, 1e3)
    assert np.max(np.abs(plain.smooth - ramp.smooth)) < 1e-12
    assert np.allclose(plain.coef, ramp.coef, rtol=1e-9, atol=0.0)
    n, tau, width, jump = 72, 30.4, 0.85, 2e-6
    x = np.arange(n, dtype=float)
    values = 1e-7 * (x - 36.0) ** 2 + jump * hinges.ramp_hinge(x - tau, width)
    fit = junctions.ramp_fit(values, [tau], [width], 1e2)
    assert abs(fit.coef[0] - jump) <= 1e-3 * jump
    found = junctions.JunctionFit((tau,), (float(fit.coef[0]),), 1e2, fit.smooth, fit.edf,
                                  (0.0,), 1.0, 0.0, n, fit.coef, widths=(width,))
    fine = np.linspace(27.0, 34.0, 701)
    smooth2 = np.interp(fine, x, np.gradient(np.gradient(fit.smooth, x), x))
    h2 = smooth2 + found.hinge_part(fine, 2)
    truth = 2e-7 + jump * hinges.ramp_hinge(fine - tau, width, 2)
    assert np.max(np.abs(h2 - truth)) < 1e-6 * jump
