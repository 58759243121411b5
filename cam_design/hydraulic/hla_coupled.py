"""The hydraulic lash adjuster (HLA) as an element of the SDOF and MDOF valve trains,
two-way coupled (scene ``valve_train.hla``, docs/hydraulic.md).

Where it sits: in series with the element that carries the lash, on the valve side
(SDOF: the train spring c, b_t between the cam input u = k h and the valve; MDOF: the
rocker-valve contact k_rv, b_rv). ``ratio`` r maps the HLA to the valve side: its
extension X [m] opens the element by r X, its plunger carries r F.

Element force (F, valve side; unilateral):
    delta0 = x_a - x_V - x0 (x_a: u for the SDOF, the rocker for the MDOF)
    F = max(0, [k_e (delta0 + r X - r e) + b_e delta0'])      while in contact,
the oil column compressed by e = (r F - F_s) / k_oil, k_oil = K A^2 / V0 (a spring in
series; K the effective bulk modulus with entrained air at the gallery pressure), so
F = [k_e (delta0 + r X + r F_s / k_oil) + b_e delta0'] / (1 + k_e r^2 / k_oil).
Chamber (massless plunger): p = (r F - F_s) / A (gauge; not below the vapour pressure).
Plunger: A X' = Q_check(p) - G (p - p_g), the check valve an orifice from the gallery
(p_g) opening when p < p_g, the leakage laminar through the plunger gap,
G = pi d c^3 / (12 mu L), to the reservoir at the gallery pressure. Loaded during the
lift the plunger leaks down; on the base circle the chamber refills until p = p_g (the
HLA spring and the gallery pressure then hold the train closed with
F = (F_s + p_g A) / r); unloaded during the lift (the train has separated) it refills
too and keeps what it gained: **pump-up** (the valve cannot seat on the base circle).

Method: the check valve and the orifice law make the element nonlinear, so the coupled
train (SDOF: y, y', X; MDOF: every coordinate, velocity and X) is integrated as one ODE
by scipy's LSODA (rtol 1e-9, the step at most the output step), over several
revolutions from the base-circle equilibrium; contact and seat switches are resolved
by the integrator's error control. The valve's seat is the penalty seat (the hard seat
is refused with the key).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_finite
from cam_design.hydraulic.gas import gas_events
from cam_design.hydraulic.lash_adjuster import LashAdjuster
from cam_design.hydraulic.oil import P_ATM, effective_bulk_modulus, orifice_flow
from cam_design.valve_train.cam_input import build_cam_input, lift_of_time
from cam_design.valve_train.params import SdofParams, omega_of_rpm, require_step_deg

#: keys of the scene's ``valve_train.hla`` block (all optional; defaults in LashAdjuster)
HLA_KEYS = ('plunger_diameter', 'clearance', 'gap_length', 'viscosity', 'spring_force',
            'gallery_pressure', 'check_area', 'chamber_volume', 'bulk_modulus',
            'air_fraction', 'oil_density', 'max_stroke', 'ratio', 'revolutions')
#: valve lift on the base circle above which the valve counts as held open [m]
SEAT_TOL = 1.0e-6
#: growth of the HLA extension over the last revolution that counts as pump-up [m]
GROWTH_TOL = 1.0e-7
VAPOUR = -P_ATM + 2.0e3      # Pa gauge
#: valve-lift change between the last two revolutions of a gas run that counts as settled
GAS_SETTLED = 1.0e-6
#: length over which the plunger's flow is shut off at the ends of its stroke [m]
STOP_RAMP = 1.0e-6


def hla_from_mapping(spec: Mapping[str, Any] | None,
                     key: str = 'valve_train.hla') -> tuple[LashAdjuster, int]:
    """(LashAdjuster, revolutions) from the scene block; errors name ``key.X``."""
    if spec is None:
        spec = {}
    if not isinstance(spec, Mapping):
        raise InputError(key, spec, 'a mapping of HLA dimensions (docs/hydraulic.md)')
    for k in spec:
        if k not in HLA_KEYS:
            raise InputError(f'{key}.{k}', spec[k], 'one of ' + ', '.join(HLA_KEYS))
    values = {k: require_finite(f'{key}.{k}', v) for k, v in spec.items()}
    revs = values.pop('revolutions', 6)
    if revs != int(revs) or not 2 <= revs <= 200:
        raise InputError(f'{key}.revolutions', spec.get('revolutions'), 'a whole number 2..200')
    try:
        hla = LashAdjuster(**values)
    except InputError as exc:
        name = exc.key.split('.', 1)[-1]
        raise InputError(f'{key}.{name}', exc.value, exc.expected) from None
    return hla, int(revs)


@dataclass
class HlaResult:
    """The last revolution of a coupled run plus the HLA's history over all of them."""

    alpha: NDArray[np.float64]          # rad, last revolution
    y: NDArray[np.float64]              # m, valve lift
    v: NDArray[np.float64]              # m/s
    cam_force: NDArray[np.float64]      # N at the cam (tappet side for the MDOF)
    element_force: NDArray[np.float64]  # N, valve side, through the HLA
    extension: NDArray[np.float64]      # m, HLA extension X
    pressure: NDArray[np.float64]       # Pa gauge, HLA chamber
    per_revolution: list[float]         # m, change of X over each revolution
    base_circle_lift: float             # m, valve lift at the end (base circle)
    leak_down: float                    # m, X lost during the last revolution
    refill: float                       # m, X gained during the last revolution
    pumped_up: bool
    settled: bool
    events: dict[str, Any] = field(default_factory=dict)


