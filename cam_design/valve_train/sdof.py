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
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.cam_input import CamInput, build_cam_input, with_gas
from cam_design.valve_train.params import SdofParams, omega_of_rpm, require_step_deg
from cam_design.valve_train.propagate import BOUNCE_TOL, NB, SolverError, expm
from cam_design.valve_train.sdof_model import CONTACT, SEAT, SdofModel, inside
from cam_design.valve_train.sdof_run import OPEN_TOL, Events, SdofRun

__all__ = ['BOUNCE_TOL', 'CONTACT', 'NB', 'OPEN_TOL', 'SEAT', 'Events', 'SdofModel',
           'SdofResult', 'SolverError', 'expm', 'simulate', 'simulate_cam']


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


def _regime_of(run: 'SdofRun', z: tuple[float, float], prefer: int) -> int:
    """A regime consistent with state ``z`` at node 0 (``prefer`` if it is)."""
    model, cam = run.model, run.cam
    u0 = float(cam.coeffs[0, 0])
    ud0 = float(cam.coeffs[0, 1] / cam.lengths[0]) * model.omega
    order = [prefer] + [r for r in (SEAT, SEAT | CONTACT, CONTACT, 0) if r != prefer]
    for r in order:
        if model.p.hard_seat and r & SEAT and (z[0] != 0.0 or z[1] != 0.0):
            continue
        ic, is_ = inside(model, r, float(z[0]), float(z[1]), u0, ud0)
        if ic >= 0 and is_ >= 0:
            return r
    return prefer


@dataclass
class _Shot:
    """One revolution from a given start state."""

    run: 'SdofRun'
    ys: NDArray
    vs: NDArray
    rs: NDArray
    z0: tuple[float, float]
    r0: int
    z: tuple[float, float]
    r: int


def _one_rev(model: SdofModel, cam: CamInput, z0: tuple[float, float], r0: int,
             events_only: bool = False, first: bool = False) -> _Shot:
    run = SdofRun(model, cam)
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
    model = SdofModel(params, omega)
    wn = math.sqrt((params.stiffness + params.spring_rate) / params.mass)
    run = SdofRun(model, cam)
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


def _shoot(model: SdofModel, cam: CamInput, shot: _Shot, wn: float,
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
