"""Benchmark of the coupled camshaft (``cam_design.camshaft``): CPU time per coupled
revolution against the number of valve trains on the shaft, the error against an
independent LSODA integration of the whole coupled ODE (shaft + every SDOF train), and
the CPU time of a 100-speed sweep of the example scene.

Cases: n = 1, 8, 16 lobes h = 3 mm + 2 mm cos(a - 2 pi i / n) (valve held off its seat,
contact everywhere: the loads are smooth, so the comparison measures the coupling, not
the sampling of kinks) with the default scene's train (0.12 kg, 1.2e7 N/m, 3e4 N/m,
250 N, rocker 1.5, no lash) on a steel shaft of 30 mm sections 25 mm long (constant-speed
sprocket, lobes 1.4e-5 kg m^2, 2 % damping), 1500 rpm, 1 deg grid; reference: LSODA at
rtol 1e-10 over 4 revolutions (error = largest twist difference / peak twist, and the
same for the valve lift). Sweep: config/camshaft_i4_scene.yaml (8 lobes, chain drive,
friction) at 100 speeds from 500 to 3000 rpm on a 1 deg grid. Time per revolution =
CPU time of the coupled solve / (iterations x 4 revolutions run per train).

Each speed of the sweep starts from the previous speed's converged response.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks camshaft`` (writes
benchmarks/results/camshaft.md; the sweep takes about 5 min of CPU:
``CAMSHAFT_SWEEP_SPEEDS=10`` runs a shorter one, ``CAMSHAFT_REFERENCE_MAX=8`` skips the
LSODA reference above 8 trains: it costs minutes; ``CAMSHAFT_TRAINS=16`` picks the cases).
"""
from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from benchmarks.machine import report
from cam_design.camshaft.coupled import LobeOnShaft, run_camshaft
from cam_design.camshaft.spec import camshaft_from_mapping
from cam_design.camshaft.torsion import assemble
from cam_design.lift_laws.base import LiftLaw
from cam_design.train.run import TrainSpec
from cam_design.valve_train.params import SdofParams, omega_of_rpm

RESULT = Path(__file__).resolve().parent / 'results' / 'camshaft.md'
TRAIN = SdofParams(mass=0.12, stiffness=1.2e7, damping=60.0, spring_rate=3.0e4,
                   spring_preload=250.0, rocker_ratio=1.5, lash=0.0)
RPM, STEP, REVS = 1500.0, 1.0, 4


class _Cosine(LiftLaw):
    """h = h0 + e cos(a) over the whole revolution."""

    continuity_order = 3

    def __init__(self, h0: float = 3e-3, e: float = 2e-3) -> None:
        self.h0, self.e = h0, e

    @property
    def support(self) -> tuple[float, float]:
        return (-math.pi, math.pi)

    def _evaluate(self, alpha: np.ndarray, nu: int) -> np.ndarray:
        return self.h0 * (nu == 0) + self.e * np.cos(alpha + nu * math.pi / 2)


def _shaft(n: int) -> dict:
    stations = ['sprocket'] + [f'lobe_{i}' for i in range(n)]
    return {'stations': stations,
            'sections': [{'length': 0.025, 'diameter': 0.03}] * n,
            'lobe_inertia': 1.4e-5, 'damping_ratio': 0.02}