class _Train:
    """Linear parts, unilateral elements and the HLA of one train (SDOF or MDOF)."""

    def __init__(self, base: SdofParams, hla: LashAdjuster | None, mdof: Any = None) -> None:
        if base.hard_seat and hla is not None:
            raise InputError('valve_train.hla', 'with a hard seat (seat.restitution)',
                             'the penalty seat (the coupled HLA uses it)')
        self.hard = base.hard_seat
        self.base, self.hla = base, hla
        if mdof is None:
            self.n, self.iv, self.ia = 1, 0, None
            self.m = np.array([base.mass])
            self.k_lin = np.array([[base.spring_rate]])
            self.c_lin = np.array([[base.valve_damping]])
            self.preload = np.array([-base.spring_preload])
            self.k_e, self.b_e = base.stiffness, base.damping
            self.k_c = self.b_c = 0.0
            self.it = None
        else:
            from cam_design.valve_train.mdof import MdofAssembly, R, T, V

            asm = MdofAssembly(mdof)
            self.n, self.iv, self.ia, self.it = asm.n, V, R, T
            self.m, self.k_lin, self.c_lin = asm.m, asm.k_lin, asm.c_lin
            self.preload = asm.preload
            self.k_e, self.b_e = asm.k_rv, asm.b_rv
            self.k_c, self.b_c = asm.k_c, asm.b_c
        if hla is None:         # the plain lash element (gas-force path without HLA)
            self.k_oil, self.den, self.f_eq = math.inf, 1.0, 0.0
            return
        k_eff = effective_bulk_modulus(hla.bulk_modulus, hla.air_fraction,
                                       hla.gallery_pressure + P_ATM)
        self.k_oil = k_eff * hla.area ** 2 / hla.chamber_volume
        r = hla.ratio
        self.den = 1.0 + self.k_e * r * r / self.k_oil
        self.f_eq = (hla.spring_force + hla.gallery_pressure * hla.area) / r

    def element(self, delta0: float, d_delta0: float, x: float) -> float:
        """HLA element force F [N] (valve side) for the opening delta0 [m], its rate and
        the extension X [m]."""
        if self.hla is None:
            return max(0.0, self.k_e * delta0 + self.b_e * d_delta0) if delta0 > 0 else 0.0
        h, r = self.hla, self.hla.ratio
        spring = self.k_e * (delta0 + r * x + r * h.spring_force / self.k_oil)
        if spring <= 0.0:
            return 0.0
        return max(0.0, (spring + self.b_e * d_delta0) / self.den)

    def pressure(self, f: float) -> float:
        """HLA chamber pressure [Pa gauge] under the element force ``f``."""
        h = self.hla
        if h is None:
            return 0.0
        return max((h.ratio * f - h.spring_force) / h.area, VAPOUR)

    def plunger_rate(self, p: float, x: float) -> float:
        """X' [m/s]: refill through the check valve, leakage through the gap."""
        h = self.hla
        if h is None:
            return 0.0
        q = -h.gap_conductance * (p - h.gallery_pressure)
        if p < h.gallery_pressure:
            q += orifice_flow(h.gallery_pressure - p, h.check_area, h.oil_density)
        rate = q / h.area
        # the stroke's ends as stops, ramped over STOP_RAMP (a sliding stop with a
        # discontinuous rate stalls the integrator)
        if rate > 0.0:
            return rate * min(1.0, max(0.0, (h.max_stroke - x) / STOP_RAMP))
        return rate * min(1.0, max(0.0, x / STOP_RAMP))


