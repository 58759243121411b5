"""Regimes of the single-DOF valve train (``sdof``): the linear system of each
regime (cam contact on/off, seat contact on/off), its cached exact propagators, the
switching functions and their screening and Taylor expansion (docs/dynamics.md)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.valve_train.params import SdofParams
from cam_design.valve_train.propagate import FACT, NB, dips, expm, sub_node_jets

SUB = math.pi / 4.0           # max |lambda| * sub-step
TAYLOR = 22                   # order of the local Taylor series ((pi/4)^22/22! ~ 1e-23)
CONTACT, SEAT = 1, 2          # regime bits: cam contact, seat contact (held if hard seat)


class SdofModel:
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
        """The switching components of ``switch_jets`` for steps of lt seconds cut into
        m sub-intervals, as the affine map const + x @ lin of x = [y0 [m], v0 [m/s],
        u monomials (NB) [m], gas-force monomials (NB) [N]] (the equation is linear):
        lin (2 + 2 NB, 2 C (m+1)), const (2 C (m+1),). Built once per regime, step
        length and m by evaluating ``switch_jets`` on the unit inputs, cached."""
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
        jets = switch_jets(self, r, ucoef, fco, la, np.full(nx + 1, lt), z0, zs)
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
        return out * FACT


def inside(model: SdofModel, r: int, y: Any, v: Any, u: Any, ud: Any) -> tuple[Any, Any]:
    """Switching functions (inside_C, inside_S) of regime r; the regime holds while
    both are >= 0. Works elementwise on arrays. ud = du/dt [m/s]."""
    p = model.p
    delta = u - y
    gc = p.stiffness * delta + p.damping * (ud - v)
    if isinstance(delta, float) and isinstance(gc, float):
        return inside_scalar(p, r, y, v, u, ud, delta, gc)
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


def switch_jets(model: SdofModel, r: int, ucoef: NDArray, fco: NDArray, la: NDArray,
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
    f = (fco / FACT) @ v0
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


def switch_flags(model: SdofModel, r: int, lt: float, m: int, z0: NDArray,
                 ucoef: NDArray, gco: NDArray | None) -> NDArray:
    """(q, m) True where sub-interval j of step q may hold a switch: the switching
    components' cubic Hermite interpolants (values and time derivatives at the
    sub-nodes, from the exact states) cross zero in the direction that ends regime r.

    All q steps last lt seconds and are cut into m sub-intervals; z0: (q, 2) start
    states [m, m/s]; ucoef, gco: (q, NB) monomials of u [m] and of the gas force [N]
    (None: no gas). The components are the affine map ``SdofModel.switch_map`` of them.
    """
    lin, const = model.switch_map(r, lt, m)
    x = np.concatenate([z0, ucoef] if gco is None else [z0, ucoef, gco], axis=1)
    jets = (x @ lin[:x.shape[1]] + const).reshape(x.shape[0], -1, m + 1)
    nc = jets.shape[1] // 2
    dipped = dips(jets[:, :nc], jets[:, nc:])          # (q, C, m)
    # in a regime: leaves when a component dips; out of it: enters when all rise
    bad = dipped[:, 0] | dipped[:, 1] if r & CONTACT else dipped[:, 0] & dipped[:, 1]
    if model.p.hard_seat:
        return bad | dipped[:, 2]
    return bad | (dipped[:, 2] | dipped[:, 3] if r & SEAT else dipped[:, 2] & dipped[:, 3])


def screen_weights(p: SdofParams, ds: float) -> NDArray:
    """(C, 4) weights of the switching components (u - y, F_t, then -y and the seat force,
    or y for the hard seat) on [u - y, its t-derivative, y, its t-derivative], t = s / ds
    (ds [s])."""
    if p.hard_seat:
        return np.array([[1.0, 0.0, 0.0, 0.0], [p.stiffness, p.damping / ds, 0.0, 0.0],
                         [0.0, 0.0, 1.0, 0.0]])
    return np.array([[1.0, 0.0, 0.0, 0.0], [p.stiffness, p.damping / ds, 0.0, 0.0],
                     [0.0, 0.0, -1.0, 0.0], [0.0, 0.0, -p.seat_stiffness,
                                             -p.seat_damping / ds]])


def inside_scalar(p: SdofParams, r: int, y: float, v: float, u: float, ud: float,
                  delta: float, gc: float) -> tuple[float, float]:
    """Scalar version of ``inside`` (hot path of the root finder)."""
    fc = min(delta, gc)
    in_c = fc if r & CONTACT else -fc
    if p.hard_seat:
        if r & SEAT:
            return 1.0, -min(u, p.stiffness * u + p.damping * ud - p.spring_preload)
        return in_c, y
    fs = min(-y, -p.seat_stiffness * y - p.seat_damping * v)
    return in_c, (fs if r & SEAT else -fs)


def taylor(model: SdofModel, r: int, z: tuple[float, float], fcoef: NDArray,
           ds: float) -> NDArray:
    """Coefficients c_n of y(t) = sum c_n t^n, t = s/ds in [0, 1], exact solution.

    fcoef: monomial coefficients (in t) of the forcing f [N].
    """
    k_, b_ = model.coefs(r)
    M = model.p.mass
    f = fcoef.tolist() + [0.0] * (TAYLOR + 1 - fcoef.size)
    c = [float(z[0]), float(z[1]) * ds]
    kk = k_ * ds * ds / M
    bb = b_ * ds / M
    fs = ds * ds / M
    for n in range(TAYLOR - 1):
        c.append((f[n] * fs - kk * c[n] - bb * (n + 1) * c[n + 1]) / ((n + 2) * (n + 1)))
    return np.array(c)
