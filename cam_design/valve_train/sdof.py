"""Single-DOF valve-train model (docs/dynamics.md, docs/contract.md ``sdof``), solved exactly.

Equation (valve side, SI): with u = k h(alpha) - x0, delta = u - y,
    M y'' = F_t + R_seat - F0 - c' y - b_v y'        (time derivatives)
    F_t    = max(0, c delta + b_t (du/dt - dy/dt))  if delta > 0 else 0
    R_seat = max(0, -k_s y - b_s dy/dt)             if y < 0 else 0   (penalty seat)
or, with ``restitution`` e, a hard seat: y >= 0, impact dy/dt -> -e dy/dt, the valve
held on the seat while the train force does not exceed F0.

Method. Between regime switches (cam contact on/off, seat contact on/off) the
equation is linear with constant coefficients, M y'' + B y' + K y = f(t), and the
forcing f = -F0 [+ c u + b_t du/dt] is a polynomial on each angle step (the degree-7
Hermite interpolant of u, see ``cam_input``). Each step is propagated exactly with the
matrix exponential of the system augmented by the polynomial basis (one ``expm`` per
regime and step length, cached), so stiffness (seat 1e11 N/m) costs no stability. The
switching functions (delta, F_t, y, R_seat) are checked at sub-nodes spaced at most
1/8 of the regime's fastest period, and a switch is located to machine precision on
the Taylor series of the exact local solution (bracketing, so the new regime starts
strictly inside its domain). The result is exact up to rounding and the Hermite
interpolation of h (O(step^8)); the step only sets the output grid.

Periodic state (``simulate_cam``): revolutions from the static state, then shooting
(Newton on the one-revolution map z -> P(z), Jacobian by forward differences), then
more revolutions as the fallback; every result says ``settled``, ``left_cam`` and
``unstable`` (docs/dynamics.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.cam_input import DEGREE, CamInput, build_cam_input, with_gas
from cam_design.valve_train.params import SdofParams, omega_of_rpm, require_step_deg

NB = DEGREE + 1
_FACT = np.array([math.factorial(j) for j in range(NB)], dtype=float)
_SUB = math.pi / 4.0          # max |lambda| * sub-step
_TAYLOR = 22                  # order of the local Taylor series ((pi/4)^22/22! ~ 1e-23)
_MAX_EVENTS = 20000
OPEN_TOL = 1e-6              # m: a lift-off is the opening once the valve rises this high
BOUNCE_TOL = 1e-9             # m: smallest bounce (height bound) that is counted
CONTACT, SEAT = 1, 2          # regime bits: cam contact, seat contact (held if hard seat)


def expm(g: NDArray) -> NDArray:
    """Matrix exponential of a small matrix: Taylor (order 18) with scaling and squaring.

    scipy.linalg.expm calls threaded LAPACK and costs milliseconds on 10x10 matrices
    under load; this costs ~30 us and is accurate to rounding for the balanced
    augmented matrices used here (norm scaled below 0.5 before the series).
    """
    norm = float(np.max(np.sum(np.abs(g), axis=0)))
    sq = max(0, int(math.ceil(math.log2(norm / 0.5)))) if norm > 0.5 else 0
    a = g / (2.0 ** sq)
    eye = np.eye(g.shape[0])
    e = eye + a / 18.0
    for n in range(17, 0, -1):
        e = eye + (a @ e) / n
    for _ in range(sq):
        e = e @ e
    return e


class SolverError(RuntimeError):
    """The solver could not finish (e.g. an endless chatter of events)."""


@dataclass
class Events:
    """Events of one revolution (angles in rad on the lobe's alpha axis)."""

    opening: float | None = None
    closing: float | None = None             # first seating
    seating_velocity: float | None = None    # m/s, > 0 downwards
    separations: list[list[float]] = field(default_factory=list)   # [start, end] rad
    recontact_velocities: list[float] = field(default_factory=list)  # m/s, u' - y'
    impacts: list[tuple[float, float]] = field(default_factory=list)  # (alpha, m/s) at seat
    bounce_count: int = 0
    bounce_height: float = 0.0               # m, largest lift after the first seating
    count: int = 0                           # number of regime switches


@dataclass
class SdofResult:
    """Solution on the step nodes of the last revolution simulated.

    alpha [rad], y [m], v = dy/dt [m/s], force = F_t [N] (valve side), regime flags,
    u [m] rigid lift; ``events``; ``revolutions`` simulated; ``periodic_residual``
    (max |change| of y [m] over the last revolution at its start node).
    """

    alpha: NDArray[np.float64]
    y: NDArray[np.float64]
    v: NDArray[np.float64]
    force: NDArray[np.float64]
    u: NDArray[np.float64]
    regime: NDArray[np.int64]
    uniform: NDArray[np.bool_]
    events: Events
    omega: float
    params: SdofParams
    revolutions: int
    periodic_residual: float
    settled: bool = False
    left_cam: bool = False
    shooting_iterations: int = 0
    unstable: bool = False

    @property
    def cam_force(self) -> NDArray[np.float64]:
        """Cam-follower contact force k F_t [N] (docs/dynamics.md)."""
        return self.params.rocker_ratio * self.force


class _Model:
    """Regime matrices, cached propagators and switching functions for one speed."""

    def __init__(self, p: SdofParams, omega: float) -> None:
        self.p = p
        self.omega = omega
        self.cache: dict[tuple[int, float, int], tuple[NDArray, NDArray]] = {}

    def coefs(self, r: int) -> tuple[float, float]:
        """(K, B) of regime r."""
        p = self.p
        k_ = p.spring_rate
        b_ = p.valve_damping
        if r & CONTACT:
            k_ += p.stiffness
            b_ += p.damping
        if r & SEAT and not p.hard_seat:
            k_ += p.seat_stiffness
            b_ += p.seat_damping
        return k_, b_

    def rho(self, r: int) -> float:
        """Largest |eigenvalue| [1/s] of regime r."""
        k_, b_ = self.coefs(r)
        m = self.p.mass
        disc = (b_ / (2 * m)) ** 2 - k_ / m
        if disc <= 0:
            return math.sqrt(k_ / m)
        return b_ / (2 * m) + math.sqrt(disc)

    def propagator(self, r: int, lt: float, m: int = 1) -> tuple[NDArray, NDArray]:
        """(Phi, Gamma) at the m sub-nodes j lt/m, j = 1..m, of a step of lt seconds.

        Phi: (m, 2, 2); Gamma: (m, 2, NB) maps the forcing coefficients in the basis
        sigma^j / j! (sigma = t / lt) to the state.
        """
        key = (r, lt, m)
        hit = self.cache.get(key)
        if hit is not None:
            return hit
        k_, b_ = self.coefs(r)
        M = self.p.mass
        # velocity scaled by rho keeps the augmented matrix balanced for expm
        rho = math.sqrt(k_ / M) if k_ > 0 else max(b_ / M, 1.0 / lt)
        g = np.zeros((2 + NB, 2 + NB))
        g[0, 1] = rho
        g[1, 0] = -k_ / M / rho
        g[1, 1] = -b_ / M
        g[1, 2] = 1.0 / (M * rho)
        for j in range(NB - 1):
            g[2 + j, 3 + j] = 1.0 / lt
        e1 = expm(g * (lt / m))
        phis = np.empty((m, 2, 2))
        gams = np.empty((m, 2, NB))
        e = e1
        for j in range(m):
            if j:
                e = e @ e1
            phis[j] = e[:2, :2]
            gams[j] = e[:2, 2:]
        phis[:, 0, 1] /= rho
        phis[:, 1, 0] *= rho
        gams[:, 1, :] *= rho
        if len(self.cache) > 4096:
            self.cache.clear()
        self.cache[key] = (phis, gams)
        return phis, gams

    def switch_map(self, r: int, lt: float, m: int) -> tuple[NDArray, NDArray]:
        """The switching components of ``_switch_jets`` for steps of lt seconds cut into
        m sub-intervals, as the affine map const + x @ lin of x = [y0 [m], v0 [m/s],
        u monomials (NB) [m], gas-force monomials (NB) [N]] (the equation is linear):
        lin (2 + 2 NB, 2 C (m+1)), const (2 C (m+1),). Built once per regime, step
        length and m by evaluating ``_switch_jets`` on the unit inputs, cached."""
        key = (-1 - r, lt, m)
        hit = self.cache.get(key)
        if hit is not None:
            return hit
        nx = 2 + 2 * NB
        basis = np.vstack([np.zeros(nx), np.eye(nx)])      # row 0: the constant part
        z0, ucoef, gco = basis[:, :2], basis[:, 2:2 + NB], basis[:, 2 + NB:]
        la = np.full(nx + 1, lt * self.omega)
        fco = self.forcing(r, ucoef, la, gco)
        phis, gams = self.propagator(r, lt, m)
        zs = np.einsum('mab,qb->qma', phis, z0) + np.einsum('mab,qb->qma', gams, fco)
        jets = _switch_jets(self, r, ucoef, fco, la, np.full(nx + 1, lt), z0, zs)
        jets = jets.transpose(1, 0, 2).reshape(nx + 1, -1)   # (1 + nx, 2 C (m+1))
        out = (jets[1:] - jets[0], jets[0].copy())
        self.cache[key] = out
        return out

    def forcing(self, r: int, ucoef: NDArray, la: NDArray | float,
                gco: NDArray | None = None) -> NDArray:
        """Forcing coefficients (..., NB) in the basis sigma^j/j! for regime r.

        ucoef: (..., NB) monomial coefficients of u(sigma); la: step angle(s) [rad];
        gco: monomials of an external force pushing the valve shut [N] (gas), or None.
        """
        p = self.p
        out = np.zeros(np.shape(ucoef))
        if r & CONTACT and not (r & SEAT and p.hard_seat):
            du = np.zeros(np.shape(ucoef))
            du[..., :-1] = ucoef[..., 1:] * np.arange(1, NB)
            rate = np.asarray(self.omega / np.asarray(la, dtype=float))[..., None]
            out = p.stiffness * ucoef + p.damping * rate * du
        out[..., 0] -= p.spring_preload
        if gco is not None:
            out = out - gco
        return out * _FACT


def _inside(model: _Model, r: int, y: Any, v: Any, u: Any, ud: Any) -> tuple[Any, Any]:
    """Switching functions (inside_C, inside_S) of regime r; the regime holds while
    both are >= 0. Works elementwise on arrays. ud = du/dt [m/s]."""
    p = model.p
    delta = u - y
    gc = p.stiffness * delta + p.damping * (ud - v)
    if isinstance(delta, float) and isinstance(gc, float):
        return _inside_scalar(p, r, y, v, u, ud, delta, gc)
    fc = np.minimum(delta, gc)
    in_c = fc if r & CONTACT else -fc
    if p.hard_seat:
        if r & SEAT:
            in_s = -np.minimum(u, p.stiffness * u + p.damping * ud - p.spring_preload)
            in_c = np.zeros_like(in_s) + 1.0
        else:
            in_s = y
    else:
        fs = np.minimum(-y, -p.seat_stiffness * y - p.seat_damping * v)
        in_s = fs if r & SEAT else -fs
    return in_c, in_s


_VANDER: dict[int, tuple[NDArray, NDArray]] = {}
_ARANGE = np.arange(64, dtype=float)
_GRID9 = np.linspace(0.0, 1.0, 33)
_VG9 = _GRID9[None, :] ** np.arange(64)[:, None]
_SCREEN: dict[int, tuple[NDArray, NDArray]] = {}


def _screen_grid(dense: int) -> tuple[NDArray, NDArray]:
    """(grid, VGD): 32 dense + 1 points on [0, 1] (``_GRID9`` for dense = 1) and the
    (64, 2 points) matrix of the monomials t^j and their derivatives j t^(j-1) there."""
    hit = _SCREEN.get(dense)
    if hit is None:
        grid = np.linspace(0.0, 1.0, 32 * dense + 1)
        vg = grid[None, :] ** _ARANGE[:, None]
        dvg = np.vstack([np.zeros((1, grid.size)), _ARANGE[1:, None] * vg[:-1]])
        hit = (grid, np.hstack([vg, dvg]))
        _SCREEN[dense] = hit
    return hit


def _horner2(c: NDArray, t: float) -> tuple[float, float]:
    """(p(t), p'(t)) of monomial coefficients c."""
    val = 0.0
    der = 0.0
    for x in c[::-1].tolist():
        der = der * t + val
        val = val * t + x
    return val, der


def _vander(m: int) -> tuple[NDArray, NDArray]:
    """(NB, m) matrices: coeffs @ V gives p(j/m), coeffs @ dV gives p'(j/m), j=1..m."""
    hit = _VANDER.get(m)
    if hit is None:
        sig = np.arange(1, m + 1) / m
        jj = np.arange(NB)[:, None]
        vand = sig[None, :] ** jj
        dvand = np.zeros_like(vand)
        dvand[1:] = jj[1:] * sig[None, :] ** (jj[1:] - 1)
        hit = (vand, dvand)
        if len(_VANDER) < 256:
            _VANDER[m] = hit
    return hit


def _vander0(m: int) -> tuple[NDArray, NDArray, NDArray]:
    """(NB, m+1) matrices giving p, p', p'' (sigma derivatives) at sigma = j/m, j=0..m."""
    sig = np.arange(m + 1) / m
    jj = np.arange(NB)[:, None]
    v0 = sig[None, :] ** jj
    v1 = np.zeros_like(v0)
    v1[1:] = jj[1:] * sig[None, :] ** (jj[1:] - 1)
    v2 = np.zeros_like(v0)
    v2[2:] = jj[2:] * (jj[2:] - 1) * sig[None, :] ** (jj[2:] - 2)
    return v0, v1, v2


def _dips(f: NDArray, d: NDArray) -> NDArray:
    """True on each interval where the cubic Hermite interpolant of values f and slopes
    d (per unit of the interval), shape (..., m+1), goes below 0 -> (..., m).

    Cheap bound first: the cubic departs from the chord by at most
    (4/27)(|m0 - D| + |m1 - D|), D = p1 - p0; the exact minimum is computed only where
    that bound does not settle the question."""
    p0, p1 = f[..., :-1], f[..., 1:]
    m0, m1 = d[..., :-1], d[..., 1:]
    lo = np.minimum(p0, p1)
    chord = p1 - p0
    dev = (4.0 / 27.0) * (np.abs(m0 - chord) + np.abs(m1 - chord))
    out = lo < 0
    unsure = ~out & (lo - dev < 0)
    if not np.any(unsure):
        return out
    q0, q1, n0, n1 = p0[unsure], p1[unsure], m0[unsure], m1[unsure]
    a3 = 2 * q0 + n0 - 2 * q1 + n1
    a2 = -3 * q0 - 2 * n0 + 3 * q1 - n1
    a1 = n0
    qa, qb, qc = 3 * a3, 2 * a2, a1
    disc = qb * qb - 4 * qa * qc
    low = np.minimum(q0, q1)
    with np.errstate(divide='ignore', invalid='ignore'):
        sq = np.sqrt(np.maximum(disc, 0.0))
        small = np.abs(qa) < 1e-300
        r1 = np.where(small, -qc / np.where(qb == 0, np.inf, qb), (-qb - sq) / (2 * qa))
        r2 = np.where(small, r1, (-qb + sq) / (2 * qa))
        for r in (r1, r2):
            ok = (disc >= 0) & np.isfinite(r) & (r > 0) & (r < 1)
            val = ((a3 * r + a2) * r + a1) * r + q0
            low = np.where(ok, np.minimum(low, val), low)
    out[unsure] = low < 0
    return out


_VANDER0: dict[int, tuple[NDArray, NDArray, NDArray]] = {}


def sub_node_jets(ucoef: NDArray, m: int, omega: float, la: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Cam input at the m + 1 sub-nodes j/m of each step: u [m], du/dt [m/s],
    d2u/dt2 [m/s^2] from its (q, NB) monomials ``ucoef`` over step angles ``la`` [rad] at
    ``omega`` [rad/s], and the value matrix (for other polynomials on the same nodes)."""
    mats = _VANDER0.get(m)
    if mats is None:
        mats = _vander0(m)
        if len(_VANDER0) < 256:
            _VANDER0[m] = mats
    v0, v1, v2 = mats
    rate = (omega / la)[:, None]
    return ucoef @ v0, (ucoef @ v1) * rate, (ucoef @ v2) * rate * rate, v0


def _switch_jets(model: '_Model', r: int, ucoef: NDArray, fco: NDArray, la: NDArray,
                 lt: NDArray, z0: NDArray, zs: NDArray) -> NDArray:
    """Switching components of regime r at the m + 1 sub-nodes j/m of each step, signed
    so that the regime ends where one goes below 0: (2 C, q, m+1), the C values then
    their time derivatives times the sub-step (per unit of the sub-interval).

    C = 4 (penalty seat: u - y, F_t, -y, seat force) or 3 (hard seat: u - y, F_t, y).
    ucoef, fco: (q, NB) u monomials [m] and forcing (sigma^j/j!) [N]; la, lt: (q,) step
    angle [rad] and time [s]; z0: (q, 2) start states; zs: (q, m, 2) sub-node states.
    """
    p = model.p
    m = zs.shape[1]
    u, ud, udd, v0 = sub_node_jets(ucoef, m, model.omega, la)
    f = (fco / _FACT) @ v0
    y = np.concatenate([z0[:, :1], zs[..., 0]], axis=1)
    v = np.concatenate([z0[:, 1:], zs[..., 1]], axis=1)
    k_, b_ = model.coefs(r)
    acc = (f - k_ * y - b_ * v) / p.mass
    h = (lt / m)[:, None]
    delta, ddelta = u - y, ud - v
    gc, dgc = p.stiffness * delta + p.damping * ddelta, p.stiffness * ddelta + p.damping * (
        udd - acc)
    sc = 1.0 if r & CONTACT else -1.0
    vals = [sc * delta, sc * gc]
    ders = [sc * ddelta * h, sc * dgc * h]
    if p.hard_seat:
        vals.append(y)
        ders.append(v * h)
    else:
        gs = -p.seat_stiffness * y - p.seat_damping * v
        dgs = -p.seat_stiffness * v - p.seat_damping * acc
        ss = 1.0 if r & SEAT else -1.0
        vals += [-ss * y, ss * gs]
        ders += [-ss * v * h, ss * dgs * h]
    return np.stack(vals + ders)


def _flags(model: '_Model', r: int, lt: float, m: int, z0: NDArray, ucoef: NDArray,
           gco: NDArray | None) -> NDArray:
    """(q, m) True where sub-interval j of step q may hold a switch: the switching
    components' cubic Hermite interpolants (values and time derivatives at the
    sub-nodes, from the exact states) cross zero in the direction that ends regime r.

    All q steps last lt seconds and are cut into m sub-intervals; z0: (q, 2) start
    states [m, m/s]; ucoef, gco: (q, NB) monomials of u [m] and of the gas force [N]
    (None: no gas). The components are the affine map ``_Model.switch_map`` of them.
    """
    lin, const = model.switch_map(r, lt, m)
    x = np.concatenate([z0, ucoef] if gco is None else [z0, ucoef, gco], axis=1)
    jets = (x @ lin[:x.shape[1]] + const).reshape(x.shape[0], -1, m + 1)
    nc = jets.shape[1] // 2
    dips = _dips(jets[:, :nc], jets[:, nc:])          # (q, C, m)
    # in a regime: leaves when a component dips; out of it: enters when all rise
    bad = dips[:, 0] | dips[:, 1] if r & CONTACT else dips[:, 0] & dips[:, 1]
    if model.p.hard_seat:
        return bad | dips[:, 2]
    return bad | (dips[:, 2] | dips[:, 3] if r & SEAT else dips[:, 2] & dips[:, 3])


def _screen_weights(p: SdofParams, ds: float) -> NDArray:
    """(C, 4) weights of the switching components (u - y, F_t, then -y and the seat force,
    or y for the hard seat) on [u - y, its t-derivative, y, its t-derivative], t = s / ds
    (ds [s])."""
    if p.hard_seat:
        return np.array([[1.0, 0.0, 0.0, 0.0], [p.stiffness, p.damping / ds, 0.0, 0.0],
                         [0.0, 0.0, 1.0, 0.0]])
    return np.array([[1.0, 0.0, 0.0, 0.0], [p.stiffness, p.damping / ds, 0.0, 0.0],
                     [0.0, 0.0, -1.0, 0.0], [0.0, 0.0, -p.seat_stiffness,
                                             -p.seat_damping / ds]])


def _inside_scalar(p: SdofParams, r: int, y: float, v: float, u: float, ud: float,
                   delta: float, gc: float) -> tuple[float, float]:
    """Scalar version of ``_inside`` (hot path of the root finder)."""
    fc = min(delta, gc)
    in_c = fc if r & CONTACT else -fc
    if p.hard_seat:
        if r & SEAT:
            return 1.0, -min(u, p.stiffness * u + p.damping * ud - p.spring_preload)
        return in_c, y
    fs = min(-y, -p.seat_stiffness * y - p.seat_damping * v)
    return in_c, (fs if r & SEAT else -fs)


_BINOM = np.array([[math.comb(j, n) for j in range(NB)] for n in range(NB)], dtype=float)
_POW = np.array([[j - n if j >= n else 0 for j in range(NB)] for n in range(NB)])


_SHIFT: dict[tuple[float, float], NDArray] = {}


def _shift(c: NDArray, a: float, w: float) -> NDArray:
    """Monomial coefficients of p(a + w t) from those of p(sigma) (last axis)."""
    if a == 0.0 and w == 1.0:
        return c
    mat = _SHIFT.get((a, w))
    if mat is None:
        mat = (_BINOM * np.power(a, _POW) * (w ** np.arange(NB))[:, None]).T
        if len(_SHIFT) < 4096:      # sub-step starts j/m and widths 1/m repeat
            _SHIFT[(a, w)] = mat
    return c @ mat


def _taylor(model: _Model, r: int, z: tuple[float, float], fcoef: NDArray,
            ds: float) -> NDArray:
    """Coefficients c_n of y(t) = sum c_n t^n, t = s/ds in [0, 1], exact solution.

    fcoef: monomial coefficients (in t) of the forcing f [N].
    """
    k_, b_ = model.coefs(r)
    M = model.p.mass
    f = fcoef.tolist() + [0.0] * (_TAYLOR + 1 - fcoef.size)
    c = [float(z[0]), float(z[1]) * ds]
    kk = k_ * ds * ds / M
    bb = b_ * ds / M
    fs = ds * ds / M
    for n in range(_TAYLOR - 1):
        c.append((f[n] * fs - kk * c[n] - bb * (n + 1) * c[n + 1]) / ((n + 2) * (n + 1)))
    return np.array(c)


def _eval_min(comp: tuple[float, list[list[float]]], t: float) -> tuple[float, float]:
    """sign * min_i P_i(t) and the derivative of the active P_i (Horner)."""
    sign, polys = comp
    best = math.inf
    dbest = 0.0
    for c in polys:
        val = der = 0.0
        for x in c:
            der = der * t + val
            val = val * t + x
        if val < best:
            best, dbest = val, der
    return sign * best, sign * dbest


def _poly_root(c: list[float], a: float, b: float, fa: float) -> float:
    """Root in [a, b] of the polynomial c (Horner order) changing sign there
    (safeguarded Newton from the secant point)."""
    def ev(t: float) -> tuple[float, float]:
        val = der = 0.0
        for x in c:
            der = der * t + val
            val = val * t + x
        return val, der

    fb = ev(b)[0]
    x = a - fa * (b - a) / (fb - fa) if fb != fa else 0.5 * (a + b)
    up = fb > fa
    for _ in range(60):
        if not a <= x <= b:
            x = 0.5 * (a + b)
        f, d = ev(x)
        if f == 0.0:
            return x
        if (f < 0) == up:
            a = x
        else:
            b = x
        xn = x - f / d if d != 0 else 0.5 * (a + b)
        if not a < xn < b:
            xn = 0.5 * (a + b)
        if abs(xn - x) < 1e-15 or b - a < 1e-15:
            return xn
        x = xn
    return 0.5 * (a + b)


def _newton_bracket(comp: tuple[float, list[list[float]]], a: float,
                    b: float) -> tuple[float, float]:
    """[a, b] with f(a) >= 0 > f(b), f = sign * min_i P_i, shrunk to ~1e-14.

    The components are smooth: each one's own root is found by Newton, and the switch
    is the first component root (sign +1: a component drops below 0) or the last one
    (sign -1: every component has become positive); bisection on f is the fallback.
    """
    sign, polys = comp
    roots = []
    for c in polys:
        pa = _eval_min((1.0, [c]), a)[0]
        pb = _eval_min((1.0, [c]), b)[0]
        if sign > 0 and pb < 0 <= pa:
            roots.append(_poly_root(c, a, b, pa))
        elif sign < 0 and pa <= 0 < pb:
            roots.append(_poly_root(c, a, b, pa))
    if roots:
        x = min(roots) if sign > 0 else max(roots)
        lo, hi = max(a, x - 1e-14), min(b, x + 1e-14)
        if _eval_min(comp, hi)[0] < 0 and _eval_min(comp, lo)[0] >= 0:
            return lo, hi
    for _ in range(200):           # fallback: bisection on f
        if b - a <= 1e-14:
            break
        m = 0.5 * (a + b)
        if _eval_min(comp, m)[0] >= 0:
            a = m
        else:
            b = m
    return a, b


def _bracket(fun: Any, a: float, b: float, fa: float, fb: float) -> tuple[float, float]:
    """Shrink [a, b] with fun(a) >= 0 > fun(b) to width ~1e-14 (Brent, then a check
    that the returned upper end is strictly past the switch)."""
    x = brentq(fun, a, b, xtol=1e-15, rtol=1e-15, maxiter=200)
    lo, hi = max(a, x - 1e-14), min(b, x + 1e-14)
    for _ in range(60):
        if fun(hi) < 0 or hi >= b:
            break
        hi = min(b, hi + 2 * (hi - x) + 1e-14)
    if fun(hi) >= 0:
        hi = b
    if fun(lo) < 0:
        lo = a
    return lo, hi


class _Run:
    """One simulation: state machine over the steps of a CamInput."""

    def __init__(self, model: _Model, cam: CamInput) -> None:
        self.model = model
        self.cam = cam
        self.lt = cam.lengths / model.omega
        self._groups()
        self.ev = Events()
        self.seated_once = False
        self.opened = False
        self.peak = 0.0            # largest node lift since the last lift-off [m]
        self.lift_off: float | None = None   # last lift-off not followed by a seating
        self.start_open = False    # the revolution starts inside an open phase
        self.next_cycle: list[list[float]] | None = None   # [start, end, u' - y']
        self.sep_open: list[float] | None = None
        self.stop_after_bounce = False
        self.hint: tuple[int, int, NDArray, NDArray] | None = None

    # -- regimes -----------------------------------------------------------------
    def initial(self) -> tuple[tuple[float, float], int]:
        """Static state on the base circle at the first node and its regime."""
        p = self.model.p
        u0 = float(self.cam.coeffs[0, 0])
        g0 = 0.0 if self.cam.gas is None else float(self.cam.gas[0, 0])
        if p.hard_seat:
            return (0.0, 0.0), SEAT
        for r in (SEAT, SEAT | CONTACT, 0, CONTACT):
            k_, _ = self.model.coefs(r)
            f = -p.spring_preload - g0 + (p.stiffness * u0 if r & CONTACT else 0.0)
            y = f / k_ if k_ > 0 else 0.0
            ic, is_ = _inside(self.model, r, y, 0.0, u0, 0.0)
            if ic >= 0 and is_ >= 0 and (r & CONTACT or u0 - y <= 0) and (
                    r & SEAT or y >= 0):
                return (y, 0.0), r
        raise SolverError('no consistent static state on the base circle')

    # -- bulk propagation ----------------------------------------------------------
    def _groups(self) -> None:
        """Steps of equal length share one propagator: group index per step."""
        uniq, inv = np.unique(self.lt, return_inverse=True)
        self.g_len = uniq.tolist()
        self.g_inv = inv
        self.g_invl = inv.tolist()
        self.g_run = np.concatenate([[0], np.cumsum(np.diff(inv) != 0)])  # changes so far
        self.g_props: dict[int, list[tuple[int, NDArray, NDArray, list[float]]]] = {}

    def _props(self, r: int) -> list[tuple[int, NDArray, NDArray, list[float]]]:
        """Per step-length group: (sub-nodes m, Phi, Gamma, end Phi as 4 floats)."""
        hit = self.g_props.get(r)
        if hit is None:
            rho = self.model.rho(r)
            hit = []
            for L in self.g_len:
                m = min(max(2, int(math.ceil(rho * L / _SUB))), 4096)
                phis, gams = self.model.propagator(r, L, m)
                hit.append((m, phis, gams, phis[-1].ravel().tolist()))
            self.g_props[r] = hit
        return hit

    def bulk(self, k0: int, z: tuple[float, float], r: int,
             n: int) -> tuple[int, NDArray, NDArray]:
        """Propagate steps k0..k0+n-1 in regime r; stop before the first step with a
        switch. Returns (number of clean steps, y and v at nodes k0+1..k0+clean).

        The linear recurrence runs in windows of growing size (16, 32, ...), each
        checked for switches at its sub-nodes before the next is propagated, so a
        switch early in a long stretch costs little waste."""
        model, cam = self.model, self.cam
        k1 = min(k0 + n, cam.lengths.size)
        q = k1 - k0
        la = cam.lengths[k0:k1]
        if model.p.hard_seat and r & SEAT:
            vand, dvand = _vander(4)
            uu = cam.coeffs[k0:k1] @ vand
            ud = (cam.coeffs[k0:k1] @ dvand) * (model.omega / la)[:, None]
            _, ins = _inside(model, r, 0.0, 0.0, uu, ud)
            bad = np.nonzero(np.any(ins < 0, axis=1))[0]
            clean = int(bad[0]) if bad.size else q
            return clean, np.zeros(clean), np.zeros(clean)
        fco = model.forcing(r, cam.coeffs[k0:k1], la,
                            None if cam.gas is None else cam.gas[k0:k1])
        props = self._props(r)
        inv = self.g_inv[k0:k1]
        invl = self.g_invl
        if self.g_run[k0] == self.g_run[k1 - 1]:
            wl = (fco @ props[invl[k0]][2][-1].T).tolist()
        else:
            w = np.empty((q, 2))
            for g in np.unique(inv).tolist():
                idx = np.nonzero(inv == g)[0]
                w[idx] = fco[idx] @ props[g][2][-1].T
            wl = w.tolist()
        y, v = z
        yl = [y]
        vl = [v]
        pos, win = 0, 32
        clean = q
        while pos < q:
            hi = min(q, pos + win)
            one_group = self.g_run[k0 + pos] == self.g_run[k0 + hi - 1]
            a, b, c, d = props[invl[k0 + pos]][3]
            for i in range(pos, hi):
                if not one_group:
                    a, b, c, d = props[invl[k0 + i]][3]
                wy, wv = wl[i]
                y, v = a * y + b * v + wy, c * y + d * v + wv
                yl.append(y)
                vl.append(v)
            if not (math.isfinite(y) and math.isfinite(v)):
                raise SolverError('non-finite state in bulk propagation')
            ys = np.asarray(yl[pos:hi])
            vs = np.asarray(vl[pos:hi])
            if one_group:
                parts = [(invl[k0 + pos], None)]
            else:
                gw = inv[pos:hi]
                parts = [(g, np.nonzero(gw == g)[0]) for g in np.unique(gw).tolist()]
            for g, sub in parts:
                m, phis, gams, _ = props[g]
                if sub is None:
                    idx = np.arange(pos, hi)
                    z0 = np.stack([ys, vs], axis=1)
                else:
                    idx = pos + sub
                    z0 = np.stack([ys[sub], vs[sub]], axis=1)       # (q, 2)
                flags = _flags(model, r, self.g_len[g], m, z0, cam.coeffs[k0 + idx],
                               None if cam.gas is None else cam.gas[k0 + idx])
                bad = np.nonzero(np.any(flags, axis=1))[0]
                if bad.size and int(idx[bad[0]]) < clean:
                    clean = int(idx[bad[0]])
                    # hand the sub-node states and flags of that step to event_step
                    zs = phis @ z0[bad[0]] + gams @ fco[clean]
                    self.hint = (k0 + clean, r, zs, flags[bad[0]].copy())
            if clean < q:
                break
            pos = hi
            win *= 4
        return clean, np.asarray(yl[1:clean + 1]), np.asarray(vl[1:clean + 1])

    # -- one step with events --------------------------------------------------------
    def event_step(self, k: int, z: tuple[float, float],
                   r: int) -> tuple[tuple[float, float], int]:
        """Integrate step k from node k to node k+1, handling every switch inside.

        The step is covered by segments [s0, s0 + w] (fractions of the step), each cut
        into ``pieces`` sub-intervals on which the local Taylor series locates a switch:
        from a node of the step's sub-grid in regime r (m_step sub-intervals, the step
        start or a node reached after a switch) the step's cached propagator gives the
        sub-node states and the switch flags of the rest of the step; after a switch, a
        short rest (m <= 4) is chained with Taylor pieces, a longer one is taken with one
        Taylor piece up to the next sub-grid node, then from there as above."""
        model, cam = self.model, self.cam
        p = model.p
        s0 = 0.0
        node: int | None = 0          # s0 = node / m_step of regime r's sub-grid
        la_step = float(cam.lengths[k])
        lt_step = float(self.lt[k])
        while True:
            if 1.0 - s0 <= 1e-15:
                return z, r
            if p.hard_seat and r & SEAT:
                w = 1.0 - s0
                hit = self._held_exit(_shift(cam.coeffs[k], s0, w), la_step * w)
                if hit is None:
                    return (0.0, 0.0), r
                s0 += w * hit
                r = self._after_held(s0, k)
                z, node = (0.0, 0.0), None
                continue
            m_step = self._props(r)[self.g_invl[k]][0]
            need = int(math.ceil(model.rho(r) * lt_step * (1.0 - s0) / _SUB))
            m = min(max(2, need), 4096)
            zs, used, dense, upto = None, 1, 1, None
            if node is None and m <= 4:   # short rest: chain the Taylor series over
                w = 1.0 - s0              # max(1, need) pieces, screened as finely as m
                pieces = max(1, need)
                dense = m // pieces
            elif node is None:            # one Taylor piece up to the next sub-grid node
                upto = min(m_step, int(s0 * m_step) + 1)
                w, pieces = upto / m_step - s0, 1
            else:                         # from a sub-grid node: the step's propagator
                w, pieces, used = 1.0, m_step, m_step - node
            uco = _shift(cam.coeffs[k], s0, w)
            gco = None if cam.gas is None else _shift(cam.gas[k], s0, w)
            fco = model.forcing(r, uco, la_step * w, gco)
            if node is None:
                todo: Any = range(pieces)
            elif node == 0 and self.hint is not None and self.hint[:2] == (k, r) and \
                    self.hint[2].shape[0] == m_step:
                zs, todo = self.hint[2], np.nonzero(self.hint[3])[0].tolist()
            else:
                phis, gams = model.propagator(r, lt_step, m_step)
                zs = phis[:used] @ np.asarray(z) + gams[:used] @ fco         # (used, 2)
                flags = _flags(model, r, lt_step, m_step, np.asarray(z)[None, :],
                               uco[None, :], None if gco is None else gco[None, :])[0]
                todo = np.nonzero(flags[:used])[0].tolist()
            ds = lt_step * w / pieces
            found = None
            z_start = z
            for j in todo:
                if zs is not None:
                    z = z_start if j == 0 else (float(zs[j - 1, 0]), float(zs[j - 1, 1]))
                f_loc = _shift(fco / _FACT, j / pieces, 1.0 / pieces)
                u_loc = _shift(uco, j / pieces, 1.0 / pieces)
                cy = _taylor(model, r, z, f_loc, ds)
                hit = self._first_switch(r, cy, u_loc, ds, dense)
                if hit is not None:
                    found = (j, hit[1], hit[2], cy, u_loc)
                    break
                z = (float(np.sum(cy)), float(cy[1:] @ _ARANGE[1:cy.size]) / ds)
            if found is None:
                if zs is not None:
                    z = (float(zs[used - 1, 0]), float(zs[used - 1, 1]))
                if not (math.isfinite(z[0]) and math.isfinite(z[1])):
                    raise SolverError('non-finite state')
                if upto is None or upto == m_step:
                    return z, r
                s0, node = upto / m_step, upto
                continue
            j, t_out, which, cy, u_loc = found
            ye, ve = _horner2(cy, t_out)
            uu, ud = _horner2(u_loc, t_out)
            ve /= ds
            ud /= ds
            s0 = s0 + w * (j + t_out) / pieces
            node = None
            alpha = float(cam.nodes[k] + la_step * s0)
            z, r = self.switch(r, which, alpha, (ye, ve), uu, ud)
            self.ev.count += 1
            if self.ev.count > _MAX_EVENTS:
                raise SolverError(f'more than {_MAX_EVENTS} regime switches (chatter)')

    def _held_exit(self, uco: NDArray, la: float) -> float | None:
        """First sigma in (0, 1] where a held (hard-seat) valve starts to open."""
        model = self.model
        pol = np.polynomial.polynomial
        dco = pol.polyder(uco)

        def fun(s: float) -> float:
            u = pol.polyval(s, uco)
            ud = pol.polyval(s, dco) * model.omega / la
            return float(_inside(model, SEAT, 0.0, 0.0, u, ud)[1])

        grid = np.linspace(0.0, 1.0, 17)
        vals = [fun(s) for s in grid]
        for i in range(1, grid.size):
            if vals[i] < 0:
                if vals[i - 1] < 0:
                    return float(grid[i - 1])
                _, b = _bracket(fun, grid[i - 1], grid[i], vals[i - 1], vals[i])
                return b
        return None

    def _after_held(self, s: float, k: int) -> int:
        """Regime right after a held valve lifts off (records the opening)."""
        alpha = float(self.cam.nodes[k] + self.cam.lengths[k] * s)
        self._reopen(alpha)
        return CONTACT

    def _reopen(self, alpha: float, v_up: float = math.inf) -> None:
        """Lift-off at ``alpha`` with velocity ``v_up`` [m/s]: the opening, or a bounce
        if after the first seating and its free-flight height bound M v^2 / (2 F0)
        reaches ``BOUNCE_TOL`` (reopenings of 1e-10 m on the penalty seat at crawl
        speed are not reported as bounces)."""
        self.peak = 0.0
        self.lift_off = alpha
        if self.start_open and self.seated_once:
            self.next_cycle = []    # an open phase of the next cycle may start here
        if not self.opened:
            self.opened = True
            self.ev.opening = alpha
        elif self.seated_once:
            p = self.model.p
            height = (p.mass * v_up * v_up / (2 * p.spring_preload)
                      if p.spring_preload > 0 else math.inf)
            if height >= BOUNCE_TOL:
                self.ev.bounce_count += 1

    def _first_switch(self, r: int, cy: NDArray, u_loc: NDArray, ds: float,
                      dense: int = 1) -> tuple[float, float, int] | None:
        """(t_in, t_out, which) of the first switch on [0, 1]; which: CONTACT|SEAT.

        cy: Taylor coefficients of y [m] in t = s / ds (``_taylor``); u_loc: monomials
        of u [m] in t; ds: length of the piece [s]. The switching functions are
        screened on 32 dense + 1 grid points first (one product for values and
        t-derivatives of u - y and y); the component polynomials are built only when
        one dips there."""
        p = self.model.p
        n = max(cy.size, u_loc.size)
        two = np.zeros((2, n))                 # monomials of u - y and of y
        two[0, :u_loc.size] = u_loc
        two[0, :cy.size] -= cy
        two[1, :cy.size] = cy
        grid, vgd = _screen_grid(dense)
        weights = _screen_weights(p, ds)       # the switching components, defined once
        # rows: u - y, d(u - y)/dt, y, dy/dt (t-derivatives) on the grid -> components
        scr = weights @ (two @ vgd[:n]).reshape(4, grid.size)
        low = np.minimum(scr[0], scr[1])
        bad = low < 0 if r & CONTACT else low > 0   # leaves (enters) contact
        if p.hard_seat:
            bad |= scr[2] < 0
        else:
            low = np.minimum(scr[2], scr[3])
            bad |= low < 0 if r & SEAT else low > 0
        bad[0] = False
        if not bad.any():
            return None
        sc = 1.0 if r & CONTACT else -1.0
        dt = np.zeros((2, n))                  # monomials of their t-derivatives
        dt[:, :-1] = two[:, 1:] * _ARANGE[1:n]
        # the component polynomials: the same weights on the monomials
        rows = weights @ np.stack([two[0], dt[0], two[1], dt[1]])
        rl = rows[:, ::-1].tolist()
        comps = [(sc, rl[:2])]
        if p.hard_seat:
            comps.append((1.0, rl[2:]))
        else:
            comps.append((1.0 if r & SEAT else -1.0, rl[2:]))

        def scalar(t: float, pos: int) -> float:
            sign, polys = comps[pos]
            best = math.inf
            for c in polys:
                acc = 0.0
                for x in c:
                    acc = acc * t + x
                if acc < best:
                    best = acc
            return sign * best

        i = int(np.argmax(bad))
        a, b = float(grid[i - 1]), float(grid[i])
        best = None
        for which, pos in ((CONTACT, 0), (SEAT, 1)):
            fa, fb = scalar(a, pos), scalar(b, pos)
            if fb < 0 <= fa:
                ta, tb = _newton_bracket(comps[pos], a, b)
            elif fb < 0 and fa < 0:
                ta, tb = a, a
            else:
                continue
            if best is None or tb < best[1]:
                best = (ta, tb, which)
        return best

    def switch(self, r: int, which: int, alpha: float, z: tuple[float, float],
               u: float, ud: float) -> tuple[tuple[float, float], int]:
        """Apply a switch of ``which`` at ``alpha``; record events; new (state, regime)."""
        p = self.model.p
        y, v = z
        ev = self.ev
        if which == CONTACT:
            if r & CONTACT:       # contact lost
                if self.opened and not self.seated_once and u > 0:
                    self.sep_open = [alpha, alpha]
                elif self.next_cycle is not None and u > 0:
                    self.next_cycle.append([alpha, alpha, math.nan])
                return z, r & ~CONTACT
            if self.sep_open is not None:    # contact regained after a separation
                self.sep_open[1] = alpha
                ev.separations.append(self.sep_open)
                ev.recontact_velocities.append(ud - v)
                self.sep_open = None
            elif self.next_cycle and math.isnan(self.next_cycle[-1][2]):
                self.next_cycle[-1][1:] = [alpha, ud - v]
            return z, r | CONTACT
        # seat
        if p.hard_seat:
            # impact (r has no SEAT here: held exits are handled separately)
            self._seat(alpha, -v)
            ev.impacts.append((alpha, -v))
            v_new = -p.restitution * v
            if v_new <= 1e-9:
                held_inside = _inside(self.model, SEAT, 0.0, 0.0, u, ud)[1]
                if held_inside >= 0:
                    return (0.0, 0.0), SEAT
                return (0.0, 0.0), r
            self._reopen(alpha, v_new)
            return (0.0, v_new), r
        if r & SEAT:            # leaves the seat
            self._reopen(alpha, v)
            return z, r & ~SEAT
        self._seat(alpha, -v)
        ev.impacts.append((alpha, -v))
        return z, r | SEAT

    def commit_next_cycle(self, alpha: float) -> None:
        """A periodic revolution that starts inside an open phase (the valve lands
        after the window start) holds the next cycle's open phase after its closing:
        its separations are this orbit's too (they were recorded in ``next_cycle``
        since the last lift-off) when the valve rose OPEN_TOL in it."""
        cyc, self.next_cycle = self.next_cycle, None
        if not cyc or self.peak < OPEN_TOL:
            return
        for a0, a1, vrel in cyc:
            self.ev.separations.append([a0, alpha if math.isnan(vrel) else a1])
            if not math.isnan(vrel):
                self.ev.recontact_velocities.append(vrel)

    def _seat(self, alpha: float, vdown: float) -> None:
        self.lift_off = None
        if self.next_cycle is not None:
            self.commit_next_cycle(alpha)
        if self.opened and not self.seated_once and self.peak < OPEN_TOL:
            # the valve never rose OPEN_TOL since it left the seat: seat chatter (or the
            # end of a bounce that was still in the air at the window start), not an
            # opening and closing
            self.opened = False
            self.ev.opening = None
            self.sep_open = None
            return
        if self.opened and not self.seated_once:
            self.seated_once = True
            self.ev.closing = alpha
            self.ev.seating_velocity = vdown
            if self.sep_open is not None:
                self.sep_open[1] = alpha
                self.ev.separations.append(self.sep_open)
                self.sep_open = None

    # -- driver ------------------------------------------------------------------
    def revolution(self, z: tuple[float, float],
                   r: int) -> tuple[NDArray, NDArray, NDArray, tuple[float, float], int]:
        """One revolution from node 0; returns node arrays y, v, regime and end state."""
        n = self.cam.lengths.size
        ys = np.empty(n + 1)
        vs = np.empty(n + 1)
        rs = np.empty(n + 1, dtype=np.int64)
        ys[0], vs[0], rs[0] = z[0], z[1], r
        k = 0
        chunk = 64      # steps asked of bulk: small after a switch (switches cluster)
        while k < n:
            if self.stop_after_bounce and self.seated_once and len(self.ev.impacts) >= 2:
                ys[k + 1:], vs[k + 1:], rs[k + 1:] = np.nan, np.nan, -1
                break
            want = min(chunk, n - k)
            clean, yb, vb = self.bulk(k, z, r, want)
            if clean:
                ys[k + 1:k + 1 + clean] = yb
                vs[k + 1:k + 1 + clean] = vb
                rs[k + 1:k + 1 + clean] = r
                z = (float(yb[-1]), float(vb[-1]))
                k += clean
                self.peak = max(self.peak, float(yb.max()))
            if k >= n:
                break
            if clean == want:
                chunk = min(4 * chunk, 4096)
                continue
            chunk = 64
            z, r = self.event_step(k, z, r)
            k += 1
            ys[k], vs[k], rs[k] = z[0], z[1], r
            self.peak = max(self.peak, z[0])
        return ys, vs, rs, z, r


def simulate(law: LiftLaw, params: SdofParams, rpm: float, *, step_deg: float = 0.1,
             max_revolutions: int = 4, periodic_tol: float = 1e-10,
             key: str = 'lift', gas: Any = None) -> SdofResult:
    """Simulate the valve at ``rpm`` (camshaft) until periodic; solution of the last
    revolution on nodes every ``step_deg`` (plus the law's junctions).

    Periodic steady state: revolutions are repeated (at most ``max_revolutions``)
    until the state at the start node repeats within ``periodic_tol`` m (and the
    velocity within periodic_tol * omega_n). A reopening after the first seating counts
    as a bounce when its free-flight height bound M v^2/(2 F0) is >= BOUNCE_TOL (1e-9 m);
    ``bounce_height`` is the largest lift after the first seating, sampled at the nodes.
    ``gas(alpha)`` [N]: a force on the valve that pushes it shut (cylinder gas on an
    exhaust valve), as a function of cam angle [rad]; penalty seat only.
    """
    if not isinstance(law, LiftLaw):
        raise InputError('lift', type(law).__name__, 'a cam_design LiftLaw')
    omega = omega_of_rpm(rpm)
    step = math.radians(require_step_deg('step_deg', step_deg))
    if int(max_revolutions) < 1:
        raise InputError('max_revolutions', max_revolutions, 'an integer >= 1')
    cam = build_cam_input(law, params.rocker_ratio, params.lash, step, key=key)
    if gas is not None:
        cam = with_gas(cam, gas)
    return simulate_cam(cam, params, omega, max_revolutions=int(max_revolutions),
                        periodic_tol=periodic_tol)


def _regime_of(run: '_Run', z: tuple[float, float], prefer: int) -> int:
    """A regime consistent with state ``z`` at node 0 (``prefer`` if it is)."""
    model, cam = run.model, run.cam
    u0 = float(cam.coeffs[0, 0])
    ud0 = float(cam.coeffs[0, 1] / cam.lengths[0]) * model.omega
    order = [prefer] + [r for r in (SEAT, SEAT | CONTACT, CONTACT, 0) if r != prefer]
    for r in order:
        if model.p.hard_seat and r & SEAT and (z[0] != 0.0 or z[1] != 0.0):
            continue
        ic, is_ = _inside(model, r, float(z[0]), float(z[1]), u0, ud0)
        if ic >= 0 and is_ >= 0:
            return r
    return prefer


@dataclass
class _Shot:
    """One revolution from a given start state."""

    run: '_Run'
    ys: NDArray
    vs: NDArray
    rs: NDArray
    z0: tuple[float, float]
    r0: int
    z: tuple[float, float]
    r: int


def _one_rev(model: _Model, cam: CamInput, z0: tuple[float, float], r0: int,
             events_only: bool = False, first: bool = False) -> _Shot:
    run = _Run(model, cam)
    run.stop_after_bounce = events_only
    if not first and not (r0 & SEAT) and z0[0] > BOUNCE_TOL:
        # a periodic start off the seat: the valve is in the air, already open (a lobe
        # over the whole revolution, a valve still bouncing or flying from the last
        # lobe); if it lands without rising OPEN_TOL it was a bounce ending (``_seat``)
        run.opened = True
        run.start_open = True
        run.peak = float(z0[0])
    ys, vs, rs, z, r = run.revolution(z0, r0)
    if run.next_cycle is not None:       # the next open phase runs past the window end
        run.commit_next_cycle(float(cam.nodes[-1]))
    if run.start_open and run.ev.opening is None and run.lift_off is not None:
        # the open phase at the window start is the one running over the window end
        # (periodic state): its lift-off, one revolution earlier, is the opening (as MDOF)
        run.ev.opening = run.lift_off - 2.0 * math.pi
    return _Shot(run, ys, vs, rs, z0, r0, z, r)


#: m: target of the shooting (the one-revolution map is satisfied to this)
SHOOT_TOL = 1e-13


def simulate_cam(cam: CamInput, params: SdofParams, omega: float, *,
                 max_revolutions: int = 4, periodic_tol: float = 1e-10,
                 events_only: bool = False, shooting: bool = True) -> SdofResult:
    """``simulate`` on a prepared CamInput (reuse it across speeds).

    Periodic state: revolutions from the static state on the base circle; when two
    successive start states differ by more than ``periodic_tol`` (m; velocity scaled by
    1/omega_n), Newton's method on the one-revolution map z -> P(z) (shooting, Jacobian
    by forward differences: the map is piecewise linear in z between switch-time
    changes), then repeated revolutions up to ``max_revolutions`` more as the fallback.
    ``settled`` says whether the final revolution starts and ends in the same state
    within ``periodic_tol``; ``left_cam`` whether the valve ends the revolution in free
    flight off cam and seat or rises far above the rigid lift (it no longer follows).

    ``events_only`` (legacy): one revolution from rest, stopped at the end of the first
    bounce; later nodes are NaN (regime -1); never ``settled``.
    """
    if cam.gas is not None and params.hard_seat:
        raise InputError('valve_train.gas', 'with a hard seat',
                         'the penalty seat (the hard seat does not take a gas force yet)')
    model = _Model(params, omega)
    wn = math.sqrt((params.stiffness + params.spring_rate) / params.mass)
    run = _Run(model, cam)
    z0, r0 = run.initial()

    def resid(sh: _Shot) -> float:
        return max(abs(sh.z[0] - sh.z0[0]), abs(sh.z[1] - sh.z0[1]) / wn)

    umax = float(np.max(cam.coeffs[:, 0]))

    def runaway(sh: _Shot) -> bool:
        """The valve has left the cam: far above the rigid lift, or in free flight
        well above the seat at the end of the revolution."""
        in_air = not (sh.r & (CONTACT | SEAT)) and sh.z[0] > max(1e-6, 0.05 * umax)
        return in_air or float(np.nanmax(sh.ys)) > 1.5 * umax + 1e-4

    shot = _one_rev(model, cam, z0, r0, events_only, first=True)
    revs = 1
    iters = 0
    unstable = False
    if not events_only and (resid(shot) > periodic_tol or shot.r != r0):
        shot = _one_rev(model, cam, shot.z, shot.r)
        revs += 1
        gone = runaway(shot)     # no periodic state to look for: it is what it is
        if resid(shot) > periodic_tol and shooting and not gone:
            shot_n, n_rev, iters, radius = _shoot(model, cam, shot, wn, resid)
            revs += n_rev
            unstable = radius > 1.0 + 1e-6 and resid(shot_n) <= periodic_tol
            if not unstable:
                shot = shot_n
            # an unstable periodic orbit is not what the valve does: keep the physical
            # trajectory (repeated revolutions below) and report it as not settled
    if not events_only and not runaway(shot):
        extra = 0
        while resid(shot) > periodic_tol and extra < max_revolutions:
            shot = _one_rev(model, cam, shot.z, shot.r)
            revs += 1
            extra += 1
    residual = resid(shot) if not events_only else math.inf
    ys, vs, rs, run = shot.ys, shot.vs, shot.rs, shot.run
    u = np.concatenate([cam.coeffs[:, 0], [np.sum(cam.coeffs[-1])]])
    du = np.concatenate([cam.coeffs[:, 1] / cam.lengths,
                         [np.sum(cam.coeffs[-1, 1:] * np.arange(1, NB)) / cam.lengths[-1]]])
    ud = du * omega
    p = params
    delta = u - ys
    ft = np.where((rs & CONTACT) > 0,
                  np.maximum(0.0, p.stiffness * delta + p.damping * (ud - vs)), 0.0)
    if p.hard_seat:
        held = (rs & SEAT) > 0
        ft = np.where(held, np.where(u > 0, np.maximum(0.0, p.stiffness * u + p.damping * ud),
                                     0.0), ft)
    ev = run.ev
    if ev.closing is not None:
        after = np.zeros(cam.nodes.size, dtype=bool)
        after[cam.nodes > ev.closing] = True
        ev.bounce_height = float(max(0.0, np.nanmax(ys[after], initial=0.0)))
    settled = bool(residual <= periodic_tol) and not unstable
    left = bool(not events_only and runaway(shot))
    return SdofResult(alpha=cam.nodes.copy(), y=ys, v=vs, force=ft, u=u, regime=rs,
                      uniform=cam.uniform.copy(), events=ev, omega=omega, params=params,
                      revolutions=revs, periodic_residual=float(residual),
                      settled=settled, left_cam=left, shooting_iterations=iters,
                      unstable=unstable)


def _shoot(model: _Model, cam: CamInput, shot: _Shot, wn: float,
           resid: Any, max_iter: int = 8) -> tuple[_Shot, int, int, float]:
    """Newton on F(z) = P(z) - z from ``shot`` (the last revolution). Returns the
    best revolution found, revolutions simulated, Newton iterations and the spectral
    radius of the map's Jacobian dP/dz (> 1: an unstable periodic orbit, which
    repeated revolutions would never reach)."""
    best = shot
    revs = 0
    radius = math.nan
    scale = np.array([1.0, wn])       # work in (y, v / wn): both in m
    for it in range(1, max_iter + 1):
        z = np.array(best.z0, dtype=float)
        r = best.r0
        f0 = (np.array(best.z) - z) / scale
        jac = np.empty((2, 2))
        for j in range(2):       # forward differences: the map is affine piecewise
            hs = max(1e-9, 1e-6 * float(np.max(np.abs(f0))))     # scaled step [m]
            zp = z.copy()
            zp[j] += hs * scale[j]
            sp = _one_rev(model, cam, tuple(zp), _regime_of(best.run, tuple(zp), r))
            revs += 1
            fp = (np.array(sp.z) - zp) / scale
            jac[:, j] = (fp - f0) / hs
        if np.all(np.isfinite(jac)):
            radius = float(np.max(np.abs(np.linalg.eigvals(jac + np.eye(2)))))
        try:
            dz = -np.linalg.solve(jac, f0) * scale
        except np.linalg.LinAlgError:
            return best, revs, it, radius
        if not np.all(np.isfinite(dz)):
            return best, revs, it, radius
        lam = 1.0
        trial = best
        while lam > 0.05:                   # damped Newton
            znew = z + lam * dz
            trial = _one_rev(model, cam, tuple(znew), _regime_of(best.run, tuple(znew), r))
            revs += 1
            if resid(trial) < resid(best):
                break
            lam *= 0.5
        if resid(trial) >= resid(best):
            return best, revs, it, radius
        slow = it >= 2 and resid(trial) > 0.3 * resid(best)
        best = trial
        if slow:            # no Newton convergence (chaotic or non-smooth map): give up
            return best, revs, it, radius
        if resid(best) <= SHOOT_TOL:
            return best, revs, it, radius
    return best, revs, max_iter, radius