def _cam_function(law: Any, ratio: float, omega: float, step: float
                  ) -> tuple[Callable[[float], tuple[float, float]], float]:
    """(u(t), u'(t)) = k h at the cam angle a0 + omega t (periodic) from the degree-7
    Hermite pieces of ``cam_input``, and the start angle a0 [rad]."""
    cam = build_cam_input(law, ratio, 0.0, step)
    a0 = float(cam.nodes[0])
    u = lift_of_time(cam, a0, omega, periodic=True)
    return u, a0


def _rhs_factory(tr: _Train, u: Callable[[float], tuple[float, float]],
                 gas: Callable[[float], float] | None, a0: float, omega: float
                 ) -> tuple[Callable[..., Any], Callable[..., Any]]:
    n, iv, ia, it = tr.n, tr.iv, tr.ia, tr.it
    b = tr.base
    minv = 1.0 / tr.m
    ks, bs = b.seat_stiffness, b.seat_damping

    def forces(t: float, s: NDArray) -> tuple[NDArray, float, float]:
        x, xd, hx = s[:n], s[n:2 * n], s[2 * n]
        uc, ucd = u(t)
        f = tr.preload - tr.k_lin @ x - tr.c_lin @ xd
        fc = 0.0
        if it is None:                       # SDOF: the element runs from the cam
            d0, dd0 = uc - x[iv] - b.lash, ucd - xd[iv]
        else:
            d = uc - x[it]
            if d > 0:
                fc = max(0.0, tr.k_c * d + tr.b_c * (ucd - xd[it]))
            f[it] += fc
            d0, dd0 = x[ia] - x[iv] - b.lash, xd[ia] - xd[iv]
        fe = tr.element(d0, dd0, hx)
        f[iv] += fe
        if ia is not None:
            f[ia] -= fe
        if x[iv] < 0 and not tr.hard:
            f[iv] += max(0.0, -ks * x[iv] - bs * xd[iv])
        if gas is not None:
            f[iv] -= gas(a0 + omega * t)
        return f, fe, (fe if it is None else fc)

    if it is None and not tr.hard:      # SDOF: the same equations on floats
        m, c_s, b_v, f0 = float(tr.m[0]), float(tr.k_lin[0, 0]), float(tr.c_lin[0, 0]), \
            -float(tr.preload[0])
        lash = b.lash

        def rhs_sdof(t: float, s: NDArray) -> list[float]:
            y, v, hx = float(s[0]), float(s[1]), float(s[2])
            uc, ucd = u(t)
            fe = tr.element(uc - y - lash, ucd - v, hx)
            f = fe - f0 - c_s * y - b_v * v
            if y < 0:
                f += max(0.0, -ks * y - bs * v)
            if gas is not None:
                f -= gas(a0 + omega * t)
            return [v, f / m, tr.plunger_rate(tr.pressure(fe), hx)]

        return rhs_sdof, forces

    def rhs(t: float, s: NDArray) -> NDArray:
        f, fe, _ = forces(t, s)
        out = np.empty(2 * n + 1)
        out[:n] = s[n:2 * n]
        out[n:2 * n] = f * minv
        out[2 * n] = tr.plunger_rate(tr.pressure(fe), s[2 * n])
        return out

    return rhs, forces


