"""Every valve train of an engine on one twisting camshaft (docs/camshaft.md).

At a camshaft speed omega the periodic coupled state is found by fixed-point iteration:
1. each lobe's valve train runs (``run_train``) on its lift seen through the shaft's
   current twist at the lobe (``twist.TwistedLift``; none at the start);
2. it loads the shaft at its station with T = F h'(a + psi) + T_friction (contact force
   times its lever arm, plus the cam-follower friction torque); the journals take the
   bearing friction of the lobe forces they carry (lever rule along the shaft);
3. the shaft's periodic response to these loads (``torsion.respond``) gives the new
   twist; repeat until the twist at the lobes changes by less than ``tol`` rad.
The twist at convergence is the coupled solution: each train is solved exactly for the
cam motion the shaft imposes, and the shaft exactly (in the sampled Fourier series) for
the torques the trains return.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.camshaft.friction import (bearing_friction_torque, flat_friction_torque,
                                          roller_friction_torque, roller_slip)
from cam_design.camshaft.spec import SPROCKET, CamshaftSpec
from cam_design.camshaft.piecewise_fourier import integral
from cam_design.camshaft.torsion import (Response, Shaft, assemble, damping_work,
                                         harmonic_orders, natural_frequencies, receptance,
                                         respond)
from cam_design.camshaft.twist import PeriodicJets, TwistedLift
from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.train.run import TrainSpec, run_train, train_force
from cam_design.valve_train.params import omega_of_rpm, require_step_deg
from cam_design.valve_train.report import ContactGeometry, Run

#: harmonic orders of the drive torque reported
ORDERS = 24


@dataclass(frozen=True)
class LobeOnShaft:
    """One lobe and its valve train: ``law`` on the lobe's own angle axis, ``shift``
    [rad] the lobe angle at shaft angle 0 (a = alpha + shift), the train, the contact
    geometry (Hertz stress; None: none), the follower kind and roller radius [m], and
    the key naming the lobe's lift in refusals."""

    id: str
    law: LiftLaw
    shift: float
    train: TrainSpec
    base_radius: float
    follower: str = 'flat'
    roller_radius: float = 0.0
    geometry: ContactGeometry | None = None
    key: str = 'lift'


@dataclass
class CamshaftRun:
    """The coupled periodic state at one speed, on the shaft grid alpha [rad] (N points
    over a revolution): each lobe's Run (on its own axis), its twist psi [rad], the
    load torques [N m] per station, the drive torque [N m], the friction torque [N m]
    (all cam-follower and bearing), energies per revolution [J] and the convergence."""

    rpm: float
    alpha: NDArray[np.float64]
    runs: dict[str, Run]
    twist: dict[str, NDArray[np.float64]]
    loads: NDArray[np.float64]
    drive: NDArray[np.float64]
    friction: NDArray[np.float64]
    friction_loss: float
    contact_work: float
    damping_work: float
    drive_work: float
    iterations: int
    change: float
    converged: bool
    extras: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: the shaft's periodic response (the start of the next speed of a sweep)
    response: Response | None = None
    #: whether the coupling fell back to the damped iteration (``run_camshaft``)
    damped: bool = False

    def summary(self) -> dict[str, Any]:
        """JSON-ready per-speed figures: drive torque (mean, peak, orders), friction
        loss and mean power, and per lobe the timing shift at the nose and the twist
        range [deg]."""
        omega = omega_of_rpm(self.rpm)
        lobes = {}
        for lid, psi in self.twist.items():
            lobes[lid] = {'timing_shift_deg': self.extras[lid]['timing_shift_deg'],
                          'twist_min_deg': math.degrees(float(psi.min())),
                          'twist_max_deg': math.degrees(float(psi.max())),
                          **{k: v for k, v in self.extras[lid].items()
                             if k != 'timing_shift_deg'}}
        return {'cam_speed_rpm': self.rpm,
                'drive_torque_nm': {'mean': self.drive_work / (2.0 * math.pi),
                                    'peak': float(np.max(self.drive)),
                                    'min': float(np.min(self.drive)),
                                    'orders': harmonic_orders(self.drive, ORDERS)},
                'friction_loss_j_per_rev': self.friction_loss,
                'friction_power_w': self.friction_loss * omega / (2.0 * math.pi),
                'drive_work_j_per_rev': self.drive_work,
                'damping_work_j_per_rev': self.damping_work,
                'iterations': self.iterations, 'converged': self.converged,
                'coupling_damped': self.damped,
                'twist_change_rad': self.change, 'lobes': lobes}


