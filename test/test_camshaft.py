"""The camshaft in the dynamics: torsional shaft, drive, friction and the coupled run
against closed forms, an independent scipy integration, the energy balance and the
rigid-shaft limit; bad input of the ``camshaft:`` block."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cam_design.camshaft.coupled import LobeOnShaft, run_camshaft
from cam_design.camshaft.piecewise_fourier import coefficients, integral, kernel_coefficients
from cam_design.camshaft.friction import (flat_friction_torque, mixed_coefficient,
                                          roller_lever)
from cam_design.camshaft.spec import FlatFriction, camshaft_from_mapping
from cam_design.camshaft.torsion import assemble, natural_frequencies, respond
from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.train.run import TrainSpec, run_train
from cam_design.valve_train import SdofParams
from cam_design.valve_train.params import omega_of_rpm
from test_valve_train_sdof import BASE, ramp_law

G, RHO = 8.0e10, 7850.0
L_SEC, D_SEC, J_LOBE = 0.1, 0.03, 5.0e-5


def one_lobe_block(**extra: object) -> dict:
    return {'stations': ['sprocket', 'lobe_1'],
            'sections': [{'length': L_SEC, 'diameter': D_SEC}],
            'lobe_inertia': J_LOBE, 'damping_ratio': 0.05, **extra}


def shaft_constants() -> tuple[float, float]:
    """(k [N m/rad], J [kg m^2]) of the one-lobe shaft, from the bar formulas."""
    jp = math.pi * D_SEC ** 4 / 32
    return G * jp / L_SEC, J_LOBE + 0.5 * RHO * jp * L_SEC


def test_single_oscillator_closed_form_amplitude_and_phase() -> None:
    """psi = -T0 cos(n a - phi) / sqrt((k - J w^2)^2 + (c w)^2), tan phi = c w/(k - J w^2)
    for T = T0 cos(n a) at the lobe (held sprocket, c = 2 zeta/w1 k)."""
    k, J = shaft_constants()
    shaft = assemble(camshaft_from_mapping(one_lobe_block(), ['lobe_1']))
    w1 = math.sqrt(k / J)
    assert natural_frequencies(shaft)[0] == pytest.approx(w1 / (2 * math.pi), rel=1e-12)
    c = 2 * 0.05 / w1 * k
    N, T0, rpm = 720, 3.0, 2400.0
    omega = omega_of_rpm(rpm)
    a = np.arange(N) * 2 * math.pi / N
    for n in (1, 7, 23, 40):
        loads = np.zeros((2, N))
        loads[1] = T0 * np.cos(n * a)
        res = respond(shaft, loads, omega)
        w = n * omega
        amp = T0 / math.hypot(k - J * w * w, c * w)
        phi = math.atan2(c * w, k - J * w * w)
        expect = -amp * np.cos(n * a - phi)
        assert np.max(np.abs(res.psi[1] - expect)) < 1e-12 * amp + 1e-18
        # the held sprocket's reaction: k psi + c psi_dot (the section's torque)
        drive = -(k * res.psi[1] + c * omega * res.dpsi[1])
        assert np.max(np.abs(res.drive - drive)) < 1e-9 * T0


class OffsetEccentric(LiftLaw):
    """h = h0 + e cos(alpha) over the whole revolution: a valve held off its seat, in
    contact everywhere (smooth, band-limited loads)."""

    continuity_order = 3

    def __init__(self, h0: float, e: float) -> None:
        self.h0, self.e = h0, e
        self.breaks = np.array([-math.pi, math.pi])
        self.pieces = None

    @property
    def support(self) -> tuple[float, float]:
        return (-math.pi, math.pi)

    def _evaluate(self, alpha: np.ndarray, nu: int) -> np.ndarray:
        return (self.h0 * (nu == 0)
                + self.e * np.cos(alpha + nu * math.pi / 2))

    def jets(self, theta: float) -> tuple[float, float]:
        return self.h0 + self.e * math.cos(theta), -self.e * math.sin(theta)


def _fast_law(law):
    """(h, h') of a PiecewisePolynomialLaw by scalar Horner (the integrator's hot path),
    periodic over the revolution, 0 off the lobe."""
    import bisect

    breaks = [float(x) for x in law.breaks]
    coefs = [[list(reversed(piece[nu].convert().coef.tolist())) for nu in (0, 1)]
             for piece in law.pieces]
    lo, hi = breaks[0], breaks[-1]

    def jets(theta: float) -> tuple[float, float]:
        t = lo + (theta - lo) % (2 * math.pi)
        if t > hi:
            return 0.0, 0.0
        i = min(max(bisect.bisect_right(breaks, t) - 1, 0), len(coefs) - 1)
        out = []
        for c in coefs[i]:
            val = 0.0
            for x in c:
                val = val * t + x
            out.append(val)
        return out[0], out[1]

    return jets


def _reference_twist(law, p: SdofParams, rpm: float, N: int, revs: int = 4):
    """Independent integration (LSODA, tight tolerances) of the shaft + SDOF train as
    one ODE: valve lift y, velocity, twist psi and its rate; the last revolution on the
    N-point grid."""
    k, J = shaft_constants()
    c = 2 * 0.05 / math.sqrt(k / J) * k
    omega = omega_of_rpm(rpm)
    jets = law.jets if isinstance(law, OffsetEccentric) else _fast_law(law)

    def rhs(t: float, z: np.ndarray) -> list[float]:
        y, v, psi, dpsi = z
        h0, h1 = jets(omega * t + psi)
        u = p.rocker_ratio * h0 - p.lash
        ud = p.rocker_ratio * h1 * (omega + dpsi)
        delta = u - y
        ft = max(0.0, p.stiffness * delta + p.damping * (ud - v)) if delta > 0 else 0.0
        seat = max(0.0, -p.seat_stiffness * y - p.seat_damping * v) if y < 0 else 0.0
        acc = (ft + seat - p.spring_preload - p.spring_rate * y - p.valve_damping * v) / p.mass
        return [v, acc, dpsi, (-p.rocker_ratio * ft * h1 - c * dpsi - k * psi) / J]

    period = 2 * math.pi / omega
    t_eval = (revs - 1) * period + np.arange(N) * period / N
    z0 = [p.rocker_ratio * jets(0.0)[0] - p.lash - p.spring_preload / p.stiffness
          if isinstance(law, OffsetEccentric) else -p.spring_preload / p.seat_stiffness,
          0.0, 0.0, 0.0]
    sol = solve_ivp(rhs, (0.0, revs * period), z0, method='LSODA', t_eval=t_eval,
                    rtol=1e-12, atol=[1e-16, 1e-13, 1e-16, 1e-13])
    assert sol.success
    return sol.y


def _coupled_vs_reference(law, p: SdofParams, rpm: float, step: float):
    spec = camshaft_from_mapping(one_lobe_block(), ['lobe_1'])
    N = round(360 / step)
    cr = run_camshaft([LobeOnShaft('lobe_1', law, 0.0, TrainSpec('sdof', sdof=p), 0.0165)],
                      spec, rpm, step_deg=step, tol=1e-13)
    assert cr.converged
    ref = _reference_twist(law, p, rpm, N)
    run = cr.runs['lobe_1']
    k0 = np.rint(run.alpha / (2 * math.pi / N)).astype(int) % N
    peak = np.max(np.abs(ref[2]))
    assert peak > 1e-5                     # the shaft does twist
    twist_err = np.max(np.abs(cr.twist['lobe_1'] - ref[2])) / peak
    lift_err = np.max(np.abs(run.lift - ref[0][k0])) / np.max(ref[0])
    return twist_err, lift_err


def test_coupled_run_matches_independent_integration_smooth_loads() -> None:
    """Contact everywhere, valve off its seat (smooth loads): the fixed-point coupled
    state (exact SDOF on the twisted lift + Fourier shaft) against LSODA on the full
    coupled ODE, twist and valve lift to 1e-6 of their peaks."""
    p = SdofParams(**{**BASE, 'lash': 0.0})
    twist_err, lift_err = _coupled_vs_reference(OffsetEccentric(3e-3, 2e-3), p, 1200.0, 0.5)
    assert twist_err < 1e-6
    assert lift_err < 1e-6


def _event_reference(law, p: SdofParams, rpm: float, N: int, revs: int = 5):
    """Independent reference for a real lobe: the shaft + SDOF train as one ODE in time
    (y, y', psi, psi'), integrated by DOP853 at rtol 1e-10 in pieces between events
    located by solve_ivp (contact onset/loss, seat contact/lift-off, the cam angle
    omega t + psi crossing a junction of the lobe), each piece with its regime fixed
    (a smooth right-hand side). Returns (y, psi) of the last revolution on the N-point
    grid."""
    k, J = shaft_constants()
    c = 2 * 0.05 / math.sqrt(k / J) * k
    omega = omega_of_rpm(rpm)
    jets = _fast_law(law)
    marks = [float(x) for x in law.breaks]
    kr = p.rocker_ratio

    def forces(t, z):
        y, v, psi, dpsi = z
        h0, h1 = jets(omega * t + psi)
        delta = kr * h0 - p.lash - y
        ddelta = kr * h1 * (omega + dpsi) - v
        ft = p.stiffness * delta + p.damping * ddelta
        rs = -p.seat_stiffness * y - p.seat_damping * v
        return delta, ft, y, rs, h1

    def rhs(t, z, contact, seat):
        y, v, psi, dpsi = z
        _, ft, _, rs, h1 = forces(t, z)
        ft = ft if contact else 0.0
        rs = rs if seat else 0.0
        acc = (ft + rs - p.spring_preload - p.spring_rate * y - p.valve_damping * v) / p.mass
        return [v, acc, dpsi, (-kr * ft * h1 - c * dpsi - k * psi) / J]

    period = 2 * math.pi / omega
    t_grid = (revs - 1) * period + np.arange(N) * period / N
    out = np.full((4, N), np.nan)
    z = np.array([-p.spring_preload / p.seat_stiffness, 0.0, 0.0, 0.0])
    t, contact, seat = period / 2, False, True          # at rest on the base circle
    t_end = revs * period
    passed = None                       # the junction just crossed (not watched again yet)
    while t < t_end:
        evs = []
        d0, _, y0, _, _ = forces(t, z)
        # watched: in contact delta and F_t falling through 0; out of it delta rising
        # (F_t rising too when delta > 0); the same for the seat with -y and R
        watch = ((-1 if contact else 1, True), (-1 if contact else 1, contact or d0 > 0),
                 (1 if seat else -1, True), (-1 if seat else 1, seat or y0 < 0))
        for pos, (sign, on) in enumerate(watch):
            def ev(tt, zz, pos=pos, on=on, sign=sign):
                return forces(tt, zz)[pos] if on else -sign
            ev.terminal, ev.direction = True, sign
            evs.append(ev)
        for m in marks:
            def evj(tt, zz, m=m, off=m == passed):
                return 1.0 if off else math.sin(omega * tt + zz[2] - m)
            evj.terminal, evj.direction = True, 1
            evs.append(evj)
        sel = (t_grid >= t) & (t_grid <= t_end)
        sol = solve_ivp(lambda tt, zz, c=contact, st=seat: rhs(tt, zz, c, st), (t, t_end), z,
                        method='DOP853',
                        rtol=1e-10, atol=[1e-15, 1e-12, 1e-16, 1e-13], events=evs,
                        dense_output=True)
        assert sol.status >= 0
        t_new = float(sol.t[-1])
        inside = sel & (t_grid <= t_new)
        if np.any(inside):
            out[:, inside] = sol.sol(t_grid[inside])
        z = sol.y[:, -1].copy()
        if sol.status == 1:             # an event: the regime after it
            fired = next(i for i, te in enumerate(sol.t_events) if te.size)
            passed = marks[fired - 4] if fired >= 4 else None
            delta, ft, y, rs, _ = forces(t_new, z)
            if fired in (0, 1):         # contact lost, or entered with a pushing force
                contact = False if contact else (ft > 0 if fired == 0 else delta > 0)
            elif fired in (2, 3):       # seat left, or landed on with a pushing force
                seat = False if seat else (rs > 0 if fired == 2 else y < 0)
        t = t_new
    assert np.all(np.isfinite(out))
    return out[0], out[2]


@pytest.mark.parametrize('rpm', [1200.0, 3000.0])
def test_coupled_run_matches_event_reference_real_lobe(rpm: float) -> None:
    """A lobe with lash, ramps and a seat on a 0.1 deg grid, at 1200 rpm and at
    3000 rpm, past the jump speed (the valve leaves the cam for 70 deg and bounces on
    the seat): the coupling converges and the twist at the lobe and the valve lift agree
    to 1e-6 of their peaks with an independent event-located DOP853 integration of the
    whole coupled ODE (the load torque's jumps and kinks at contact onset/loss, seat
    events and the lobe's junctions are taken out of its Fourier series exactly:
    docs/methods.md)."""
    p = SdofParams(**BASE, seat_stiffness=1e8, seat_damping=2000.0)
    spec = camshaft_from_mapping(one_lobe_block(), ['lobe_1'])
    law = ramp_law()
    step = 0.1
    N = round(360 / step)
    cr = run_camshaft([LobeOnShaft('lobe_1', law, 0.0, TrainSpec('sdof', sdof=p), 0.0165)],
                      spec, rpm, step_deg=step, tol=1e-13)
    assert cr.converged
    run = cr.runs['lobe_1']
    assert bool(run.events['separations']) == (rpm > 2000)
    lift_ref, twist_ref = _event_reference(law, p, rpm, N)
    peak = np.max(np.abs(twist_ref))
    assert peak > 1e-5
    assert np.max(np.abs(cr.twist['lobe_1'] - twist_ref)) < 1e-6 * peak
    k0 = np.rint(run.alpha / (2 * math.pi / N)).astype(int) % N
    assert np.max(np.abs(run.lift - lift_ref[k0])) < 1e-6 * np.max(lift_ref)


def test_damped_fallback_takes_over_a_cycling_iteration() -> None:
    """A shaft 33 times softer (peak twist 1 deg) past the jump speed: the plain
    fixed-point iteration (no acceleration) overshoots and cycles at 2e-2 rad for its
    first iterations (undamped it needs 62 iterations to 1e-10 rad); the damped fallback
    takes over and reaches the accelerated iteration's state within 55 iterations, to
    1e-6 of the peak twist."""
    p = SdofParams(**BASE, seat_stiffness=1e8, seat_damping=2000.0)
    spec = camshaft_from_mapping(one_lobe_block(material={'shear_modulus': G * 0.03}),
                                 ['lobe_1'])
    lobes = [LobeOnShaft('lobe_1', ramp_law(), 0.0, TrainSpec('sdof', sdof=p), 0.0165)]
    plain = run_camshaft(lobes, spec, 3000.0, step_deg=0.2, tol=1e-10, depth=0, max_iter=55)
    assert plain.converged and plain.damped and plain.summary()['coupling_damped']
    fast = run_camshaft(lobes, spec, 3000.0, step_deg=0.2, tol=1e-10)
    assert fast.converged and not fast.damped
    peak = np.max(np.abs(fast.twist['lobe_1']))
    assert peak > math.radians(0.5)
    assert np.max(np.abs(plain.twist['lobe_1'] - fast.twist['lobe_1'])) < 1e-6 * peak


def _friction_case(rpm: float = 2000.0):
    law = ramp_law()
    p = SdofParams(**BASE)
    block = one_lobe_block(friction={'cam_follower': {'coefficient': 0.08},
                                     'bearing': {'coefficient': 0.01}},
                           journal_radius=0.012)
    block['stations'] = ['sprocket', 'lobe_1', 'journal_1']
    block['sections'] = [{'length': L_SEC, 'diameter': D_SEC},
                         {'length': 0.03, 'diameter': D_SEC}]
    spec = camshaft_from_mapping(block, ['lobe_1'])
    return run_camshaft([LobeOnShaft('lobe_1', law, 0.0, TrainSpec('sdof', sdof=p), 0.0165)],
                        spec, rpm, step_deg=0.2, tol=1e-13)


def test_energy_balance_over_a_periodic_revolution() -> None:
    """Work of the drive torque = work into the valve train + friction loss + damping
    work of the shaft (one periodic revolution) to 1e-6."""
    cr = _friction_case()
    assert cr.converged and cr.friction_loss > 0 and cr.damping_work > 0
    total = cr.contact_work + cr.friction_loss + cr.damping_work
    assert cr.drive_work == pytest.approx(total, rel=1e-6)
    # the reported mean drive torque is the work per radian (the integral with the
    # kinks taken out); the mean of the 0.2 deg samples differs at the O(step^2) level
    assert cr.summary()['drive_torque_nm']['mean'] * 2 * math.pi == pytest.approx(
        cr.drive_work, rel=1e-12)
    assert np.mean(cr.drive) * 2 * math.pi == pytest.approx(cr.drive_work, rel=1e-4)


def test_flat_friction_torque_closed_form() -> None:
    """mu F (R0 + h); on the base circle mu F R0; the mixed law's regimes."""
    f = np.array([100.0, 200.0])
    h = np.array([0.0, 2e-3])
    t = flat_friction_torque(f, h, np.zeros(2), 0.0165, FlatFriction(coefficient=0.1), 1000.0)
    assert t == pytest.approx([0.1 * 100 * 0.0165, 0.1 * 200 * 0.0185], rel=1e-14)
    mu = mixed_coefficient(np.array([0.5, 1.0, 2.0, 3.0, 5.0]), 0.12, 0.02)
    assert mu == pytest.approx([0.12, 0.12, 0.07, 0.02, 0.02], abs=1e-15)
    assert roller_lever(np.zeros(1), np.zeros(1), 0.0165, 0.01)[0] == pytest.approx(0.0165)


