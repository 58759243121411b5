"""Per-speed figures of the coupled camshaft as JSON-ready data and a plot
(docs/camshaft.md): natural frequencies and order crossings, drive torque (mean, peak,
orders), friction loss and power, timing shift and twist per lobe."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cam_design.camshaft.coupled import ORDERS, CamshaftRun
from cam_design.camshaft.spec import CamshaftSpec
from cam_design.camshaft.torsion import assemble, natural_frequencies, order_crossings

#: order crossings are listed up to this multiple of the highest speed run
CROSSING_SPAN = 1.5


def camshaft_summary(spec: CamshaftSpec, runs: Sequence[CamshaftRun],
                     failures: dict[str, str] | None = None) -> dict[str, Any]:
    """``camshaft`` block of the dynamics JSON: per-speed arrays aligned with
    ``cam_speed_rpm`` (docs/contract.md)."""
    freqs = natural_frequencies(assemble(spec))
    top = max((r.rpm for r in runs), default=0.0)
    per = [r.summary() for r in runs]
    lobe_ids = list(runs[0].twist) if runs else []
    out: dict[str, Any] = {
        'natural_frequencies_hz': [float(f) for f in freqs],
        'order_crossings': order_crossings(freqs, ORDERS, CROSSING_SPAN * top),
        'drive': spec.drive.kind, 'phaser_deg': spec.drive.phaser_deg,
        'cam_speed_rpm': [p['cam_speed_rpm'] for p in per],
        'drive_torque_nm': {k: [p['drive_torque_nm'][k] for p in per]
                            for k in ('mean', 'peak', 'min', 'orders')},
        'friction_loss_j_per_rev': [p['friction_loss_j_per_rev'] for p in per],
        'friction_power_w': [p['friction_power_w'] for p in per],
        'converged': [p['converged'] for p in per],
        'iterations': [p['iterations'] for p in per],
        'lobes': {lid: {k: [p['lobes'][lid][k] for p in per]
                        for k in per[0]['lobes'][lid]} for lid in lobe_ids} if per else {},
    }
    if failures:
        out['failures'] = dict(failures)
    return out


def plot_camshaft(runs: Sequence[CamshaftRun], path: str | Path, title: str = '') -> Path:
    """Four panels: drive and friction torque against cam angle (each speed), twist at
    each lobe (highest speed), timing shift against speed, drive-torque orders."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(12, 8))
    deg = np.degrees(runs[0].alpha)
    for r in runs:
        ax[0, 0].plot(deg, r.drive, lw=1, label=f'{r.rpm:g} rpm')
        if np.any(r.friction):
            ax[0, 0].plot(deg, r.friction, lw=0.8, ls='--', label=f'friction {r.rpm:g} rpm')
    ax[0, 0].set(xlabel='cam angle [deg]', ylabel='torque at the sprocket [N m]',
                 title='drive torque')
    ax[0, 0].legend(fontsize=7)
    last = max(runs, key=lambda r: r.rpm)
    for lid, psi in last.twist.items():
        ax[0, 1].plot(deg, np.degrees(psi), lw=1, label=lid)
    ax[0, 1].set(xlabel='cam angle [deg]', ylabel='twist [deg]',
                 title=f'twist at each lobe, {last.rpm:g} rpm')
    ax[0, 1].legend(fontsize=7, ncol=2)
    rpm = [r.rpm for r in runs]
    for lid in last.twist:
        ax[1, 0].plot(rpm, [r.extras[lid]['timing_shift_deg'] for r in runs], 'o-', ms=3,
                      label=lid)
    ax[1, 0].set(xlabel='cam speed [rpm]', ylabel='timing shift at the nose [deg]',
                 title='timing shift (positive: earlier)')
    ax[1, 0].legend(fontsize=7, ncol=2)
    orders = np.arange(1, ORDERS + 1)
    width = 0.8 / len(runs)
    for i, r in enumerate(runs):
        amp = r.summary()['drive_torque_nm']['orders']
        ax[1, 1].bar(orders + (i - (len(runs) - 1) / 2) * width, amp, width=width,
                     label=f'{r.rpm:g} rpm')
    ax[1, 1].set(xlabel='order [per cam revolution]', ylabel='amplitude [N m]',
                 title='drive torque orders')
    ax[1, 1].legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