def _initial_state(tr: _Train, uc: float, gas0: float = 0.0) -> NDArray[np.float64]:
    """Base-circle equilibrium: the HLA element carries F_eq, the valve on its seat
    (``gas0``: the gas force there [N])."""
    n, iv, ia, it = tr.n, tr.iv, tr.ia, tr.it
    b = tr.base
    kk = tr.k_lin.copy()
    f = tr.preload.copy()
    f[iv] -= gas0
    kk[iv, iv] += b.seat_stiffness
    f[iv] += tr.f_eq
    if it is not None:
        kk[it, it] += tr.k_c
        f[it] += tr.k_c * uc
        f[ia] -= tr.f_eq
    if tr.hard:             # held on the hard seat: x_V = 0
        keep = [i for i in range(n) if i != iv]
        x = np.zeros(n)
        if keep:
            x[keep] = np.linalg.solve(tr.k_lin[np.ix_(keep, keep)]
                                      + np.diag([tr.k_c if i == it else 0.0 for i in keep]),
                                      f[keep])
        return np.concatenate([x, np.zeros(n), [0.0]])
    x = np.linalg.solve(kk, f)
    if x[iv] > 0:           # the preload does not hold the valve shut: no seat force
        kk[iv, iv] -= b.seat_stiffness
        x = np.linalg.solve(kk, f)
    if tr.hla is None:      # lash element open on the base circle (checked by the run)
        return np.concatenate([x, np.zeros(n), [0.0]])
    d0 = (uc if it is None else x[ia]) - x[iv] - b.lash
    r = tr.hla.ratio
    e = (r * tr.f_eq - tr.hla.spring_force) / tr.k_oil
    hx = (tr.f_eq / tr.k_e - d0) / r + e
    if not 0.0 <= hx <= tr.hla.max_stroke:
        raise InputError('valve_train.hla.max_stroke', tr.hla.max_stroke,
                         f'a stroke that takes up the lash ({hx * 1e3:.3g} mm needed)')
    return np.concatenate([x, np.zeros(n), [hx]])


def integrate(tr: _Train, u: Callable[[float], tuple[float, float]], t_out: NDArray,
              state0: NDArray, *, gas: Callable[[float], float] | None = None,
              a0: float = 0.0, omega: float = 1.0, max_step: float = math.inf,
              rtol: float = 1e-9) -> tuple[NDArray, NDArray, NDArray]:
    """Integrate the coupled train from ``state0`` at t = 0 over ``t_out`` [s]; returns
    (states (2n+1, T), element force, cam force) on ``t_out``."""
    from scipy.integrate import solve_ivp

    rhs, forces = _rhs_factory(tr, u, gas, a0, omega)
    n = tr.n
    atol = np.concatenate([np.full(n, 1e-12), np.full(n, 1e-9), [1e-13]])
    sol = solve_ivp(rhs, (0.0, float(t_out[-1])), state0, method='LSODA', t_eval=t_out,
                    rtol=rtol, atol=atol, max_step=max_step)
    if not sol.success:
        raise RuntimeError(f'HLA train integration failed: {sol.message}')
    fe = np.empty(t_out.size)
    fc = np.empty(t_out.size)
    for i, t in enumerate(sol.t):
        _, fe[i], fc[i] = forces(t, sol.y[:, i])
    return sol.y, fe, fc


def _run_grid(law: Any, base: SdofParams, rpm: float, step_deg: float, revolutions: int
              ) -> tuple[float, float, Callable[[float], tuple[float, float]], float, int,
                         float, NDArray]:
    """(omega [rad/s], step [rad], cam drive u(t), start angle a0 [rad], steps per
    revolution, revolution time [s], output times [s]) of a run of ``revolutions``."""
    omega = omega_of_rpm(rpm)
    step = math.radians(require_step_deg('step_deg', step_deg))
    u, a0 = _cam_function(law, base.rocker_ratio, omega, step)
    per_rev = int(round(2 * math.pi / step))
    t_rev = 2 * math.pi / omega
    t_out = np.linspace(0.0, revolutions * t_rev, revolutions * per_rev + 1)
    return omega, step, u, a0, per_rev, t_rev, t_out


