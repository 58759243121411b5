"""Regimes of the exact 4+N1+N2 solver (``mdof_exact``, docs/dynamics.md): the linear
system of each regime (cam contact, rocker-valve contact with the lash, valve seat), its
cached exact propagators and the screening of the switching functions."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.valve_train.propagate import NB, dips, expm, sub_node_jets

T, P, R, V = 0, 1, 2, 3
CAM, RV, SEAT = 1, 2, 4
SUB = math.pi / 4.0


class MdofModel:
    """Regime matrices, cached propagators and switching functions at one speed.

    ``asm``: ``mdof._Assembly`` (masses m, k_lin, c_lin, preload, contact rates)."""

    def __init__(self, asm: Any, omega: float) -> None:
        b = asm.mp.base
        self.asm = asm
        self.n = asm.n
        self.omega = omega
        self.hard = b.hard_seat
        self.e = b.restitution if b.hard_seat else 0.0
        self.lash = b.lash
        self.ks, self.bs = b.seat_stiffness, b.seat_damping
        self.minv = 1.0 / asm.m
        self._mats: dict[int, tuple[NDArray, NDArray, NDArray, NDArray, float]] = {}
        self.cache: dict[tuple[int, float, int], tuple[NDArray, NDArray, NDArray]] = {}

    def held(self, r: int) -> bool:
        return self.hard and bool(r & SEAT)

    def mats(self, r: int) -> tuple[NDArray, NDArray, NDArray, NDArray, float]:
        """(K, C, f, A, rho) of regime r: stiffness, damping and constant force of the
        free equations M x'' = f - K x - C x' (+ cam on T), the first-order matrix A
        (valve rows zero when held) and its spectral radius [1/s]."""
        hit = self._mats.get(r)
        if hit is not None:
            return hit
        a = self.asm
        n = self.n
        kk, cc, f = a.k_lin.copy(), a.c_lin.copy(), a.preload.copy()
        if r & CAM:
            kk[T, T] += a.k_c
            cc[T, T] += a.b_c
        if r & RV:
            for (i, j, sgn) in ((R, R, 1), (V, V, 1), (R, V, -1), (V, R, -1)):
                kk[i, j] += sgn * a.k_rv
                cc[i, j] += sgn * a.b_rv
            f[R] += a.k_rv * self.lash
            f[V] -= a.k_rv * self.lash
        if r & SEAT and not self.hard:
            kk[V, V] += self.ks
            cc[V, V] += self.bs
        am = np.zeros((2 * n, 2 * n))
        am[:n, n:] = np.eye(n)
        am[n:, :n] = -kk * self.minv[:, None]
        am[n:, n:] = -cc * self.minv[:, None]
        if self.held(r):
            am[V, :] = 0.0
            am[n + V, :] = 0.0
        rho = float(np.max(np.abs(np.linalg.eigvals(am))))
        out = (kk, cc, f, am, max(rho, 1e-12))
        self._mats[r] = out
        return out

    def const_rate(self, r: int) -> NDArray:
        """Constant part b_r of z' [(2n,)]."""
        _, _, f, _, _ = self.mats(r)
        n = self.n
        b = np.zeros(2 * n)
        b[n:] = f * self.minv
        if self.held(r):
            b[n + V] = 0.0
        return b

    def propagator(self, r: int, lt: float, m: int) -> tuple[NDArray, NDArray, NDArray]:
        """(Phi (m, 2n, 2n), Gq (m, 2n, NB), G1 (m, 2n)) at the sub-nodes j lt/m,
        j = 1..m: z_j = Phi_j z_0 + Gq_j q + G1_j for the cam forcing coefficients q in
        the basis sigma^i / i! (sigma = t / lt)."""
        key = (r, lt, m)
        hit = self.cache.get(key)
        if hit is not None:
            return hit
        n = self.n
        _, _, f, am, rho = self.mats(r)
        s = rho                                   # velocity scale: balances G
        na = 2 * n + NB + 1
        g = np.zeros((na, na))
        g[:n, n:2 * n] = am[:n, n:] * s
        g[n:2 * n, :n] = am[n:, :n] / s
        g[n:2 * n, n:2 * n] = am[n:, n:]
        g[n + T, 2 * n] = self.minv[T] / s
        g[n:2 * n, na - 1] = self.const_rate(r)[n:] / s
        for j in range(NB - 1):
            g[2 * n + j, 2 * n + j + 1] = 1.0 / lt
        e1 = expm(g * (lt / m))
        phis = np.empty((m, 2 * n, 2 * n))
        gq = np.empty((m, 2 * n, NB))
        g1 = np.empty((m, 2 * n))
        e = e1
        for j in range(m):
            if j:
                e = e @ e1
            phis[j] = e[:2 * n, :2 * n]
            gq[j] = e[:2 * n, 2 * n:2 * n + NB]
            g1[j] = e[:2 * n, na - 1]
        phis[:, :n, n:] /= s
        phis[:, n:, :n] *= s
        gq[:, n:, :] *= s
        g1[:, n:] *= s
        if len(self.cache) > 512:
            self.cache.clear()
        out = (phis, gq, g1)
        self.cache[key] = out
        return out

    def cam_forcing(self, r: int, ucoef: NDArray, la: NDArray | float) -> NDArray:
        """Monomial coefficients (..., NB) of g = k_c u + b_c du/dt [N] (0 off the cam)."""
        if not r & CAM:
            return np.zeros(np.shape(ucoef))
        du = np.zeros(np.shape(ucoef))
        du[..., :-1] = ucoef[..., 1:] * np.arange(1, NB)
        rate = np.asarray(self.omega / np.asarray(la, dtype=float))[..., None]
        return self.asm.k_c * ucoef + self.asm.b_c * rate * du

    # -- switching functions --------------------------------------------------------
    def groups(self, r: int, x: Any, xd: Any, xdd: Any, u: Any, ud: Any,
               udd: Any, one: Any = 1.0) -> list[tuple[float, list[Any], list[Any]]]:
        """Switching groups (sign, values, time derivatives) of regime r; the regime
        holds while sign * min(values) >= 0 for every group. x, xd, xdd: (..., n).
        ``one``: the constant 1 (its coefficient vector when the inputs are
        polynomial coefficients along the first axis)."""
        a = self.asm
        out = []
        delta, dd, ddd = u - x[..., T], ud - xd[..., T], udd - xdd[..., T]
        out.append((1.0 if r & CAM else -1.0,
                    [delta, a.k_c * delta + a.b_c * dd], [dd, a.k_c * dd + a.b_c * ddd]))
        d2 = x[..., R] - x[..., V] - self.lash * one
        v2 = xd[..., R] - xd[..., V]
        a2 = xdd[..., R] - xdd[..., V]
        out.append((1.0 if r & RV else -1.0,
                    [d2, a.k_rv * d2 + a.b_rv * v2], [v2, a.k_rv * v2 + a.b_rv * a2]))
        if self.hard:
            if r & SEAT:
                fv, dfv = self.valve_force(r, x, xd, xdd, one)
                out.append((1.0, [-fv], [-dfv]))
            else:
                out.append((1.0, [x[..., V]], [xd[..., V]]))
        else:
            gs = -self.ks * x[..., V] - self.bs * xd[..., V]
            dgs = -self.ks * xd[..., V] - self.bs * xdd[..., V]
            out.append((1.0 if r & SEAT else -1.0, [-x[..., V], gs], [-xd[..., V], dgs]))
        return out

    def valve_force(self, r: int, x: Any, xd: Any, xdd: Any,
                    one: Any = 1.0) -> tuple[Any, Any]:
        """Net force [N] on the held valve from rocker, coils and preload (> 0 opens it)
        and its time derivative."""
        kk, cc, f, _, _ = self.mats(r)
        fv = f[V] * one - x @ kk[V] - xd @ cc[V]
        dfv = -(xd @ kk[V]) - xdd @ cc[V]
        return fv, dfv

    def accel(self, r: int, x: NDArray, xd: NDArray, g: Any) -> NDArray:
        """x'' of regime r (..., n) for the cam forcing g [N] (..., )."""
        kk, cc, f, _, _ = self.mats(r)
        acc = (f - x @ kk.T - xd @ cc.T) * self.minv
        acc[..., T] += np.asarray(g) * self.minv[T]
        if self.held(r):
            acc[..., V] = 0.0
        return acc