def test_rigid_shaft_limit_equals_single_train() -> None:
    """Without a camshaft the run is today's, its drive torque F h'; a shaft 1e6 times
    stiffer gives the same valve motion to 1e-9 m and the same drive work."""
    law = ramp_law()
    train = TrainSpec('sdof', sdof=SdofParams(**BASE))
    rigid = run_train(law, train, 1500.0, step_deg=0.2)
    assert np.array_equal(rigid.drive_torque, rigid.force * law(rigid.alpha, 1))
    assert not np.any(rigid.friction_torque)
    block = one_lobe_block(material={'shear_modulus': G * 1e6})
    cr = run_camshaft([LobeOnShaft('lobe_1', law, 0.0, train, 0.0165)],
                      camshaft_from_mapping(block, ['lobe_1']), 1500.0, step_deg=0.2)
    assert np.max(np.abs(cr.runs['lobe_1'].lift - rigid.lift)) < 1e-9
    # the rigid run's work: its torque integrated with its own breakpoints (regime
    # switches, the lobe's ends and junctions) over the grid from alpha = 0
    step = math.radians(0.2)
    first = int(round(rigid.alpha[0] / step))
    torque = np.roll(rigid.drive_torque[:-1], first)
    breaks = np.concatenate([rigid.breaks, [*law.support, *law.junctions]])
    work = integral(torque, breaks)
    assert cr.drive_work == pytest.approx(work, rel=1e-6)