def simulate_hla(law: Any, base: SdofParams, hla: LashAdjuster, rpm: float, *,
                 mdof: Any = None, revolutions: int = 6, step_deg: float = 0.5,
                 gas: Callable[[float], float] | None = None,
                 rtol: float = 1e-9) -> HlaResult:
    """Run the train with the coupled HLA for ``revolutions`` camshaft revolutions at
    ``rpm`` from the base-circle equilibrium; report the last one, the HLA's change of
    extension per revolution, leak-down and refill, and pump-up (the valve held off its
    seat on the base circle at the end); ``settled`` False while the extension still
    changes by more than GROWTH_TOL over the last revolution."""
    tr = _Train(base, hla, mdof)
    omega, step, u, a0, per_rev, t_rev, t_out = _run_grid(law, base, rpm, step_deg,
                                                          revolutions)
    state0 = _initial_state(tr, u(0.0)[0], 0.0 if gas is None else gas(a0))
    z, fe, fc = integrate(tr, u, t_out, state0, gas=gas, a0=a0,
                          omega=omega, max_step=t_rev / per_rev, rtol=rtol)
    hx = z[2 * tr.n]
    starts = hx[::per_rev]
    changes = np.diff(starts).tolist()
    last = slice((revolutions - 1) * per_rev, revolutions * per_rev + 1)
    y = z[tr.iv, last]
    dx = np.diff(hx[last])
    cam_force = fc[last] * (base.rocker_ratio if mdof is not None else 1.0)
    base_lift = float(y[-1])
    growth = changes[-1]
    pumped = base_lift > SEAT_TOL
    settled = abs(growth) <= GROWTH_TOL or pumped
    p = np.array([tr.pressure(f) for f in fe[last]])
    res = HlaResult(alpha=a0 + np.linspace(0.0, 2 * math.pi, per_rev + 1), y=y,
                    v=z[tr.n + tr.iv, last], cam_force=cam_force, element_force=fe[last],
                    extension=hx[last], pressure=p, per_revolution=changes,
                    base_circle_lift=base_lift, leak_down=float(-dx[dx < 0].sum()),
                    refill=float(dx[dx > 0].sum()), pumped_up=bool(pumped),
                    settled=bool(settled))
    res.events = {
        'hla_pump_up': res.pumped_up,
        'hla_extension_change_last_rev_m': float(growth),
        'hla_extension_change_per_rev_m': [float(c) for c in changes],
        'hla_leak_down_m': res.leak_down,
        'hla_refill_m': res.refill,
        'hla_base_circle_valve_lift_m': base_lift,
        'hla_peak_pressure_pa': float(p.max()),
        'hla_settled': res.settled,
        'hla_revolutions': int(revolutions),
    }
    return res


def run_with_hla(law: Any, params: SdofParams, hla_spec: Mapping[str, Any], rpm: float, *,
                 mdof: Any = None, step_deg: float = 0.5,
                 gas: Callable[[float], float] | None = None,
                 geometry: Any = None, train_checks: Any = None) -> Any:
    """A ``Run`` of the SDOF (``mdof`` None) or MDOF train with the coupled HLA of the
    scene block ``hla_spec``: the last revolution's arrays, the usual events (opening,
    closing, separations, seating velocity on the sampled solution) and the HLA's
    (``hla_*``; pump-up also in the ``note``). ``settled`` is the HLA's: its extension
    no longer changes from one revolution to the next."""
    from cam_design.valve_train.mdof import sampled_events
    from cam_design.valve_train.report import finish_run

    hla, revs = hla_from_mapping(hla_spec)
    res = simulate_hla(law, params, hla, rpm, mdof=mdof, revolutions=revs,
                       step_deg=max(step_deg, 0.5), gas=gas)
    u = params.rocker_ratio * law(res.alpha)
    contact = res.element_force if mdof is None else res.cam_force
    events = sampled_events(res.alpha, res.y, res.v, contact, u)
    events.update(res.events)
    if gas is not None:
        events.update(gas_events(gas, res.alpha, events.get('opening_deg')))
    events.update({'revolutions': revs, 'settled': res.settled,
                   'periodic_residual_m': abs(res.events['hla_extension_change_last_rev_m']),
                   'left_cam': False})
    run = finish_run(law, params, rpm, 'mdof' if mdof is not None else 'sdof', res.alpha,
                     res.y, res.v, res.cam_force, events, geometry, train_checks)
    if res.pumped_up:
        gained = sum(res.per_revolution)
        full = res.extension[-1] >= hla.max_stroke - 2 * STOP_RAMP
        text = (f'HLA pump-up at {rpm:g} rpm: the lash adjuster extended by '
                f'{gained * 1e6:.1f} um over {revs} revolutions'
                + (' (to the end of its stroke)' if full else '')
                + f' and the valve is {res.base_circle_lift * 1e3:.3f} mm off its seat on '
                'the base circle (lash lost: the valve cannot close)')
        old = run.events.get('note')
        run.events['note'] = text if not old else f'{text}; {old}'
    elif not res.settled:
        growth = res.events['hla_extension_change_last_rev_m']
        text = (f'the HLA still changes its extension by {growth * 1e6:.2f} um per '
                f'revolution after {revs} revolutions at {rpm:g} rpm: pump-up is not '
                'excluded (raise valve_train.hla.revolutions)')
        old = run.events.get('note')
        run.events['note'] = text if not old else f'{text}; {old}'
    return run


