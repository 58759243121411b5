"""Multi-DOF valve train "4 + N1 + N2" (docs/dynamics.md, Shang §3.2 RECONSTRUCTED).

Shang's text is not available; this is the reading of docs/dynamics.md: four lumped
bodies - tappet, push-rod, rocker (a translational DOF at the valve side) and valve
with retainer - plus the inner and outer valve springs discretised into N1 and N2 coil
masses. Every coordinate is referred to the valve side (tappet-side displacements
times the rocker ratio k, masses and stiffnesses divided by k^2), SI units.

Elements (force > 0 pushes the valve open):
* cam-tappet contact, unilateral: F_c = max(0, k_c d + b_c d') for d = k h - x_t > 0;
* tappet-push-rod k_tp and push-rod-rocker k_pr (linear springs with dashpots);
* rocker-valve contact with the lash x0, unilateral: d = x_r - x_v - x0;
* spring i (rate c_i, mass m_i, preload F0_i): N_i masses m_i/N_i joined by N_i + 1
  springs of rate (N_i + 1) c_i between the retainer (valve) and the head (fixed);
  the preload is a constant force on the valve;
* the penalty seat of the ``sdof`` contract on the valve, or the hard seat with
  restitution (exact solver only);
* (addition needed once the lash is open) a light follower spring keeping the tappet,
  push-rod and rocker on the cam: rate k_f and preload F_f on the tappet.
Dashpots are stiffness-proportional, b = beta k, beta = b_t / c of the SDOF train, and
beta_s for the coils. Integration: by default the exact piecewise-linear solver of
``mdof_exact`` (matrix exponentials per regime and step, switches located on the exact
local solution, Newton shooting to the periodic state); ``method`` LSODA | Radau | BDF
keeps the earlier scipy ``solve_ivp`` path (analytic piecewise Jacobian, one span from
rest, contact switches inside the right-hand side, separations on the output grid) as a
reference option.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

from cam_design.errors import InputError, require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.cam_input import build_cam_input, lift_of_time
from cam_design.valve_train.params import SdofParams, omega_of_rpm, require_step_deg

T, P, R, V = 0, 1, 2, 3


@dataclass(frozen=True)
class CoilSpring:
    """A valve spring: rate [N/m], mass [kg], coil masses N, share of the preload."""

    rate: float
    mass: float
    coils: int
    preload_share: float


@dataclass(frozen=True)
class MdofParams:
    """Parameters of the 4+N1+N2 model (valve side). ``base`` carries the SDOF values
    used unchanged: rocker ratio, lash, preload, valve damping, seat, beta = b_t / c."""

    base: SdofParams
    masses: tuple[float, float, float, float]          # tappet, push-rod, rocker, valve
    stiffness: tuple[float, float, float, float]       # cam contact, t-p, p-r, rocker-valve
    springs: tuple[CoilSpring, ...]
    coil_beta: float = 2e-6                            # s, coil dashpots b = beta k
    follower_rate: float = 1.0e3                       # N/m
    follower_preload: float = 20.0                     # N

    @property
    def series_stiffness(self) -> float:
        """1 / sum(1/k) of the four train elements [N/m]."""
        return 1.0 / sum(1.0 / k for k in self.stiffness)

    @property
    def n_dof(self) -> int:
        return 4 + sum(s.coils for s in self.springs)


MDOF_KEYS = ('masses', 'stiffness', 'springs', 'coil_beta', 'follower_rate',
             'follower_preload')


def mdof_from_mapping(spec: Mapping[str, Any] | None, base: SdofParams,
                      key: str = 'valve_train.mdof') -> MdofParams:
    """Build from a scene's ``valve_train.mdof`` mapping (None: defaults derived from
    the SDOF values, documented in docs/dynamics.md).

    Keys: masses [tappet, pushrod, rocker, valve] kg; stiffness [cam_contact,
    tappet_pushrod, pushrod_rocker, rocker_valve] N/m; springs: list of {rate, mass,
    coils, preload_share}; coil_beta s; follower_rate N/m; follower_preload N.
    """
    spec = dict(spec or {})
    unknown = sorted(set(spec) - set(MDOF_KEYS))
    if unknown:
        raise InputError(f'{key}.{unknown[0]}', spec[unknown[0]],
                         'one of ' + ', '.join(MDOF_KEYS))
    M, c = base.mass, base.stiffness
    masses = spec.get('masses', [0.1 * M, 0.1 * M, 0.2 * M, 0.5 * M])
    stiff = spec.get('stiffness', [4 * c, 4 * c, 4 * c, 4 * c])
    for name, vals in (('masses', masses), ('stiffness', stiff)):
        if not isinstance(vals, (list, tuple)) or len(vals) != 4:
            raise InputError(f'{key}.{name}', vals, 'a list of 4 positive numbers')
        for i, v in enumerate(vals):
            require_positive(f'{key}.{name}[{i}]', v)
    springs_spec = spec.get('springs', [
        {'rate': 0.4 * base.spring_rate, 'mass': 0.25 * M, 'coils': 8, 'preload_share': 0.4},
        {'rate': 0.6 * base.spring_rate, 'mass': 0.35 * M, 'coils': 8, 'preload_share': 0.6}])
    if not isinstance(springs_spec, (list, tuple)) or not springs_spec:
        raise InputError(f'{key}.springs', springs_spec, 'a non-empty list of springs')
    springs = []
    for i, s in enumerate(springs_spec):
        k = f'{key}.springs[{i}]'
        if not isinstance(s, Mapping):
            raise InputError(k, s, 'a mapping {rate, mass, coils, preload_share}')
        coils = s.get('coils', 8)
        if isinstance(coils, bool) or not isinstance(coils, int) or not 1 <= coils <= 200:
            raise InputError(f'{k}.coils', coils, 'an integer 1..200')
        springs.append(CoilSpring(rate=require_positive(f'{k}.rate', s.get('rate')),
                                  mass=require_positive(f'{k}.mass', s.get('mass')),
                                  coils=coils,
                                  preload_share=require_positive(
                                      f'{k}.preload_share', s.get('preload_share', 1.0),
                                      allow_zero=True)))
    share = sum(s.preload_share for s in springs)
    if share <= 0:
        raise InputError(f'{key}.springs', 'preload shares', 'shares with a positive sum')
    m4 = [float(m) for m in masses]            # four of each: checked above
    k4 = [float(x) for x in stiff]
    return MdofParams(base=base, masses=(m4[0], m4[1], m4[2], m4[3]),
                      stiffness=(k4[0], k4[1], k4[2], k4[3]), springs=tuple(springs),
                      coil_beta=require_positive(f'{key}.coil_beta',
                                                 spec.get('coil_beta', 2e-6), allow_zero=True),
                      follower_rate=require_positive(f'{key}.follower_rate',
                                                     spec.get('follower_rate', 1e3),
                                                     allow_zero=True),
                      follower_preload=require_positive(f'{key}.follower_preload',
                                                        spec.get('follower_preload', 20.0),
                                                        allow_zero=True))


class MdofAssembly:
    """The assembled 4 + N1 + N2 train, shared by the exact, scipy-reference and HLA solvers.

    ``m`` masses [kg], ``k_lin`` [N/m] and ``c_lin`` [N s/m] the linear stiffness and
    damping matrices, ``preload`` [N] the constant forces, ``k_c``/``b_c`` and
    ``k_rv``/``b_rv`` the rates of the unilateral cam-tappet and rocker-valve contacts,
    ``surge_hz`` the coil surge frequencies of each spring [Hz].
    """

    def __init__(self, mp: MdofParams) -> None:
        b = mp.base
        n = mp.n_dof
        self.mp = mp
        self.n = n
        beta = b.damping / b.stiffness
        m = np.zeros(n)
        m[:4] = mp.masses
        k_lin = np.zeros((n, n))
        c_lin = np.zeros((n, n))

        def link(i: int, j: int | None, k: float, bb: float) -> None:
            k_lin[i, i] += k
            c_lin[i, i] += bb
            if j is not None:
                k_lin[j, j] += k
                k_lin[i, j] -= k
                k_lin[j, i] -= k
                c_lin[j, j] += bb
                c_lin[i, j] -= bb
                c_lin[j, i] -= bb

        k_c, k_tp, k_pr, k_rv = mp.stiffness
        link(T, P, k_tp, beta * k_tp)
        link(P, R, k_pr, beta * k_pr)
        link(T, None, mp.follower_rate, 0.0)
        c_lin[V, V] += b.valve_damping
        idx = 4
        share = sum(s.preload_share for s in mp.springs)
        self.preload = np.zeros(n)
        self.preload[V] = -b.spring_preload
        self.preload[T] = -mp.follower_preload
        self.surge_hz: list[list[float]] = []
        for s in mp.springs:
            ke = (s.coils + 1) * s.rate
            heads = [V] + list(range(idx, idx + s.coils))     # valve, then the coils
            tails: list[int | None] = [*heads[1:], None]      # ... the last to ground
            for a_, b_ in zip(heads, tails):
                link(a_, b_, ke, mp.coil_beta * ke)
            m[idx:idx + s.coils] = s.mass / s.coils
            sub_k = k_lin[idx:idx + s.coils, idx:idx + s.coils]
            w2 = eigh(sub_k, np.diag(m[idx:idx + s.coils]), eigvals_only=True)
            self.surge_hz.append((np.sqrt(np.maximum(w2, 0)) / (2 * math.pi)).tolist())
            idx += s.coils
        del share
        self.m = m
        self.k_lin = k_lin
        self.c_lin = c_lin
        self.k_c, self.k_rv = k_c, k_rv
        self.b_c, self.b_rv = beta * k_c, beta * k_rv

    def natural_frequencies(self) -> NDArray[np.float64]:
        """[Hz] with both contacts closed and the valve off its seat."""
        k = self.k_lin.copy()
        k[T, T] += self.k_c
        k[R, R] += self.k_rv
        k[V, V] += self.k_rv
        k[R, V] -= self.k_rv
        k[V, R] -= self.k_rv
        w2 = eigh(k, np.diag(self.m), eigvals_only=True)
        return np.sqrt(np.maximum(w2, 0.0)) / (2 * math.pi)


@dataclass
class MdofResult:
    """Valve motion on the output grid (alpha rad) and the events.

    ``settled``: the state at the start node repeated within the periodic tolerance
    (always False for a single revolution of the LSODA/Radau/BDF path, which does not
    check it); ``periodic_residual`` [m] and ``revolutions`` say how close it came."""

    alpha: NDArray[np.float64]
    y: NDArray[np.float64]                 # valve lift [m]
    v: NDArray[np.float64]                 # valve velocity [m/s]
    cam_force: NDArray[np.float64]         # k * F_c [N] at the cam
    natural_frequencies_hz: NDArray[np.float64]
    surge_hz: list[list[float]]
    events: dict[str, Any] = field(default_factory=dict)
    nfev: int = 0
    method: str = 'exact'
    revolutions: int = 1
    periodic_residual: float = math.inf
    settled: bool = False


METHODS = ('exact', 'LSODA', 'Radau', 'BDF')
#: a valve lift above RUNAWAY times the rigid lift k h_max - x0: the valve has left the cam
RUNAWAY = 1.1


def simulate_mdof(law: LiftLaw, mp: MdofParams, rpm: float, *, step_deg: float = 0.1,
                  method: str = 'exact', max_revolutions: int = 8,
                  periodic_tol: float = 1e-10, rtol: float = 1e-8, atol: float = 1e-12,
                  pre_deg: float = 1.0, span_deg: float = 360.0) -> MdofResult:
    """Valve motion from static equilibrium on the base circle ``pre_deg`` before the
    lobe, on the multiples of ``step_deg``.

    ``method`` 'exact' (default): the piecewise-exact solver of ``mdof_exact``,
    revolutions repeated until periodic (``periodic_tol`` m, at most
    ``max_revolutions``), penalty or hard seat; the last revolution is returned (cut
    to ``span_deg``). 'LSODA' | 'Radau' | 'BDF': scipy ``solve_ivp`` over ``span_deg``
    from rest with the contact switches inside the right-hand side (penalty seat only;
    the earlier reference path, kept for comparison)."""
    if method not in METHODS:
        raise InputError('method', method, ' | '.join(METHODS))
    if method != 'exact':
        return _simulate_ivp(law, mp, rpm, step_deg=step_deg, rtol=rtol, atol=atol,
                             method=method, pre_deg=pre_deg, span_deg=span_deg)
    if isinstance(max_revolutions, bool) or int(max_revolutions) < 1:
        raise InputError('max_revolutions', max_revolutions, 'an integer >= 1')
    return MdofRunner(law, mp, step_deg=step_deg, max_revolutions=int(max_revolutions),
                      periodic_tol=periodic_tol, pre_deg=pre_deg, span_deg=span_deg)(rpm)


class MdofRunner:
    """Exact MDOF runs of one lobe at many speeds: the assembly and the cam polynomial
    are built once (``simulate_mdof`` is one call of a fresh runner, so a sweep and the
    single runs compute exactly the same thing)."""

    def __init__(self, law: LiftLaw, mp: MdofParams, *, step_deg: float = 0.1,
                 max_revolutions: int = 8, periodic_tol: float = 1e-10,
                 pre_deg: float = 1.0, span_deg: float = 360.0) -> None:
        step = math.radians(require_step_deg('step_deg', step_deg))
        span = math.radians(require_positive('span_deg', span_deg))
        if span > 2 * math.pi + 1e-12:
            raise InputError('span_deg', span_deg, 'at most 360')
        if isinstance(max_revolutions, bool) or int(max_revolutions) < 1:
            raise InputError('max_revolutions', max_revolutions, 'an integer >= 1')
        self.mp = mp
        self.span = span
        self.max_revolutions = int(max_revolutions)
        self.periodic_tol = periodic_tol
        self.asm = MdofAssembly(mp)
        self.cam = build_cam_input(law, mp.base.rocker_ratio, 0.0, step,
                                   pre=math.radians(require_positive('pre_deg', pre_deg)))

    def __call__(self, rpm: float) -> 'MdofResult':
        from cam_design.valve_train.mdof_exact import run_exact

        omega = omega_of_rpm(rpm)
        return self._finish(run_exact(self.asm, self.cam, omega,
                                      max_revolutions=self.max_revolutions,
                                      periodic_tol=self.periodic_tol))

    def _finish(self, ex: Any) -> 'MdofResult':
        asm, cam, mp, span = self.asm, self.cam, self.mp, self.span
        n = asm.n
        sel = cam.uniform & (cam.nodes <= cam.nodes[0] + span + 1e-9)
        z = ex.z[sel]
        alpha = cam.nodes[sel]
        fc = _cam_force(asm, z, ex.u[sel], ex.ud[sel], (ex.regime[sel] & 1) > 0)
        y = z[:, V]
        ev = ex.events
        bounce_h = 0.0
        if ev.closing is not None:
            after = alpha > ev.closing
            bounce_h = float(max(0.0, np.max(y[after], initial=0.0)))
        rigid = float(np.max(ex.u)) - mp.base.lash
        runaway = bool(np.max(ex.z[:, V]) > RUNAWAY * max(rigid, 0.0) + 1e-6)
        events = {
            'opening_deg': _deg(ev.opening), 'closing_deg': _deg(ev.closing),
            'separations': [[math.degrees(a), math.degrees(b)] for a, b in ev.separations],
            'valve_toss': [[math.degrees(a), math.degrees(b)] for a, b in ev.valve_toss],
            'jump': bool(ev.separations or ev.valve_toss or runaway),
            'valve_leaves_cam': runaway,
            'seating_velocity_m_s': ev.seating_velocity,
            'bounce_count': int(ev.bounce_count), 'bounce_height_m': bounce_h,
            'revolutions': int(ex.revolutions),
            'periodic_residual_m': float(ex.periodic_residual),
            'settled': bool(ex.settled), 'switches': int(ev.count)}
        return MdofResult(alpha=alpha, y=y, v=z[:, n + V],
                          cam_force=mp.base.rocker_ratio * fc,
                          natural_frequencies_hz=asm.natural_frequencies(),
                          surge_hz=asm.surge_hz, events=events, method='exact',
                          revolutions=ex.revolutions, periodic_residual=ex.periodic_residual,
                          settled=ex.settled)


def _deg(x: float | None) -> float | None:
    return None if x is None else math.degrees(x)


def _cam_force(asm: 'MdofAssembly', z: NDArray, u: NDArray, ud: NDArray,
               contact: NDArray) -> NDArray:
    """Valve-side cam contact force F_c [N] at the nodes (0 off contact)."""
    d = u - z[:, T]
    f = asm.k_c * d + asm.b_c * (ud - z[:, asm.n + T])
    return np.where(contact & (d > 0), np.maximum(f, 0.0), 0.0)


def _simulate_ivp(law: LiftLaw, mp: MdofParams, rpm: float, *, step_deg: float,
                  rtol: float, atol: float, method: str, pre_deg: float,
                  span_deg: float) -> MdofResult:
    """The scipy path (one span from rest, switches inside the right-hand side)."""
    omega = omega_of_rpm(rpm)
    step = math.radians(require_step_deg('step_deg', step_deg))
    asm = MdofAssembly(mp)
    b = mp.base
    k = b.rocker_ratio
    n = asm.n
    lo, _ = law.support
    a0 = math.floor((lo - math.radians(pre_deg)) / step + 1e-9) * step   # alpha = 0 is a node
    span = math.radians(require_positive('span_deg', span_deg))
    if span > 2 * math.pi + 1e-12:
        raise InputError('span_deg', span_deg, 'at most 360')
    count = int(math.ceil(span / step - 1e-9))
    alpha = a0 + step * np.arange(count + 1, dtype=np.float64)
    alpha[-1] = min(alpha[-1], a0 + span)
    t_out = (alpha - a0) / omega
    minv = 1.0 / asm.m
    hard = b.hard_seat
    if hard:
        raise InputError('valve_train.seat.restitution', b.restitution,
                         f'the penalty seat with method {method} (or method exact)')
    ks, bs = b.seat_stiffness, b.seat_damping

    cam_in = build_cam_input(law, k, 0.0, min(step, math.radians(0.5)),
                             pre=math.radians(pre_deg))
    cam = lift_of_time(cam_in, a0, omega)

    def forces(t: float, x: NDArray, xd: NDArray) -> tuple[NDArray, float, bool, bool, bool]:
        uc, ucd = cam(t)
        f = asm.preload - asm.k_lin @ x - asm.c_lin @ xd
        d = uc - x[T]
        fc = max(0.0, asm.k_c * d + asm.b_c * (ucd - xd[T])) if d > 0 else 0.0
        f[T] += fc
        d2 = x[R] - x[V] - b.lash
        frv = max(0.0, asm.k_rv * d2 + asm.b_rv * (xd[R] - xd[V])) if d2 > 0 else 0.0
        f[R] -= frv
        f[V] += frv
        seat = False
        if x[V] < 0:
            rs = -ks * x[V] - bs * xd[V]
            if rs > 0:
                f[V] += rs
                seat = True
        return f, fc, fc > 0, frv > 0, seat

    def rhs(t: float, s: NDArray) -> NDArray:
        x, xd = s[:n], s[n:]
        f = forces(t, x, xd)[0]
        return np.concatenate([xd, f * minv])

    def jac(t: float, s: NDArray) -> NDArray:
        x, xd = s[:n], s[n:]
        _, _, on_c, on_rv, seat = forces(t, x, xd)
        kk = asm.k_lin.copy()
        cc = asm.c_lin.copy()
        if on_c:
            kk[T, T] += asm.k_c
            cc[T, T] += asm.b_c
        if on_rv:
            for (i, j, sgn) in ((R, R, 1), (V, V, 1), (R, V, -1), (V, R, -1)):
                kk[i, j] += sgn * asm.k_rv
                cc[i, j] += sgn * asm.b_rv
        if seat:
            kk[V, V] += ks
            cc[V, V] += bs
        out = np.zeros((2 * n, 2 * n))
        out[:n, n:] = np.eye(n)
        out[n:, :n] = -kk * minv[:, None]
        out[n:, n:] = -cc * minv[:, None]
        return out

    x0 = _static(asm, mp, cam(0.0)[0])

    def crossing(t: float, s: NDArray) -> float:
        return float(s[V])

    sol = solve_ivp(rhs, (0.0, float(t_out[-1])), np.concatenate([x0, np.zeros(n)]),
                    method=method, rtol=rtol, atol=atol, jac=jac, t_eval=t_out,
                    events=crossing,
                    max_step=2 * math.pi * math.sqrt(min(asm.m[:4]) / max(mp.stiffness)) * 50)
    if not sol.success:
        raise RuntimeError(f'mdof integration failed: {sol.message}')
    x = sol.y[:n]
    xd = sol.y[n:]
    fc = np.array([forces(t, x[:, i], xd[:, i])[1] for i, t in enumerate(sol.t)])
    y = x[V]
    events = sampled_events(alpha, y, xd[V], fc, k * law(alpha) - b.lash)
    _seat_events(events, a0 + omega * sol.t_events[0], sol.y_events[0][:, n + V]
                 if sol.y_events[0].size else np.zeros(0), float(alpha[int(np.argmax(y))]))
    return MdofResult(alpha=alpha, y=y, v=xd[V], cam_force=k * fc,
                      natural_frequencies_hz=asm.natural_frequencies(),
                      surge_hz=asm.surge_hz, events=events, nfev=int(sol.nfev),
                      method=method, revolutions=1, periodic_residual=math.inf,
                      settled=False)


def _static(asm: MdofAssembly, mp: MdofParams, uc: float) -> NDArray[np.float64]:
    """Static equilibrium on the base circle (cam contact closed, lash open if any)."""
    b = mp.base
    n = asm.n
    for rv_closed in (False, True):
        kk = asm.k_lin.copy()
        f = asm.preload.copy()
        kk[T, T] += asm.k_c
        f[T] += asm.k_c * uc
        kk[V, V] += b.seat_stiffness
        if rv_closed:
            for (i, j, sgn) in ((R, R, 1), (V, V, 1), (R, V, -1), (V, R, -1)):
                kk[i, j] += sgn * asm.k_rv
            f[R] -= asm.k_rv * b.lash
            f[V] += asm.k_rv * b.lash
        x = np.asarray(np.linalg.solve(kk, f), dtype=np.float64)
        if rv_closed or x[R] - x[V] - b.lash <= 0:
            return x
    return np.zeros(n)


def _seat_events(events: dict, a_cross: NDArray, v_cross: NDArray, a_top: float) -> None:
    """Refine opening, closing, seating velocity and bounce count with the exact valve
    crossings of y = 0 located by solve_ivp (angles rad, velocities m/s)."""
    ups = [(a, v) for a, v in zip(a_cross.tolist(), v_cross.tolist()) if v > 0]
    downs = [(a, v) for a, v in zip(a_cross.tolist(), v_cross.tolist()) if v < 0]
    if ups:
        events['opening_deg'] = math.degrees(ups[0][0])
    after = [(a, v) for a, v in downs if a > a_top]
    if after:
        events['closing_deg'] = math.degrees(after[0][0])
        events['seating_velocity_m_s'] = -after[0][1]
        events['bounce_count'] = sum(1 for a, _ in ups if a > after[0][0])


def sampled_events(alpha: NDArray, y: NDArray, v: NDArray, fc: NDArray, u: NDArray) -> dict:
    """Opening/closing/separations/bounces from the sampled solution (grid accuracy).

    ``alpha`` cam angle [rad], ``y``/``v`` valve lift [m] and speed [m/s], ``fc`` contact
    force [N], ``u`` the cam's input lift [m]; angles in the result in degrees.
    """
    up = y > 0
    out: dict[str, Any] = {'opening_deg': None, 'closing_deg': None, 'separations': [],
                           'seating_velocity_m_s': None, 'bounce_count': 0,
                           'bounce_height_m': 0.0, 'jump': False}
    idx = np.nonzero(up)[0]
    if idx.size == 0:
        return out
    rises = np.nonzero(up[1:] & ~up[:-1])[0]    # y[k] <= 0 < y[k + 1]

    def lift_off(k: int) -> float:
        f = -y[k] / (y[k + 1] - y[k])
        return math.degrees(float(alpha[k] + f * (alpha[k + 1] - alpha[k])))

    if up[0]:
        # the window starts open: in a periodic state the open phase began at the last
        # lift-off of the window, one revolution earlier (the exact solvers' rule)
        i_open = 0
        if rises.size and alpha[-1] - alpha[0] > 2.0 * math.pi - 1e-9:
            out['opening_deg'] = lift_off(int(rises[-1])) - 360.0
    else:
        i_open = int(idx[0])
        out['opening_deg'] = lift_off(i_open - 1)
    i_top = int(np.argmax(y))
    down = np.nonzero(~up[i_top:])[0]
    if down.size:
        i_close = i_top + int(down[0])
        f = y[i_close - 1] / (y[i_close - 1] - y[i_close])
        out['closing_deg'] = math.degrees(float(alpha[i_close - 1] + f * (
            alpha[i_close] - alpha[i_close - 1])))
        out['seating_velocity_m_s'] = float(-(v[i_close - 1] + f * (v[i_close] - v[i_close - 1])))
        after = up[i_close:]
        rises = np.nonzero(after[1:] & ~after[:-1])[0]
        out['bounce_count'] = int(rises.size)
        out['bounce_height_m'] = float(max(0.0, np.max(y[i_close:])))
    else:
        i_close = y.size
    lost = (fc <= 0) & (u > 0)
    lost[:i_open] = False
    lost[i_close:] = False
    seps = []
    i = 0
    while i < lost.size:
        if lost[i]:
            j = i
            while j + 1 < lost.size and lost[j + 1]:
                j += 1
            seps.append([math.degrees(float(alpha[i])), math.degrees(float(alpha[j]))])
            i = j + 1
        else:
            i += 1
    out['separations'] = seps
    out['jump'] = bool(seps)
    return out
