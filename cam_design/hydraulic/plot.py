"""Pressure plot of hydraulic valve-gear runs (matplotlib, Agg)."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


def plot_pressures(runs: Sequence[Any], title: str = '') -> Any:
    """Figure: valve lift [mm] and pump / actuator pressure [bar gauge] over cam angle
    [deg], one colour per speed (``runs``: HydraulicRun). The caller saves it."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    for k, run in enumerate(runs):
        colour = f'C{k % 10}'
        a = np.degrees(run.alpha)
        ax1.plot(a, run.lift * 1e3, color=colour, label=f'{run.rpm:g} rpm')
        ax2.plot(a, run.pump_pressure * 1e-5, color=colour, label=f'pump {run.rpm:g} rpm')
        ax2.plot(a, run.actuator_pressure * 1e-5, color=colour, linestyle='--',
                 label=f'actuator {run.rpm:g} rpm')
    ax1.set_ylabel('valve lift [mm]')
    ax2.set_ylabel('pressure [bar, gauge]')
    ax2.set_xlabel('cam angle alpha [deg]')
    ax1.legend(loc='upper right', fontsize='small')
    ax2.legend(loc='upper right', fontsize='small')
    if title:
        ax1.set_title(title)
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