def integrate_hard_seat(tr: _Train, u: Callable[[float], tuple[float, float]],
                        t_out: NDArray, state0: NDArray, *,
                        gas: Callable[[float], float] | None, a0: float, omega: float,
                        max_step: float, rtol: float = 1e-9
                        ) -> tuple[NDArray, NDArray, list[tuple[float, float]]]:
    """The train (no HLA) with the hard seat: held on the seat (the valve frozen) while
    the net force on it does not open it, free otherwise; the lift-off and the impact
    are located as events of the integrator (DOP853 for the SDOF, Radau for the MDOF;
    LSODA's dense output is too coarse for the event roots), the impact reverses the
    valve speed times the restitution (below 1e-9 m/s it stays held). Starts held.
    Returns the states on ``t_out``, the cam (SDOF: element) force and the impacts
    (time, speed)."""
    from scipy.integrate import solve_ivp

    rhs_free, forces = _rhs_factory(tr, u, gas, a0, omega)
    n, iv = tr.n, tr.iv
    e = float(tr.base.restitution or 0.0)

    def net(t: float, s: NDArray) -> float:
        return float(forces(t, s)[0][iv])

    def rhs_held(t: float, s: NDArray) -> NDArray:
        out = rhs_free(t, s)
        out[iv] = out[n + iv] = 0.0
        return out

    def lift(t: float, s: NDArray) -> float:
        return net(t, s)

    def hit(t: float, s: NDArray) -> float:
        return float(s[iv])

    method = 'DOP853' if n == 1 else 'Radau'       # the coil chains are stiff
    lift.terminal, lift.direction = True, 1        # type: ignore[attr-defined]
    hit.terminal, hit.direction = True, -1         # type: ignore[attr-defined]
    atol = np.concatenate([np.full(n, 1e-12), np.full(n, 1e-9), [1e-13]])
    out = np.zeros((2 * n + 1, t_out.size))
    state, t, t_end, held = state0.copy(), 0.0, float(t_out[-1]), True
    impacts: list[tuple[float, float]] = []
    count = 0
    while t < t_end:
        count += 1
        if count > 100000:
            raise RuntimeError('hard seat: more than 100000 impacts (chatter)')
        sol = solve_ivp(rhs_held if held else rhs_free, (t, t_end), state, method=method,
                        rtol=rtol, atol=atol, max_step=max_step, dense_output=True,
                        events=lift if held else hit)
        if not sol.success:
            raise RuntimeError(f'hard-seat integration failed: {sol.message}')
        t_stop = float(sol.t[-1])
        sel = (t_out >= t) & (t_out <= t_stop)
        if np.any(sel):
            out[:, sel] = sol.sol(t_out[sel])
            if held:
                out[iv, sel] = out[n + iv, sel] = 0.0
        state = sol.y[:, -1].copy()
        if sol.status == 1:
            if held:
                held = False
            else:
                v_hit = float(state[n + iv])
                impacts.append((t_stop, -v_hit))
                state[iv] = 0.0
                state[n + iv] = -e * v_hit
                held = state[n + iv] <= 1e-9 and net(t_stop, state) <= 0.0
                if held:
                    state[n + iv] = 0.0
            t = t_stop + 1e-12 * max_step * 1e3 if math.isfinite(max_step) else t_stop + 1e-12
            if held and net(t, state) > 0.0:   # lifts off again at once
                held = False
        else:
            t = t_end
    fc = np.array([forces(t, out[:, i])[2] for i, t in enumerate(t_out)])
    return out, fc, impacts


def _periodic_start(tr: _Train, mdof: Any, law: Any, base: SdofParams, omega: float,
                    step: float, fallback: NDArray) -> NDArray:
    """The exact MDOF solver's periodic state without the gas force at the window
    start (the coil surge of the previous lift included), as the start of the gas run;
    ``fallback`` when that solver does not settle."""
    from cam_design.valve_train.mdof import MdofAssembly
    from cam_design.valve_train.mdof_exact import run_exact

    cam = build_cam_input(law, base.rocker_ratio, 0.0, step)
    try:
        ex = run_exact(MdofAssembly(mdof), cam, omega, max_revolutions=8, periodic_tol=1e-10)
    except Exception:           # noqa: BLE001 - any failure: start from rest instead
        return fallback
    if not ex.settled or (tr.hard and (ex.z[0][tr.iv] != 0.0 or ex.z[0][tr.n + tr.iv] != 0.0)):
        return fallback
    return np.concatenate([np.asarray(ex.z[0], dtype=float), [0.0]])


