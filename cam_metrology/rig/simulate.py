"""Synthetic rig runs (the bench simulator's rig mode): a valve train turned at a steady
speed with a speed ripple, seen through a quantised encoder and a noisy laser with an
arbitrary zero, sampled on a time clock.

The valve motion is the dynamics' periodic solution of the *true* valve train
(``rig.true_valve_train`` of the scene, never read by the analysis) at the mean speed,
driven by the equivalent law of the speed ripple (``ripple.RippleLaw``: the valve's
response to the ripple included) and read at each sample's uniform phase. The tests use
an independent time-domain solver instead (test/rig_reference.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cam_design.errors import InputError, require_positive
from cam_metrology.rig.model import predict
from cam_metrology.rig.runs import RigRun


@dataclass(frozen=True)
class RigNoise:
    """Imperfections of the simulated rig: ``laser_noise`` [m] rms per sample;
    ``encoder_counts`` per revolution (0: exact angle); ``ripple``: speed ripple
    amplitude as a fraction of the mean; ``ripple_order``: its cycles per revolution;
    ``laser_zero`` [m]: the laser reading of the seated valve; ``sample_rate`` [Hz];
    ``vibrometer``: also record the valve velocity [m/s] (noise 1000 * laser_noise
    m/s: 1 mm/s for 1 um)."""

    laser_noise: float = 1.0e-6
    encoder_counts: int = 3600
    ripple: float = 0.005
    ripple_order: int = 2
    laser_zero: float = 3.7e-3
    sample_rate: float = 50_000.0
    vibrometer: bool = False

    def __post_init__(self) -> None:
        require_positive('laser_noise', self.laser_noise, allow_zero=True)
        require_positive('sample_rate', self.sample_rate)
        if self.encoder_counts < 0 or int(self.encoder_counts) != self.encoder_counts:
            raise InputError('encoder_counts', self.encoder_counts, 'an integer >= 0')
        if not 0.0 <= self.ripple < 0.5:
            raise InputError('ripple', self.ripple, 'a fraction in [0, 0.5)')


def simulate_run(law: Any, vt: Any, rpm: float, *, nose: float, direction: int = 1,
                 revolutions: float = 4.0, noise: RigNoise = RigNoise(), seed: int = 0,
                 name: str | None = None, start_angle: float = 0.0) -> RigRun:
    """One rig run of ``revolutions`` at mean camshaft speed ``rpm`` of valve train
    ``vt`` driven by ``law`` whose nose is at encoder angle ``nose`` [rad]."""
    from cam_metrology.rig.ripple import RippleLaw

    rng = np.random.default_rng(seed)
    omega = rpm * math.pi / 30.0
    duration = revolutions * 2 * math.pi / omega
    n = int(duration * noise.sample_rate)
    if n < 10:
        raise InputError('revolutions', revolutions, 'a run of at least 10 samples')
    t = np.arange(n) / noise.sample_rate
    k = max(1, int(noise.ripple_order))
    phase = rng.uniform(0, 2 * math.pi)
    amp = noise.ripple / k
    theta = start_angle + omega * t + amp * (np.sin(k * omega * t + phase) - math.sin(phase))
    # uniform angle psi = psi0 + omega t; the ripple amp sin(k omega t + phase) as a
    # function of the uniform lobe phase alpha_u = direction (psi - nose)
    psi0 = start_angle - amp * math.sin(phase)
    alpha = direction * (psi0 + omega * t - nose)
    drive = law if amp == 0 else RippleLaw(law, direction, np.array([k]), np.zeros(1),
                                           np.array([amp]),
                                           np.array([k * (nose - psi0) + phase]))
    pred = predict(drive, vt, rpm)
    lift = pred.at(alpha) - float(np.min(pred.lift)) + noise.laser_zero
    lift = lift + rng.normal(0.0, noise.laser_noise, n) if noise.laser_noise else lift
    enc = np.mod(theta, 2 * math.pi)
    if noise.encoder_counts:
        q = 2 * math.pi / noise.encoder_counts
        enc = np.floor(enc / q) * q
    vel = None
    if noise.vibrometer:
        a0 = pred.alpha[0]
        aw = a0 + np.mod(alpha - a0, 2 * math.pi)
        slope = np.interp(aw, pred.alpha, pred.slope)
        vel = slope * direction * omega + rng.normal(0.0, 1e3 * noise.laser_noise, n)
    return RigRun(name=name or f'run_{rpm:g}rpm', time=t, angle=enc, lift=lift,
                  velocity=vel)


def true_train(scene: Any, spec: Any) -> tuple[Any, str | None]:
    """The simulator's valve train: ``rig.true_valve_train`` (validated), else the
    nominal one (with a note saying so)."""
    if spec.true_valve_train is None:
        return scene.valve_train, ('the scene has no rig.true_valve_train: the runs are '
                                   'simulated with the nominal valve_train')
    from cam_metrology.scene.parse import valve_train_from_mapping

    return valve_train_from_mapping(spec.true_valve_train, 'rig.true_valve_train'), None


def simulate_scene_runs(scene: Any, rpms: Any, *, revolutions: float = 4.0,
                        noise: RigNoise = RigNoise(), seed: int = 0
                        ) -> tuple[list[RigRun], str | None]:
    """Runs at every speed of ``rpms`` of a scene with a rig block (the nose at
    ``rig.nose_angle_deg``, 0 when absent), and a note for the reader or None."""
    from cam_design.valve_train.params import require_rpm
    from cam_metrology.rig.session import RigSetup

    setup = RigSetup.of_scene(scene)
    train, note = true_train(scene, setup.spec)
    nose = setup.spec.nose_angle if setup.spec.nose_angle is not None else 0.0
    runs = []
    for i, rpm in enumerate(rpms):
        rpm = require_rpm(f'--rpm[{i}]', rpm)
        runs.append(simulate_run(setup.law, train, rpm, nose=nose,
                                 direction=setup.direction, revolutions=revolutions,
                                 noise=noise, seed=seed + i, name=f'run_{rpm:g}rpm',
                                 start_angle=0.37 * (i + 1)))
    return runs, note


#: s between two runs on the time line of a simulated rig stream
RUN_GAP_S = 0.1


def stream_runs(runs: Any, start_ns: int = 1_000_000_000, gap_s: float = RUN_GAP_S
                ) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """Runs on one time line, as a rig streams them: (run name, encoder angle [rad],
    valve lift [m], stamp [ns] int64) per run, each run ``gap_s`` after the previous."""
    out = []
    t0 = int(start_ns)
    for r in runs:
        stamps = t0 + np.round(np.asarray(r.time) * 1e9).astype(np.int64)
        out.append((r.name, np.asarray(r.angle, dtype=float),
                    np.asarray(r.lift, dtype=float), stamps))
        t0 = int(stamps[-1]) + int(round(gap_s * 1e9))
    return out


#: the rig mode of the bench simulator (``cam-bench run bench-sim -p mode:=rig``):
#: ROS parameter -> (default, description); the noise ones are RigNoise's fields
RIG_SIM_PARAMETERS: dict[str, tuple[Any, str]] = {
    'rig_rpm': ([905.0, 1310.0, 1705.0, 2110.0],
                'rig mode: mean camshaft speed [rpm] of each run (one run per speed)'),
    'rig_revolutions': (2.5, 'rig mode: camshaft revolutions per run'),
    'rig_seed': (0, 'rig mode: random seed of the noise and the ripple phases'),
    'rig_sample_rate': (20_000.0, 'rig mode: samples/s on the time clock (and live)'),
    'rig_laser_noise': (1.0e-6, 'rig mode: laser noise [m] rms per sample'),
    'rig_encoder_counts': (3600, 'rig mode: encoder counts per revolution (0: exact angle)'),
    'rig_ripple': (0.005, 'rig mode: speed ripple amplitude, fraction of the mean speed'),
    'rig_ripple_order': (2, 'rig mode: speed ripple cycles per revolution'),
    'rig_laser_zero': (3.7e-3, 'rig mode: laser reading [m] of the seated valve'),
}


def rig_sim_runs(scene: Any, values: dict[str, Any]) -> tuple[list[RigRun], str | None, dict]:
    """The runs of the bench simulator's rig mode from its parameter ``values``
    (``RIG_SIM_PARAMETERS``): (runs, note or None, truth dict for /bench/truth)."""
    noise = RigNoise(laser_noise=float(values['rig_laser_noise']),
                     encoder_counts=int(values['rig_encoder_counts']),
                     ripple=float(values['rig_ripple']),
                     ripple_order=int(values['rig_ripple_order']),
                     laser_zero=float(values['rig_laser_zero']),
                     sample_rate=float(values['rig_sample_rate']))
    rpms = [float(v) for v in values['rig_rpm']]
    runs, note = simulate_scene_runs(scene, rpms, revolutions=float(values['rig_revolutions']),
                                     noise=noise, seed=int(values['rig_seed']))
    from dataclasses import asdict

    from cam_metrology.rig.session import RigSetup

    spec = RigSetup.of_scene(scene).spec
    truth = {'rig': {'runs': [r.name for r in runs], 'rpm': rpms, 'noise': asdict(noise),
                     'true_valve_train': dict(spec.true_valve_train or {}) or None,
                     'note': note}}
    return runs, note, truth
