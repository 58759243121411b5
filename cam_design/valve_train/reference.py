"""Reference solution of the ``sdof`` model with scipy ``solve_ivp`` and events.

Same equations and switching rules as ``sdof`` (regimes restarted at terminal events,
law junctions as breakpoints) but with the exact lift law and a general-purpose
integrator: the truth for tests and the baseline of the benchmark.
"""
from __future__ import annotations

from typing import Any

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.params import SdofParams, omega_of_rpm
from cam_design.valve_train.sdof_model import CONTACT, SEAT, inside

_MAX_RESTARTS = 5000


@dataclass
class ReferenceResult:
    """y [m], v [m/s] at ``alpha`` [rad]; switch angles; right-hand-side evaluations."""

    alpha: NDArray[np.float64]
    y: NDArray[np.float64]
    v: NDArray[np.float64]
    switches: list[tuple[float, int]]
    nfev: int


class _Rhs:
    def __init__(self, law: LiftLaw, p: SdofParams, omega: float, a0: float,
                 gas: Any = None) -> None:
        self.law, self.p, self.omega, self.a0 = law, p, omega, a0
        self.gas = gas
        self.model = type('M', (), {'p': p})()

    def cam(self, t: float) -> tuple[float, float]:
        a = self.a0 + self.omega * t
        k = self.p.rocker_ratio
        return (k * float(self.law(a)) - self.p.lash,
                k * self.omega * float(self.law(a, 1)))

    def f(self, t: float, z: NDArray, r: int) -> NDArray:
        p = self.p
        y, v = z
        u, ud = self.cam(t)
        force = -p.spring_preload - p.spring_rate * y - p.valve_damping * v
        if self.gas is not None:
            force -= float(self.gas(self.a0 + self.omega * t))
        if r & CONTACT:
            force += p.stiffness * (u - y) + p.damping * (ud - v)
        if r & SEAT and not p.hard_seat:
            force += -p.seat_stiffness * y - p.seat_damping * v
        return np.array([v, force / p.mass])

    def inside(self, t: float, z: NDArray, r: int) -> tuple[float, float]:
        u, ud = self.cam(t)
        ic, is_ = inside(self.model, r, float(z[0]), float(z[1]), u, ud)
        return float(ic), float(is_)


def reference_solve(law: LiftLaw, params: SdofParams, rpm: float,
                    alpha_out: NDArray[np.float64], *, method: str = 'Radau',
                    rtol: float = 1e-12, atol: float = 1e-15,
                    z0: tuple[float, float] | None = None,
                    r0: int | None = None, gas: Any = None) -> ReferenceResult:
    """Integrate from alpha_out[0] (valve at rest on the seat unless ``z0``) and
    return the state at every ``alpha_out`` (increasing, within one revolution)."""
    omega = omega_of_rpm(rpm)
    a_out = np.asarray(alpha_out, dtype=float)
    if a_out.ndim != 1 or a_out.size < 2 or np.any(np.diff(a_out) <= 0):
        raise InputError('alpha_out', a_out.shape, 'increasing angles')
    p = params
    rhs = _Rhs(law, p, omega, float(a_out[0]), gas)
    if gas is not None and z0 is None:
        raise InputError('z0', None, 'a start state when a gas force is given')
    t_out = (a_out - a_out[0]) / omega
    t_end = float(t_out[-1])
    lo, hi = law.support
    breaks = sorted({(a - a_out[0]) / omega for a in (lo, hi, *law.junctions)
                     if a_out[0] < a < a_out[-1]} | {t_end})
    if z0 is None:
        if p.hard_seat:
            z0, r0 = (0.0, 0.0), SEAT
        else:
            u0 = rhs.cam(0.0)[0]
            kk = p.seat_stiffness + p.spring_rate
            y0 = -p.spring_preload / kk
            r0 = SEAT
            if u0 - y0 > 0:
                y0 = (p.stiffness * u0 - p.spring_preload) / (kk + p.stiffness)
                r0 = SEAT | CONTACT
            if y0 >= 0:
                y0, r0 = max(y0, 0.0), (CONTACT if u0 > 0 else 0)
            z0 = (y0, 0.0)
    z = np.array(z0, dtype=float)
    r = int(r0 if r0 is not None else SEAT)
    t = 0.0
    ys = np.full(t_out.size, np.nan)
    vs = np.full(t_out.size, np.nan)
    ys[0], vs[0] = z
    switches: list[tuple[float, int]] = []
    nfev = 0
    for _ in range(_MAX_RESTARTS):
        if t >= t_end:
            break
        t_stop = next((b for b in breaks if b > t + 1e-15), t_end)
        if t_stop <= t:
            break
        if p.hard_seat and r & SEAT:
            def held(tt: float) -> float:
                return rhs.inside(tt, np.zeros(2), SEAT)[1]
            grid = np.linspace(t, t_stop, 65)
            vals = [held(g) for g in grid]
            mask = np.asarray(vals) < 0
            sel = (t_out > t) & (t_out <= t_stop)
            if not np.any(mask[1:]):
                ys[sel], vs[sel] = 0.0, 0.0
                t = t_stop
                continue
            i = int(np.argmax(mask[1:])) + 1
            tt = brentq(held, grid[i - 1], grid[i], xtol=1e-16)
            sel = (t_out > t) & (t_out <= tt)
            ys[sel], vs[sel] = 0.0, 0.0
            t, z, r = tt, np.zeros(2), CONTACT
            switches.append((a_out[0] + omega * t, r))
            continue
        rr = r

        def ev_c(tt: float, zz: NDArray) -> float:
            return rhs.inside(tt, zz, rr)[0]

        def ev_s(tt: float, zz: NDArray) -> float:
            return rhs.inside(tt, zz, rr)[1]

        for e in (ev_c, ev_s):
            e.terminal = True   # type: ignore[attr-defined]
            e.direction = -1    # type: ignore[attr-defined]
        sel = (t_out > t) & (t_out <= t_stop)
        sol = solve_ivp(lambda tt, zz: rhs.f(tt, zz, rr), (t, t_stop), z, method=method,
                        rtol=rtol, atol=atol, events=(ev_c, ev_s), dense_output=True)
        nfev += sol.nfev
        t_new = float(sol.t[-1])
        sel = (t_out > t) & (t_out <= t_new)
        if np.any(sel):
            zz = sol.sol(t_out[sel])
            ys[sel], vs[sel] = zz[0], zz[1]
        z = sol.y[:, -1].copy()
        t = t_new
        if sol.status == 1:
            which = CONTACT if sol.t_events[0].size else SEAT
            if which == SEAT and p.hard_seat:
                v_new = -float(p.restitution or 0.0) * z[1]   # hard seat: set
                z = np.array([0.0, v_new])
                if v_new <= 1e-9 and rhs.inside(t, np.zeros(2), SEAT)[1] >= 0:
                    r = SEAT
                    z = np.zeros(2)
            else:
                r = r ^ which
            switches.append((a_out[0] + omega * t, r))
            # step a hair past the event so that it is not found again
            t_hair = t + 1e-13 / omega
            zz = z + np.asarray(rhs.f(t, z, r)) * 1e-13 / omega if not (
                p.hard_seat and r & SEAT) else z
            t, z = t_hair, zz
    else:
        raise RuntimeError('reference solver: too many restarts')
    return ReferenceResult(alpha=a_out, y=ys, v=vs, switches=switches, nfev=nfev)