def simulate_gas_train(law: Any, base: SdofParams, rpm: float, *, mdof: Any = None,
                       gas: Callable[[float], float], revolutions: int = 4,
                       step_deg: float = 0.5, start: str = 'periodic') -> dict[str, Any]:
    """The MDOF (or, ``mdof`` None, SDOF) train without HLA, penalty or hard seat, with
    a cylinder-gas force ``gas(alpha)`` [N] on the valve, by the same ODE path (LSODA,
    rtol 1e-9; the hard seat by ``integrate_hard_seat``) over ``revolutions`` from the
    base-circle equilibrium; the exact solvers take no gas force with the hard seat
    and the exact MDOF solver none at all. Returns the last revolution (alpha, y, v, cam force) and
    ``settled`` (the valve motion of the last two revolutions agrees to GAS_SETTLED).
    The MDOF train starts from the exact solver's periodic state without the gas
    (``start`` 'periodic'), or from the base-circle equilibrium ('rest')."""
    tr = _Train(base, None, mdof)
    omega, step, u, a0, per_rev, t_rev, t_out = _run_grid(law, base, rpm, step_deg,
                                                          revolutions)
    state0 = _initial_state(tr, u(0.0)[0], gas(a0))
    if mdof is not None and start == 'periodic':
        state0 = _periodic_start(tr, mdof, law, base, omega, step, state0)
    if tr.hard:
        z, fc, _ = integrate_hard_seat(tr, u, t_out, state0, gas=gas, a0=a0, omega=omega,
                                       max_step=t_rev / per_rev)
    else:
        z, _, fc = integrate(tr, u, t_out, state0, gas=gas, a0=a0, omega=omega,
                             max_step=t_rev / per_rev)
    last = slice((revolutions - 1) * per_rev, revolutions * per_rev + 1)
    y = z[tr.iv]
    residual = math.inf
    if revolutions > 1:
        prev = slice((revolutions - 2) * per_rev, (revolutions - 1) * per_rev + 1)
        residual = float(np.max(np.abs(y[last] - y[prev])))
    return {'alpha': a0 + np.linspace(0.0, 2 * math.pi, per_rev + 1), 'y': y[last],
            'v': z[tr.n + tr.iv, last], 'cam_force': base.rocker_ratio * fc[last],
            'settled': residual <= GAS_SETTLED, 'periodic_residual_m': residual,
            'revolutions': revolutions}


def run_gas_ode(law: Any, params: SdofParams, mdof: Any, rpm: float, *,
                gas: Callable[[float], float], step_deg: float = 0.5,
                geometry: Any = None, train_checks: Any = None,
                revolutions: int = 3) -> Any:
    """A ``Run`` of the MDOF train (any seat) or of the SDOF train with the hard seat
    (``mdof`` None) with the cylinder-gas force (``simulate_gas_train``): events on the
    sampled last revolution, ``settled`` when two revolutions agree."""
    from cam_design.valve_train.mdof import sampled_events
    from cam_design.valve_train.report import finish_run

    res = simulate_gas_train(law, params, rpm, mdof=mdof, gas=gas, revolutions=revolutions,
                             step_deg=max(step_deg, 0.5))
    u = params.rocker_ratio * law(res['alpha'])
    events = sampled_events(res['alpha'], res['y'], res['v'], res['cam_force'], u)
    events.update({'revolutions': revolutions, 'settled': res['settled'],
                   'periodic_residual_m': res['periodic_residual_m'], 'left_cam': False,
                   'integration': 'ODE path (gas force, docs/hydraulic.md)'})
    events.update(gas_events(gas, res['alpha'], events.get('opening_deg')))
    return finish_run(law, params, rpm, 'sdof' if mdof is None else 'mdof', res['alpha'],
                      res['y'], res['v'], res['cam_force'], events, geometry,
                      train_checks)