def grid_size(step_deg: float) -> int:
    """Points per revolution of the shaft grid; ``step_deg`` must divide 360 deg."""
    step = require_step_deg('step_deg', step_deg)
    n = round(360.0 / step)
    if abs(n * step - 360.0) > 1e-9 * 360.0:
        raise InputError('step_deg', step_deg, 'a step dividing 360 deg (the shaft grid)')
    return int(n)


def _on_grid(run_alpha: NDArray[np.float64], shift: float, N: int
             ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Grid indices of a run's angles (a - shift on the shaft grid) and which rows of
    the run are on it (all but the repeated end of the window)."""
    pos = (run_alpha - shift) / (2.0 * math.pi / N)
    k = np.rint(pos)
    if np.max(np.abs(pos - k)) > 1e-6:
        raise InputError('lobes[].nominal_phase', 'off the shaft grid',
                         'lobe angles on the step grid (the runs share the shaft grid)')
    idx = k.astype(np.int64) % N
    first = np.zeros(N, dtype=bool)
    keep = np.zeros(idx.size, dtype=bool)
    for r, i in enumerate(idx):
        if not first[i]:
            first[i] = True
            keep[r] = True
    if not np.all(first):
        raise InputError('step_deg', N, 'runs covering the whole revolution')
    return idx, keep


def _journal_shares(spec: CamshaftSpec, lobe_ids: list[str]
                    ) -> dict[str, list[tuple[int, float]]]:
    """Per lobe: (journal station index, share of its radial load), lever rule between
    the neighbouring journals along the shaft (all to the nearest one outside them)."""
    x = np.concatenate([[0.0], np.cumsum([s.length for s in spec.sections])])
    journals = [i for i, s in enumerate(spec.stations)
                if s != SPROCKET and s not in lobe_ids]
    out: dict[str, list[tuple[int, float]]] = {}
    for lid in lobe_ids:
        i = spec.stations.index(lid)
        left = [j for j in journals if x[j] <= x[i]]
        right = [j for j in journals if x[j] >= x[i]]
        if left and right:
            a, b = left[-1], right[0]
            w = 0.5 if x[b] == x[a] else (x[b] - x[i]) / (x[b] - x[a])
            out[lid] = [(a, w), (b, 1.0 - w)]
        elif left or right:
            out[lid] = [((left or right)[-1 if left else 0], 1.0)]
        else:
            out[lid] = []
    return out


@dataclass
class _Pass:
    """One pass of every train on the shaft's current twist: the station loads and
    their contact share [N m] (stations, N), per station the load's breakpoints on the
    shaft axis [rad], and (a full pass) each lobe's Run and extra fields."""

    loads: NDArray[np.float64]
    contact: NDArray[np.float64]
    breaks: list[NDArray[np.float64]]
    runs: dict[str, Run]
    extras: dict[str, dict[str, Any]]


def _law_breaks(lb: LobeOnShaft, jets: PeriodicJets | None) -> NDArray[np.float64]:
    """The lobe's own breakpoints (its support's ends and junctions, where h'' or a
    higher derivative jumps) on the nominal lobe axis: a + delta(a) = j [rad]."""
    lo, hi = (float(v) for v in lb.law.support)
    ends = [lo, hi] if hi - lo < 2.0 * math.pi - 1e-9 else []   # a whole-turn law: none
    j = np.array([*ends, *(float(x) for x in lb.law.junctions)], dtype=float)
    a = j.copy()
    if jets is not None:
        for _ in range(6):
            a = j - jets(a - lb.shift)[0]
    return a


def _load_pass(lobes: list[LobeOnShaft], spec: CamshaftSpec, rpm: float, N: int,
               response: Response | None, station: dict[str, int],
               shares: dict[str, list[tuple[int, float]]], *, step_deg: float,
               max_revolutions: int, full: bool) -> _Pass:
    """Every train run on the twist of ``response`` (None: rigid), its load torque
    T = F h'(a + psi) + friction at its station and the bearing friction at the
    journals; ``full``: with each lobe's complete Run (report fields), else the
    contact force alone where the model allows (``train_force``; the same force)."""
    fr = spec.friction
    omega = omega_of_rpm(rpm)
    phaser = math.radians(spec.drive.phaser_deg)
    alpha: NDArray[np.float64] = np.arange(N, dtype=np.float64) * (2.0 * math.pi / N)
    loads = np.zeros((len(spec.stations), N))
    contact = np.zeros((len(spec.stations), N))
    breaks: list[list[NDArray[np.float64]]] = [[] for _ in spec.stations]
    runs: dict[str, Run] = {}
    extras: dict[str, dict[str, Any]] = {}
    for lb in lobes:
        s = station[lb.id]
        law: LiftLaw = lb.law
        jets = None
        if response is not None or phaser:
            psi = np.zeros((4, N)) if response is None else np.stack(
                [response.psi[s], response.dpsi[s], response.d2psi[s], response.d3psi[s]])
            psi[0] += phaser
            jets = PeriodicJets(psi)
            law = TwistedLift(lb.law, jets, lb.shift)
        if full:
            run: Run | None = run_train(law, lb.train, rpm, step_deg=step_deg,
                                        geometry=lb.geometry,
                                        max_revolutions=max_revolutions, key=lb.key)
            assert run is not None
            r_alpha, r_force, r_breaks = run.alpha, run.force, run.breaks
        else:
            r_alpha, r_force, r_breaks, run = train_force(
                law, lb.train, rpm, step_deg=step_deg, max_revolutions=max_revolutions,
                key=lb.key, geometry=lb.geometry)
        idx, keep = _on_grid(r_alpha, lb.shift, N)
        force = np.zeros(N)
        force[idx[keep]] = r_force[keep]
        a = alpha + lb.shift
        d = np.zeros((4, N)) if jets is None else jets(alpha)
        lo = float(lb.law.support[0])
        theta = lo + np.mod(a + d[0] - lo, 2.0 * math.pi)     # the lobe's own window
        h = lb.law.derivatives(theta)
        t_contact = force * h[1]
        t_fric = np.zeros(N)
        extra: dict[str, Any] = {}
        if lb.follower == 'roller' and fr.roller is not None:
            t_fric = roller_friction_torque(force, h[0], h[1], lb.base_radius,
                                            lb.roller_radius, fr.roller)
            extra = roller_slip(force, h[0], h[1], alpha, lb.base_radius,
                                lb.roller_radius, fr.roller, omega)
        elif lb.follower == 'flat' and fr.flat is not None:
            t_fric = flat_friction_torque(force, h[0], h[2], lb.base_radius, fr.flat, rpm)
        loads[s] += t_contact + t_fric
        contact[s] += t_contact
        own = np.concatenate([_law_breaks(lb, jets),
                              np.zeros(0) if r_breaks is None else r_breaks]) - lb.shift
        breaks[s].append(own)
        for j, w in shares[lb.id]:
            if fr.bearing > 0:
                loads[j] += bearing_friction_torque(w * force, fr.bearing, spec.journal_radius)
                breaks[j].append(own)
        if run is not None:
            run.drive_torque = t_contact[idx] + t_fric[idx]
            run.friction_torque = t_fric[idx]
            runs[lb.id] = run
        extras[lb.id] = {**extra, 'timing_shift_deg': _nose_shift(lb, d[0], alpha)}
    return _Pass(loads=loads, contact=contact, runs=runs, extras=extras,
                 breaks=[np.mod(np.concatenate(b), 2.0 * math.pi) if b else np.zeros(0)
                         for b in breaks])


def run_camshaft(lobes: list[LobeOnShaft], spec: CamshaftSpec, rpm: float, *,
                 step_deg: float = 0.1, max_revolutions: int = 4, tol: float = 1e-9,
                 max_iter: int = 40, shaft: Shaft | None = None,
                 depth: int = 12, start: Response | None = None) -> CamshaftRun:
    """The coupled periodic state of ``lobes`` on the shaft ``spec`` at ``rpm`` (module
    docstring); ``tol`` [rad] on the change of the twist at the lobes; ``depth``: the
    Anderson acceleration's memory (0: plain iteration); ``start``: the first guess of
    the shaft's response (a neighbouring speed's, on the same grid; None: rigid)."""
    N = grid_size(step_deg)
    omega = omega_of_rpm(rpm)
    shaft = shaft or assemble(spec)
    rec = receptance(shaft, omega, N)
    ids = [lb.id for lb in lobes]
    station = {lid: spec.stations.index(lid) for lid in ids}
    shares = _journal_shares(spec, ids)
    alpha: NDArray[np.float64] = np.arange(N, dtype=np.float64) * (2.0 * math.pi / N)
    response = start if start is not None and start.psi.shape[1] == N else None
    change, it, converged = math.inf, 0, False
    lobe_rows = [station[i] for i in ids]
    mixer = _Anderson(depth)
    history: list[float] = []
    best: tuple[float, Response | None, Response, NDArray[np.float64]] | None = None
    damped = False
    while True:
        it += 1
        used = response
        ps = _load_pass(lobes, spec, rpm, N, used, station, shares, step_deg=step_deg,
                        max_revolutions=max_revolutions, full=False)
        new = respond(shaft, ps.loads, omega, ps.breaks, rec)
        resid = new.psi[lobe_rows] - (0.0 if used is None else used.psi[lobe_rows])
        change = float(np.max(np.abs(resid)))
        converged = change < tol or used is None and change == 0.0
        if converged or it >= max_iter:
            break
        history.append(change)
        if best is None or change < best[0]:
            best = (change, used, new, resid)
        if not damped and _stalled(history):
            # contact and seat events (separation, bounce) can make the accelerated map
            # overshoot or cycle: restart from the best iterate, damped, with a new memory
            damped = True
            mixer = _Anderson(depth, mixing=DAMPED_MIXING)
            _, used, new, resid = best
        response = mixer.next(used, new, resid)
    if len(ps.runs) < len(lobes):       # the report fields of the trains on this twist
        ps = _load_pass(lobes, spec, rpm, N, used, station, shares, step_deg=step_deg,
                        max_revolutions=max_revolutions, full=True)
    response = new
    friction = ps.loads - ps.contact
    every = np.concatenate(ps.breaks)
    stretch = 1.0 + response.dpsi
    fric_loss = sum(integral(friction[i] * stretch[i], ps.breaks[i])
                    for i in range(len(spec.stations)) if np.any(friction[i]))
    contact_work = sum(integral(ps.contact[i] * stretch[i], ps.breaks[i])
                       for i in range(len(spec.stations)) if np.any(ps.contact[i]))
    return CamshaftRun(
        rpm=float(rpm), alpha=alpha, runs=ps.runs,
        twist={i: response.psi[station[i]] for i in ids}, loads=ps.loads,
        drive=response.drive, friction=friction.sum(axis=0), friction_loss=float(fric_loss),
        contact_work=float(contact_work),
        damping_work=damping_work(shaft, response, omega, every), response=response,
        damped=damped,
        drive_work=_drive_work(shaft, response, ps), iterations=it, change=change,
        converged=converged, extras=ps.extras)


def _drive_work(shaft: Shaft, response: Response, ps: _Pass) -> float:
    """Work [J] of the drive torque over a revolution: 2 pi times its mean, from the
    mean twist (the response's 0th harmonic, exact for the loads' exact means): a held
    sprocket K_s psi_0 + its own load's mean, a chain/belt/gear -k_d psi_0."""
    s = shaft.sprocket
    psi0 = response.spectrum[:, 0].real
    if shaft.held:
        own = integral(ps.loads[s], ps.breaks[s]) if np.any(ps.loads[s]) else 0.0
        return float(2.0 * math.pi * (shaft.K[s] @ psi0)) + own
    return float(-2.0 * math.pi * shaft.drive_stiffness * psi0[s])


#: mixing of the damped fallback of the coupling iteration
DAMPED_MIXING = 0.5
#: iterations over which the coupling must halve its change before the fallback
STALL_WINDOW = 6


def _stalled(history: list[float]) -> bool:
    """Whether the coupling iteration diverges (the change grew tenfold over its best)
    or stalls (not halved over the last STALL_WINDOW iterations)."""
    best = min(history)
    if history[-1] > 10.0 * best:
        return True
    return (len(history) > STALL_WINDOW
            and min(history[-STALL_WINDOW:]) > 0.5 * min(history[:-STALL_WINDOW]))


class _Anderson:
    """Anderson acceleration of the fixed point x = G(x) on the shaft's response
    (Walker & Ni 2011, type II): with the last ``depth`` residuals f = G(x) - x, the
    next iterate is G(x_k) - dG gamma, gamma the least-squares fit of f_k by the
    residual differences dF (measured on the twist at the lobes). The response is linear
    in the loads, so a combination of responses is one. ``mixing`` beta < 1 damps the
    map, G_beta(x) = (1 - beta) x + beta G(x) (the fallback where contact and seat
    events make the plain map overshoot)."""

    def __init__(self, depth: int, mixing: float = 1.0) -> None:
        self.depth = depth
        self.mixing = mixing
        self.f: list[NDArray[np.float64]] = []
        self.g: list[NDArray[np.float64]] = []

    def next(self, x: Response | None, g: Response, f: NDArray[np.float64]) -> Response:
        gv = _pack(g)
        if x is not None and self.mixing != 1.0:
            gv = (1.0 - self.mixing) * _pack(x) + self.mixing * gv
        self.f.append(f.ravel())
        self.g.append(gv)
        if len(self.f) > self.depth + 1:
            self.f.pop(0)
            self.g.pop(0)
        if x is None or len(self.f) < 2 or self.depth == 0:
            return _unpack(gv, g)
        dF = np.stack([b - a for a, b in zip(self.f[:-1], self.f[1:])], axis=1)
        dG = np.stack([b - a for a, b in zip(self.g[:-1], self.g[1:])], axis=1)
        gamma = np.linalg.lstsq(dF, self.f[-1], rcond=None)[0]
        return _unpack(gv - dG @ gamma, g)


def _pack(r: Response) -> NDArray[np.float64]:
    return np.concatenate([r.psi.ravel(), r.dpsi.ravel(), r.d2psi.ravel(), r.d3psi.ravel(),
                           r.drive, r.spectrum.real.ravel(), r.spectrum.imag.ravel()])


def _unpack(v: NDArray[np.float64], like: Response) -> Response:
    parts, pos = [], 0
    for arr in (like.psi, like.dpsi, like.d2psi, like.d3psi, like.drive,
                like.spectrum.real, like.spectrum.imag):
        parts.append(v[pos:pos + arr.size].reshape(arr.shape))
        pos += arr.size
    return Response(spectrum=parts[5] + 1j * parts[6], psi=parts[0], dpsi=parts[1],
                    d2psi=parts[2], d3psi=parts[3], drive=parts[4])


def _nose_shift(lb: LobeOnShaft, delta: NDArray[np.float64], alpha: NDArray[np.float64]
                ) -> float:
    """Timing shift [deg] of the lobe: its deviation at the nose (positive: the events
    come earlier)."""
    lo, hi = lb.law.support
    grid = np.linspace(lo, hi, 2001)
    nose = float(grid[int(np.argmax(lb.law(grid)))])
    N = alpha.size
    k = int(round((nose - lb.shift) / (2.0 * math.pi / N))) % N
    return math.degrees(float(delta[k]))


def shaft_modes(spec: CamshaftSpec) -> NDArray[np.float64]:
    """Torsional natural frequencies [Hz] of the shaft of ``spec``."""
    return natural_frequencies(assemble(spec))