def _reference(spec, law: _Cosine, shifts: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """LSODA of the coupled ODE: state (y_i, v_i) per train, (psi_j, psi_j') per free
    station; returns the lobes' twist (n, N) and valve lift (n, N) on the last revolution."""
    shaft = assemble(spec)
    free = shaft.free
    K, M, C = (a[np.ix_(free, free)] for a in (shaft.K, shaft.M, shaft.C))
    minv = 1.0 / np.diag(M)
    n = len(shifts)
    row = [list(free).index(spec.stations.index(f'lobe_{i}')) for i in range(n)]
    p, omega = TRAIN, omega_of_rpm(RPM)
    sh = np.asarray(shifts)

    def rhs(t: float, z: np.ndarray) -> np.ndarray:
        y, v = z[:n], z[n:2 * n]
        psi, dpsi = z[2 * n:2 * n + len(free)], z[2 * n + len(free):]
        th = omega * t + sh + psi[row]
        h0 = law.h0 + law.e * np.cos(th)
        h1 = -law.e * np.sin(th)
        u = p.rocker_ratio * h0 - p.lash
        ud = p.rocker_ratio * h1 * (omega + dpsi[row])
        ft = np.where(u > y, np.maximum(0.0, p.stiffness * (u - y) + p.damping * (ud - v)),
                      0.0)
        acc = (ft - p.spring_preload - p.spring_rate * y) / p.mass
        load = np.zeros(len(free))
        load[row] = p.rocker_ratio * ft * h1
        return np.concatenate([v, acc, dpsi, minv * (-load - C @ dpsi - K @ psi)])

    period = 2 * math.pi / omega
    N = round(360 / STEP)
    u0 = p.rocker_ratio * (law.h0 + law.e * np.cos(sh)) - p.spring_preload / p.stiffness
    z0 = np.concatenate([u0, np.zeros(n), np.zeros(2 * len(free))])
    t_eval = (REVS - 1) * period + np.arange(N) * period / N
    sol = solve_ivp(rhs, (0.0, REVS * period), z0, method='LSODA', t_eval=t_eval,
                    rtol=1e-10, atol=1e-14)
    return np.stack([sol.y[2 * n + r] for r in row]), sol.y[:n]


def _trains(n: int) -> list[str]:
    spec = camshaft_from_mapping(_shaft(n), [f'lobe_{i}' for i in range(n)])
    law = _Cosine()
    step = math.radians(STEP)
    shifts = [round(2 * math.pi * i / n / step) * step for i in range(n)]
    lobes = [LobeOnShaft(f'lobe_{i}', law, shifts[i], TrainSpec('sdof', sdof=TRAIN), 0.0165)
             for i in range(n)]
    t0 = time.process_time()
    cr = run_camshaft(lobes, spec, RPM, step_deg=STEP, tol=1e-12)
    cpu = time.process_time() - t0
    if n > int(os.environ.get('CAMSHAFT_REFERENCE_MAX', '16')):
        return [f'| {n} | {cr.iterations} | {cpu:.2f} | {cpu / (cr.iterations * REVS):.3f} | '
                f'{cpu / (cr.iterations * REVS) / n:.4f} | not run | not run | - |']
    t0 = time.process_time()
    twist_ref, lift_ref = _reference(spec, law, shifts)
    cpu_ref = time.process_time() - t0
    twist = np.stack([cr.twist[f'lobe_{i}'] for i in range(n)])
    err = float(np.max(np.abs(twist - twist_ref)) / np.max(np.abs(twist_ref)))
    N = twist.shape[1]
    lift_err = 0.0
    for i in range(n):
        run = cr.runs[f'lobe_{i}']
        k = np.rint((run.alpha - shifts[i]) / (2 * math.pi / N)).astype(int) % N
        gap = float(np.max(np.abs(run.lift - lift_ref[i][k])) / np.max(lift_ref[i]))
        lift_err = max(lift_err, gap)
    per_rev = cpu / (cr.iterations * REVS)
    return [f'| {n} | {cr.iterations} | {cpu:.2f} | {per_rev:.3f} | {per_rev / n:.4f} | '
            f'{err:.1e} | {lift_err:.1e} | {cpu_ref:.1f} |']


def _sweep(count: int) -> list[str]:
    from cam_design.train.run import train_from_valve_train
    from cam_metrology.dynamics.camshaft import run_speeds
    from cam_metrology.scene.parse import load_scene

    scene = load_scene(Path(__file__).resolve().parents[1] / 'config' /
                       'camshaft_i4_scene.yaml')
    speeds = np.linspace(500.0, 3000.0, count)
    t0 = time.process_time()
    runs, failures = run_speeds(scene, train_from_valve_train(scene.valve_train), speeds,
                                step_deg=STEP, cam_width=0.012, youngs=2.06e11,
                                max_revolutions=4, keys={})
    cpu = time.process_time() - t0
    conv = sum(r.converged for r in runs)
    its = np.array([r.iterations for r in runs])
    damped = sum(r.damped for r in runs)
    return [f'| {count} | {cpu:.0f} | {cpu / count:.2f} | {conv} of {len(runs)} | '
            f'{len(failures)} | {np.median(its):.0f} / {its.max()} | {damped} |']


def run() -> list[str]:
    rows = ['| trains | iterations | CPU of the coupled solve [s] | CPU per revolution [s] |'
            ' per train and revolution [s] | twist error / peak (vs LSODA) | '
            'lift error / peak | CPU of the LSODA reference [s] |',
            '|---|---|---|---|---|---|---|---|']
    for n in [int(x) for x in os.environ.get('CAMSHAFT_TRAINS', '1,8,16').split(',')]:
        rows += _trains(n)
        print(rows[-1], flush=True)
    count = int(os.environ.get('CAMSHAFT_SWEEP_SPEEDS', '100'))
    rows += ['', '| sweep speeds (example scene) | CPU [s] | CPU per speed [s] | '
             'converged | failed | coupling iterations median / max | damped fallback |',
             '|---|---|---|---|---|---|---|']
    rows += _sweep(count)
    print(rows[-1], flush=True)
    return rows


def main() -> None:
    """Run and write the results table."""
    report('Camshaft: coupled valve trains on a flexible shaft', __doc__, run(), RESULT)


if __name__ == '__main__':
    main()