@pytest.mark.parametrize('patch, key', [
    ({'sections': [{'length': 0.1}]}, 'camshaft.sections[0].diameter'),
    ({'stations': ['sprocket', 'journal_1']}, 'camshaft.stations'),
    ({'drive': {'kind': 'chain', 'stiffness': 0}}, 'camshaft.drive.stiffness'),
    ({'friction': {'cam_follower': {'coefficient': 1.5}}},
     'camshaft.friction.cam_follower.coefficient'),
    ({'friction': {'roller': {'rolling_resistance': -0.1}}},
     'camshaft.friction.roller.rolling_resistance'),
])
def test_bad_camshaft_block_names_the_key(patch: dict, key: str) -> None:
    with pytest.raises(InputError) as exc:
        camshaft_from_mapping({**one_lobe_block(), **patch}, ['lobe_1'])
    assert exc.value.key == key
    assert '\n' not in str(exc.value)


def _exp_window_coefficients(b1: float, b2: float, n: np.ndarray) -> np.ndarray:
    """Fourier coefficients of f = exp(x / 2) on [b1, b2), 0 elsewhere (closed form)."""
    a = 0.5 - 1j * n
    return (np.exp(a * b2) - np.exp(a * b1)) / a / (2 * math.pi)


@pytest.mark.parametrize('b1, b2', [(1.2345, 4.0007), (math.pi / 2, 3.0)])
def test_piecewise_fourier_against_closed_form(b1: float, b2: float) -> None:
    """A window of exp(x/2) (a jump in every derivative at both ends; in the second
    case one end on a grid node): the coefficients from 720 samples with the two
    breakpoints to 1e-9 of the peak value (the plain FFT is off by ~1e-3), the harmonics
    above the Nyquist order from the jumps alone to 1e-9, and the integral."""
    N = 720
    x = np.arange(N) * 2 * math.pi / N
    f = np.where((x >= b1) & (x < b2), np.exp(x / 2), 0.0)
    n = np.arange(N // 2)
    exact = _exp_window_coefficients(b1, b2, n)
    c, br = coefficients(f, [b1, b2])
    peak = math.exp(b2 / 2)
    assert np.max(np.abs(c[:N // 2] - exact)) < 1e-9 * peak
    assert np.max(np.abs(np.fft.rfft(f)[:N // 2] / N - exact)) > 1e-4 * peak
    high = np.arange(N // 2, 3 * N)
    assert np.max(np.abs(kernel_coefficients(br, high)
                         - _exp_window_coefficients(b1, b2, high))) < 1e-9 * peak
    assert integral(f, [b1, b2]) == pytest.approx(2 * (math.exp(b2 / 2) - math.exp(b1 / 2)),
                                                  rel=1e-10)