def switch_flags(model: MdofModel, r: int, ucoef: NDArray, gmono: NDArray, la: NDArray,
                 lt: NDArray, zall: NDArray) -> NDArray:
    """(q, m) True where sub-interval j of step q may hold a switch of regime r.

    ucoef, gmono: (q, NB) monomials of u and the cam forcing; la, lt: (q,) step angle
    and time; zall: (q, m+1, 2n) states at the sub-nodes j/m, j = 0..m."""
    n = model.n
    m = zall.shape[1] - 1
    u, ud, udd, v0 = sub_node_jets(ucoef, m, model.omega, la)
    g = gmono @ v0
    x, xd = zall[..., :n], zall[..., n:]
    xdd = model.accel(r, x, xd, g)
    h = (lt / m)[:, None]
    vals, ders, kinds = [], [], []
    for sign, vs, ds in model.groups(r, x, xd, xdd, u, ud, udd):
        kinds.append((sign, len(vs)))
        vals += [sign * v for v in vs]
        ders += [sign * d * h for d in ds]
    dipped = dips(np.stack(vals), np.stack(ders))
    bad = np.zeros(dipped.shape[1:], dtype=bool)
    i = 0
    for sign, cnt in kinds:
        grp = dipped[i:i + cnt]
        bad |= np.any(grp, axis=0) if sign > 0 else np.all(grp, axis=0)
        i += cnt
    return bad
